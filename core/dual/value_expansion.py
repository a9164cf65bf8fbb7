"""MVE-DDPG: model-based value expansion, fixed horizon, one global latent model (Section 4.1.2; [28]).

Our reading of Feinberg et al.'s MVE in this architecture: the critic's Eq. 1 target bootstraps not
from Q′(φ′, μ′(φ′)) directly but after H imagined steps of the global latent model M, R under the
target actor:

    φ̂_0 = f′(s_{t+1}),  â_h = μ′(φ̂_h),  r̂_h = R(φ̂_h, â_h),  φ̂_{h+1} = M(φ̂_h, â_h),
    y_t = r_t + γ (1 − terminated_t) [ Σ_{h<H} γ^h r̂_h + γ^H Q′(φ̂_H, μ′(φ̂_H)) ].

H = 0 is plain DDPG. The model's reward head predicts the extrinsic reward; imagined steps are never
terminal (the model has no termination head). The model itself is trained on every learner
minibatch (Eq. 5 on the online encoder's φ, φ′ of the sampled real transitions, see
`core.dual.agents.ValueExpansionAgent`). Simplification, documented: MVE's "TD-k trick" (also fitting
Q on the imagined states) is not applied — only the target is expanded.
"""

from __future__ import annotations

import torch

from core.config import AgentConfig, NetConfig
from core.dual.model_bank import ModelBank
from core.envs.spec import EnvSpec
from core.modelfree.actor_critic import ActorCritic


class ValueExpansionActorCritic(ActorCritic):
    """`ActorCritic` whose TD target is the H-step model-based value expansion above."""

    def __init__(
        self,
        net: NetConfig,
        agent: AgentConfig,
        spec: EnvSpec,
        model: ModelBank,
        horizon: int,
    ) -> None:
        super().__init__(net, agent, spec)
        if horizon < 0:
            raise ValueError(f"value-expansion horizon must be >= 0, got {horizon}")
        self.model = model
        self.horizon = horizon

    @torch.no_grad()
    def td_target(self, reward: torch.Tensor, next_latent_target: torch.Tensor,
                  terminated: torch.Tensor) -> torch.Tensor:
        gamma = self.agent_config.gamma
        phi = next_latent_target
        nodes = torch.zeros(phi.shape[0], dtype=torch.int64)
        expanded = torch.zeros_like(reward)
        discount = 1.0
        for _ in range(self.horizon):
            prediction = self.model.predict(nodes, phi, self.target_actor(phi))
            expanded = expanded + discount * prediction.reward
            discount *= gamma
            phi = prediction.next_latent
        tail = self.target_critic(phi, self.target_actor(phi))
        return reward + gamma * (1.0 - terminated) * (expanded + discount * tail)
