"""The learners every agent holds (``agent.ac``): DDPG and CACLA (the paper's, ``ddpg.py``), TD3, SAC.

``make_learner(net, agent, spec)`` builds the one ``agent.ac`` names. What they share — the
critic-autoencoder, the target networks, the pixel update and the imagination update of Algorithm 3 — is
``base.py``.
"""

from __future__ import annotations

from core.config import AgentConfig, NetConfig
from core.envs.spec import EnvSpec
from core.modelfree.learners.base import Learner
from core.modelfree.learners.ddpg import CACLA, DDPG
from core.modelfree.learners.sac import SAC
from core.modelfree.learners.td3 import TD3

LEARNERS: dict[str, type[Learner]] = {"ddpg": DDPG, "cacla": CACLA, "td3": TD3, "sac": SAC}
"""The learners by ``agent.ac`` name."""


def make_learner(net: NetConfig, agent: AgentConfig, spec: EnvSpec) -> Learner:
    """The learner ``agent.ac`` names, built for ``spec``'s observations and actions."""
    if agent.ac not in LEARNERS:
        raise ValueError(f"unknown learner {agent.ac!r} (choose from {', '.join(LEARNERS)})")
    return LEARNERS[agent.ac](net, agent, spec)


__all__ = ["LEARNERS", "Learner", "make_learner"]
