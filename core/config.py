"""Typed run configuration: one place for every hyper-parameter default, with named profiles.

A run is fully described by a :class:`Config` (sections ``run``, ``env``, ``net``, ``agent``, ``dual``).
Defaults live only here. Three profiles exist (see ``docs/config.md`` for the value-by-value sources):

* ``default`` — tuned to learn fast per wall-clock second on a 2-core laptop CPU (strided encoder,
  per-step updates, annealed exploration noise, τ = 0.005).
* ``paper``  — every value stated in Section 4.1.1 of the paper; where the text is silent or
  ambiguous, the authors' released code (stride-1 16→8→4 convolutions, one update per episode with
  5 critic passes / 15 CACLA passes over a 256-sample minibatch, N(0, 1) noise, τ = 1e-6).

* ``vector`` — the default for tasks with vector observations: the textbook networks (no learned encoder,
  MLP actor and critics) and settings under which every learner learns Pendulum-v1 in 20k steps.

``load_config(profile, overrides, file)`` applies, in order: the profile, then a YAML/JSON file, then
``key=value`` overrides. Unknown keys raise :class:`ConfigError` naming the key; values are coerced to
the field's declared type (``"64"`` → 64, ``"true"`` → True, ``"none"`` → None) and checked against
``Literal`` choices.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import yaml

from core.task_levels import LEVELS


class ConfigError(ValueError):
    """A user-caused configuration error (unknown key, bad value, unreadable file)."""


@dataclass
class RunConfig:
    """What to run and for how long."""

    algo: str = "ddpg"
    """Method name, looked up in ``core.runs.methods.ALGOS`` (ddpg, cacla, and the dual-system methods)."""
    seed: int = 0
    """Seed of the run's one generator family (NumPy, torch, PyBullet resets)."""
    episodes: int | None = 3000
    """Training episodes; the run stops at whichever of episodes/steps/max_wall_s comes first."""
    steps: int | None = None
    """Training environment steps (None: no step limit)."""
    max_wall_s: float | None = None
    """Wall-clock budget in seconds for training (None: none). Checked between episodes."""
    eval_every: int = 200
    """Greedy evaluation every N training episodes (0: only the final evaluation)."""
    eval_episodes: int = 25
    """Episodes per greedy evaluation (the paper's real-robot protocol uses 25)."""
    final_eval: bool = True
    """Run one greedy evaluation when training ends normally (gives summary.json its success_rate)."""
    checkpoint_every: int = 1000
    """Write checkpoints/latest.pt (+ the replay buffer) every N episodes and at the end or on a stop.
    Saving the buffer costs ~0.8 s per 25k transitions, and a learned grasp takes 2-3 steps, so a small N
    would spend a fifth of the run writing checkpoints."""
    checkpoint_every_s: float | None = 60.0
    """Also write checkpoints/latest.pt when this many seconds have passed since the last one (checked at
    episode ends; None: by episode only), so an interrupted run loses at most about this much training."""
    device: str = "cpu"
    """torch device for the networks."""
    num_threads: int = 1
    """torch intra-op threads. 1: the batch-64 convolutions are too small to split, and on the shared
    2-core machine a second thread waiting at OpenMP barriers made updates 3-8× slower
    (docs/model-free.md)."""
    smoothing_window: int = 250
    """Sliding window (episodes) of the learning-curve PNG (Fig. 8: 250 dense, 375 sparse)."""
    tensorboard: bool = False
    """Also write TensorBoard event files into the run directory, named as metrics.csv's columns."""
    cpu_isa: Literal["native", "avx2", "sse42"] = "native"
    """Instruction set of the CPU kernels (torch/ATen, MKL, oneDNN, NumPy, OpenBLAS), pinned in the run's
    process environment so that the run reproduces bit for bit on any x86-64 machine that has it: native
    (the CPU's own; across machines reproduction is statistical), avx2 (x86-64-v3), sse42 (x86-64-v2)
    (core.runs.cpu_isa, docs/experiments.md "Portable runs")."""


NICO_GRASP_ID = "dualsys/NicoGrasp-v0"
"""The gymnasium id of the paper's task (registered by ``core.envs``); the default environment."""


@dataclass
class EnvConfig:
    """The environment: any gymnasium id (``id``, ``kwargs``); the other fields are NicoGrasp's keyword
    arguments and apply only when ``id`` is NicoGrasp (see docs/environment.md)."""

    id: str = NICO_GRASP_ID
    """Gymnasium id of the task: NicoGrasp (default), or any registered id of an installed package, e.g.
    MountainCarContinuous-v0, Pendulum-v1, dm_control/cartpole-swingup_sparse-v0 (the ``dmc`` extra)."""
    kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of ``gymnasium.make(id, ...)`` for a task other than NicoGrasp (a YAML/JSON
    mapping)."""
    success: Literal["info", "terminated"] = "info"
    """What counts as a successful episode: info: the env's ``info["success"]`` (or ``is_success``) at the
    episode's end (NicoGrasp's grasp); terminated: the episode terminated before truncation (the goal of
    MountainCar, whose only termination is reaching it)."""
    reward_offset: float = 0.0
    """A constant added to every step's reward of a task other than NicoGrasp, in training and evaluation
    alike (0: the task's own reward). A control, not a tuning knob: it asks what a cost per step alone does
    (docs/results.md, grid 5: DDPG with −0.015 per step on MountainCar)."""
    level: Literal["released", "paper", "hard", "seen"] = "released"
    """Task level (core/task_levels.py; calibrated in docs/environment.md): released, paper, hard or seen."""
    reward_mode: Literal["dense", "sparse"] = "dense"
    """Extrinsic reward of Section 4.1.2: dense shaping or 0 outside grasp/topple."""
    hand: Literal["auto", "learned"] | None = None
    """auto: 1-D shoulder action, grasp starts automatically (released code); learned: 2-D action.
    None: the level's hand (released: auto; paper, hard: learned), resolved when the config is loaded."""
    dense_shaping: Literal["distance", "squared"] = "distance"
    """−d (paper text) or −d² (released code)."""
    fixed_positions: int | None = None
    """None: new random graspable glass position every reset (paper text); N: N seeded positions cycled."""
    max_steps: int = 50
    """Episode length limit (truncation)."""
    domain: Literal["sim", "real"] = "sim"
    """Which camera renders observations."""

    @property
    def reward_label(self) -> str:
        """The reward's name in summaries and cell folders: NicoGrasp's mode, or ``task`` (the env's own)."""
        return self.reward_mode if self.id == NICO_GRASP_ID else "task"


@dataclass
class NetConfig:
    """Encoder f_ω, decoder g, critic Q(φ, a) and actor μ(φ) of Fig. 1."""

    arch: Literal["paper", "strided"] = "strided"
    """paper: stride-1 3×3 convs (released code's 16→8→4, dense to φ); strided: stride-2 3×3 convs,
    about 30× fewer multiply-adds per image, which is what lets per-step updates run on a laptop CPU."""
    conv_channels: tuple[int, ...] = (16, 32, 32)
    """Encoder conv channels (decoder mirrors them)."""
    latent_dim: int = 32
    """Size of the latent φ (Fig. 1: 32)."""
    critic_hidden: int = 20
    """Critic head hidden units (concat(φ, a) → hidden ReLU → 1)."""
    actor_hidden: int = 20
    """Actor hidden units (φ → hidden → tanh action)."""
    actor_activation: Literal["relu", "tanh"] = "relu"
    """Actor hidden activation: relu (paper text: ReLU everywhere but outputs) or tanh (released code)."""
    mlp_hidden: tuple[int, ...] = (64, 64)
    """Hidden layers of the encoder f_ω (and, mirrored, the decoder) for vector observations: an MLP with
    ReLU to the latent φ, in place of the convolutions (which images get). With ``encoder = none``, the hidden
    layers of the actor and of each critic instead (SB3: 256, 256 for SAC and TD3, 400, 300 for DDPG)."""
    encoder: Literal["learned", "none"] = "learned"
    """learned: the critic-autoencoder f_ω of Fig. 1 (Eq. 4) before the paper's one-layer heads; none (vector
    observations only): actor and critic are MLPs (``mlp_hidden``) on the scaled observation itself, the
    textbook networks of SB3 and CleanRL (docs/model-free.md, "Learners")."""
    latent_activation: Literal["auto", "relu", "layernorm_tanh"] = "auto"
    """The encoder's last activation: relu (Fig. 1) or LayerNorm + tanh (SAC-AE's bounded latent); auto: relu
    for ddpg/cacla, layernorm_tanh for td3/sac."""
    observation_scaling: Literal["bounds", "none"] = "bounds"
    """Vector observations only. bounds: each dimension with finite bounds is mapped to [-1, 1] before the
    encoder (or, with ``encoder = none``, before the MLP heads); none: the raw observation, as SB3 and CleanRL
    feed it (the parity checks against SB3 set it). Images are always uint8 / 255."""
    sac_log_prob: Literal["exact", "sb3"] = "exact"
    """SAC only: the arithmetic of log π(a | φ) = log N(u; m, σ) − Σ log(1 − tanh(u)²) (Haarnoja et al. 2018,
    Eq. 21). exact: the Gaussian term from the drawn ε (−ε²/2 − log σ − log √2π) and the correction as
    2 (log 2 − u − softplus(−2u)); sb3: Stable-Baselines3's (and the SAC authors') arithmetic,
    ``Normal(m, σ).log_prob(u)`` − Σ log(1 − tanh(u)² + 10⁻⁶). The two are the same function; sb3's loses
    precision in u − m when σ is small (10⁻³ nats at log σ ∈ [−8, −3]) and floors the correction, so runs on
    the same draws part within a few hundred updates. sb3 exists for the step-by-step parity test against SB3
    (docs/model-free.md, "Learners")."""


@dataclass
class AgentConfig:
    """The model-free learner: critic-autoencoder (Eq. 4, Eq. 1) and actor update (Eq. 2 or Eq. 3)."""

    ac: Literal["ddpg", "cacla", "td3", "sac"] = "ddpg"
    """The learner (core/modelfree/learners): DDPG (Eq. 2), off-policy CACLA (Eq. 3), TD3 (Fujimoto et al.
    2018) or SAC (Haarnoja et al. 2018, learned temperature). Set from --algo for the model-free methods."""
    gamma: float = 0.99
    """Discount factor γ of Eq. 1."""
    tau: float = 0.005
    """Target-network update rate τ (θ' ← τθ + (1−τ)θ')."""
    critic_lr: float = 1e-3
    """Adam learning rate of the critic-autoencoder (encoder, decoder, critic head)."""
    actor_lr: float = 1e-4
    """Adam learning rate of the actor."""
    lambda_rec: float = 0.1
    """λ_rec of Eq. 4."""
    lambda_q: float = 1.0
    """λ_Q of Eq. 4."""
    batch_size: int = 64
    """Minibatch size sampled from the pixel replay buffer."""
    buffer_size: int = 100_000
    """Capacity of the replay of real transitions, for every method: B of Alg. 2, B_pixel of Alg. 3 (the paper
    gives I2A's B_pixel 60k beside the others' 100k; the two differ only once a run has 60k real steps)."""
    learning_starts: int = 500
    """Environment steps collected before the first update."""
    update_schedule: Literal["per_step", "per_episode"] = "per_step"
    """per_step: Algorithm 2 lines 26-28 after every env step; per_episode: the released code."""
    updates_per_step: int = 1
    """Minibatch updates after each env step (per_step schedule)."""
    updates_per_episode: int = 1
    """Minibatch updates after each episode (per_episode schedule)."""
    critic_passes: int = 1
    """Gradient steps of Eq. 4 on one minibatch (released code: 5)."""
    ddpg_actor_passes: int = 1
    """DDPG policy-gradient steps on one minibatch (released code: 5)."""
    cacla_actor_passes: int = 1
    """CACLA regression steps over the minibatch's δ > 0 samples (released code: 15)."""
    noise_std: float = 0.5
    """Initial std of the Gaussian exploration noise added to the action (paper: N(0, 1))."""
    noise_final_std: float = 0.1
    """Std after annealing (equal to noise_std: no annealing)."""
    noise_anneal_steps: int = 30_000
    """Environment steps over which the std decays linearly to noise_final_std."""
    noise: Literal["gaussian", "ou", "pink"] = "gaussian"
    """DDPG/TD3/CACLA exploration noise: i.i.d. Gaussian, Ornstein-Uhlenbeck (θ = ``noise_theta``, dt =
    0.01, σ = the annealed std; reset every episode; SB3's OrnsteinUhlenbeckActionNoise), or pink
    (``pink-noise-rl``'s PinkNoiseProcess times the annealed std; a new sequence every episode). SAC samples
    π: with ``pink``, its ε of acting comes from the pink process (docs/model-free.md, "Pink noise")."""
    noise_theta: float = 0.15
    """θ of the Ornstein-Uhlenbeck noise (SB3's default)."""
    noise_seq_len: int | None = None
    """Pink noise: the length of each noise sequence; None: the env's step limit (the episode length)."""
    warmup: Literal["policy", "uniform"] = "policy"
    """Actions before ``learning_starts``: the policy with its exploration (paper) or uniform random (SB3)."""
    policy_delay: int = 2
    """TD3: actor and target updates every this many critic updates."""
    target_noise: float = 0.2
    """TD3: std of the target-policy smoothing noise, in the normalised action units [-1, 1]."""
    target_noise_clip: float = 0.5
    """TD3: the smoothing noise is clipped to ±this."""
    alpha_init: float = 1.0
    """SAC: initial temperature α (SB3's ``ent_coef='auto'`` starts at 1)."""
    target_entropy: float | None = None
    """SAC: the entropy α drives the policy toward; None: −dim(A)."""
    encoder_tau: float | None = None
    """τ of the target encoder (SAC-AE: 0.05 against the critic's 0.01); None: ``tau``."""
    rnd_scale: float = 0.5
    """``--algo rnd`` only: weight of the normalised RND bonus against the extrinsic reward (Burda et al.
    2018 weigh extrinsic 2 : intrinsic 1; here extrinsic 1 : intrinsic 0.5)."""
    rnd_lr: float = 1e-4
    """``--algo rnd`` only: Adam learning rate of the RND predictor (Burda et al. 2018)."""
    rnd_dim: int = 64
    """``--algo rnd`` only: output size of the random target and the predictor networks."""
    sb3_hyperparams: Literal["dualsys", "zoo"] = "dualsys"
    """SB3 peers only: dualsys (SB3 defaults on our budget) or zoo (RL Baselines3 Zoo's entry for env.id)."""


@dataclass
class DualConfig:
    """Dual-system section (ITM, learning progress, world-model bank, meta-controller, imagination).

    Used by the dual-system methods (im2c, i2a, mve, cmc, la-imagination); plain ddpg/cacla ignore it.
    Each mechanism has one field naming its reading (`core.dual.readings`): ``paper`` (the literal text),
    ``released`` (the authors' released code, where it differs) or ``repaired`` (docs/dual-system.md,
    "Mechanisms"). The defaults are the ``default`` profile: every mechanism repaired. The ``paper`` profile
    (``_paper_dual``) reads the text, and the released code where the text is silent.
    """

    regions: Literal["paper", "released", "repaired"] = "repaired"
    """ITM regions (Section 2.3.1): paper — the raw latent, squared L2 compared with e_max (the text);
    released — the raw latent, L2; repaired — the latent divided by its running RMS spread, L2."""
    e_max: float = 1.0
    """ITM mapping resolution e_max (Section 4.1.1: 6 in latent units); in units of the latent's RMS spread
    with ``regions = repaired`` (default 1)."""
    region_prune_after: int = 3000
    """Remove an ITM node that has not been the best match for this many states (0: never, paper)."""
    e_max_relative: float | None = None
    """Scale-free e_max (dual/itm_resolution.py): when set to ρ, e_max = ρ · the median pairwise L2 distance
    among 256 of the last 2048 latents, refreshed every 256 states; None: absolute e_max (paper, released).
    It is the raw latent's scale-free resolution (the first study's ablation), so it needs ``regions`` paper
    or released: with ``repaired`` (a normalised map) it is refused (`check_dual_combinations`)."""
    reliability: Literal["paper", "released", "repaired"] = "repaired"
    """Arbitration's reliability and Eq. 8-9 (Section 2.3.2): paper — LP ≥ 0 of squared errors, unnormalised,
    a new node unreliable until W+1 means exist; released — LP ≥ 0 of error norms, LP divided by the max
    mean, the oldest mean 0 at first; repaired — the held-out error and progress verdict (error norms)."""
    lp_sigma: int = 40
    """σ: window of recent prediction errors per node (Eq. 8)."""
    lp_window: int = 20
    """W: history of window means used by LP (Eq. 9)."""
    intrinsic: Literal["paper", "paper_centred", "repaired"] = "repaired"
    """r_int (Alg. 2 line 22): paper (also the released code) — −c·LP of the region the transition started
    in; paper_centred — the same minus its mean over the live regions (a control: its state dependence
    alone); repaired — +c·held-out progress / the latent's spread, of the region the action led into."""
    intrinsic_scale: float = 0.1
    """Scale c of r_int (paper: 1, the ``paper`` profile). Default 0.1: at 1 with the paper's signal the
    summed r_int of an episode outweighs the ±1 terminal reward and the agent lingers (docs/dual-system)."""
    world_models: Literal["paper", "released", "repaired"] = "repaired"
    """Local models M_n, R_n (Eq. 5): paper — raw latent in and out, φ̂′ itself, linear heads (Section
    4.1.1), a fresh model per new node; released — as paper with a sigmoid latent and tanh reward head;
    repaired — φ / s in, the change in units of s out, linear, a new node copies its parent's model."""
    model_hidden: int = 20
    """Hidden tanh units of each local world model M_n, R_n."""
    model_lr: float = 1e-3
    """Adam learning rate of the local models."""
    model_batch: int = 16
    """Samples per local-model update: the new transition and the node's recent ones (paper, released: 1)."""
    model_memory: int = 256
    """Real transitions kept per node; each update samples ``model_batch − 1`` of them (0: the newest). Must
    be 0 or at least ``model_batch − 1``, and 0 with ``model_batch = 1`` (`check_dual_combinations`)."""
    refit_every: int = 25
    """Refit the local models every N real steps on ``refit_batch`` replayed transitions re-encoded by the
    current encoder, each to its nearest node (core/dual/world_models.py ``refit``). 0: never (paper)."""
    refit_batch: int = 256
    """Transitions per refit step (one Eq. 5 Adam step of each node the batch touches)."""
    arbitration: Literal["lp", "model_free"] = "lp"
    """Meta-controller: reliability-based arbitration (Alg. 2 lines 12-19, by ``reliability``), or
    ``model_free`` — an ablation that always acts with μ(φ) (no MPC), keeping regions, local models and r_int.
    Refused with ``--algo i2a`` (`check_dual_combinations`): I2A without its planner is no method of the
    paper."""
    planner: Literal["paper", "released", "repaired", "progress", "novelty", "disagreement", "babbling",
                     "value"] = "repaired"
    """Gradient MPC (Eq. 6-7): paper — (R* − Σ r̂)², plain gradient steps, only the executed action clipped;
    released — ½ Σ (1 − r̂)² otherwise as paper; repaired — (R* − Σ r̂)², the gradient scaled to length
    ``plan_lr``, every plan action clipped after every step; progress — maximise the predicted return plus
    ``intrinsic_scale`` × the learning progress of the regions the plan reaches (issue 50), steps and clip as
    repaired; novelty — the same with prediction error in place of progress (the ablation); disagreement — the
    same with the variance of an ensemble of region models (Plan2Explore's objective). Each of the three
    babbles a fifth of its goals past the map's edge (core/dual/goal_babbling.py); babbling — the progress
    planner with its own goal removed, its babbled goals kept (the ablation that credits progress or not).
    These four add the learner's value at the plan's end, γ^H V(φ̂_H), to the predicted return (item 23);
    value — the predicted return and that value alone, no aim (the progress term's ablation)."""
    d_max: int = 6
    """Maximum planning depth D_max (Algorithm 1)."""
    plan_steps: int = 10
    """K gradient steps of plan optimisation (Eq. 7)."""
    plan_lr: float = 0.1
    """α_plan of Eq. 7 (paper: 1e-3); with ``planner = repaired`` a step length in action units."""
    r_star: float = 1.0
    """Desired return R* of Eq. 6."""
    imagination: Literal["paper", "repaired", "repaired_no_termination"] = "repaired"
    """I2A's imagined transitions (Alg. 3): paper — the act-time rollout stored in B_latent (line 17), every
    transition kept, no termination head; repaired — rollouts from the pixel minibatch's states, encoded by
    the current encoder, made at each update and never stored, gated by the node's held-out error over the
    no-change error, ``done`` from a termination head on each local model (BCE on the real ``terminated``);
    repaired_no_termination — repaired without the head (what the literal IM2C of mountaincar-repairs ran)."""
    imagination_depth: int | None = None
    """Most model steps of one learn-time imagined rollout (``imagination = repaired``; the act-time rollouts
    of ``paper`` are the planner's and keep D_max). None: D_max, the depth of Alg. 1, as before this option.
    1: every imagined transition starts at a real minibatch state, so only its next state is the model's
    (MBPO's short rollouts, Janner et al. 2019); a candidate repair of the critic divergence SAC+I2A showed
    on reacher-hard (docs/results.md, grid 4)."""
    imagination_max_ratio: float = 0.5
    """The gate keeps a transition with probability clip(1 − ratio / this, 0, 1): none from a node whose
    held-out error is at or above this fraction of the no-change error (1: the gate as first built; 0.5 chosen
    on MountainCar tuning seeds 100-102, docs/dual-system.md "Imagination in the loop")."""
    latent_buffer_size: int = 200_000
    """I2A latent replay capacity B_latent."""
    latent_batch_size: int = 64
    """Minibatch size sampled from B_latent (learn-time imagination: the most imagined rows per update)."""
    fixed_horizon: int = 2
    """MVE-DDPG's fixed value-expansion horizon H (Section 4.1.2: 2)."""
    cmc_horizon: int = 3
    """DDPG+CMC's fixed MPC horizon H (Section 4.1.2: 3)."""
    imagination_prob_scale: float = 1.0
    """LA-Imagination: scale of the rollout probability (inversely proportional to local error)."""


OLD_DUAL_SWITCHES: dict[str, tuple[str, str]] = {
    "region_space": ("regions", "space"),
    "itm_distance": ("regions", "distance"),
    "model_space": ("world_models", "space"),
    "model_target": ("world_models", "target"),
    "model_output": ("world_models", "output"),
    "new_node_model": ("world_models", "new_node"),
    "reliability": ("reliability", "signal"),
    "error_norm": ("reliability", "error_norm"),
    "lp_normalise": ("reliability", "lp_normalise"),
    "lp_warmup": ("reliability", "lp_warmup"),
    "intrinsic_signal": ("intrinsic", "signal"),
    "intrinsic_region": ("intrinsic", "region"),
    "plan_objective": ("planner", "objective"),
    "plan_optimiser": ("planner", "optimiser"),
    "plan_clip": ("planner", "clip"),
    "imagination_source": ("imagination", "source"),
    "imagination_gate": ("imagination", "gate"),
    "model_termination": ("imagination", "termination"),
}
"""The dual switches that became one reading per mechanism (`core.dual.readings`): old key → (the field
naming the mechanism's reading, the reading's attribute that holds the old value). ``dual.reliability`` kept
its name with new values (lp/heldout → paper, released/repaired)."""

OLD_DUAL_CONSTANTS: dict[str, str] = {
    "heldout_size": "size",
    "heldout_every": "every",
    "reliability_lag": "lag",
    "reliability_z": "z",
    "accurate_ratio": "accurate_ratio",
}
"""The held-out reliability's old keys, now the constants of `core.dual.readings.HeldOut`: old key → its
attribute there."""

OLD_DUAL_REJECTED: dict[str, Any] = {"imagination_reward": "model", "imagination_actor": "all"}
"""Old keys of readings tried and rejected (docs/dual-system.md, "What was tried"): old key → the one value
that remains (what every reading does)."""


def _removed_key_hint(name: str) -> str | None:
    """What replaced the removed ``dual.<name>`` (the hint of `set_value`'s ``unknown config key``)."""
    if name in OLD_DUAL_SWITCHES:
        return f"now dual.{OLD_DUAL_SWITCHES[name][0]}, a reading of core/dual/readings.py"
    if name in OLD_DUAL_CONSTANTS:
        return "now a constant of the held-out reliability, core/dual/readings.py HeldOut"
    if name in OLD_DUAL_REJECTED:
        return "removed: a rejected reading, docs/dual-system.md"
    return None


@dataclass
class Config:
    """A full run configuration. ``to_dict``/``from_dict`` round-trip through plain JSON types."""

    run: RunConfig = field(default_factory=RunConfig)
    env: EnvConfig = field(default_factory=EnvConfig)
    net: NetConfig = field(default_factory=NetConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    dual: DualConfig = field(default_factory=DualConfig)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict (tuples become lists) suitable for YAML/JSON."""
        out: dict[str, dict[str, Any]] = {}
        for section in dataclasses.fields(self):
            values = dataclasses.asdict(getattr(self, section.name))
            out[section.name] = {k: list(v) if isinstance(v, tuple) else v for k, v in values.items()}
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base: Config | None = None) -> Config:
        """Build a config from a (possibly partial) nested dict on top of ``base`` (default: defaults)."""
        config = _deep_copy(base) if base is not None else cls()
        _apply_mapping(config, data)
        return config

    def to_yaml(self) -> str:
        """The resolved config as YAML text (what a run writes as config.yaml)."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False)


def _deep_copy(config: Config) -> Config:
    return copy.deepcopy(config)


def _paper_profile() -> Config:
    """Section 4.1.1 values; the released code where the text is silent (see docs/config.md)."""
    return Config(
        run=RunConfig(episodes=10_000, eval_every=250, checkpoint_every=250),
        env=EnvConfig(
            level="paper", hand="learned", dense_shaping="distance", fixed_positions=None, max_steps=50
        ),
        net=NetConfig(
            arch="paper",
            conv_channels=(16, 8, 4),
            latent_dim=32,
            critic_hidden=20,
            actor_hidden=20,
            actor_activation="relu",
        ),
        agent=AgentConfig(
            gamma=0.99,
            tau=1e-6,
            critic_lr=1e-3,
            actor_lr=1e-4,
            lambda_rec=0.1,
            lambda_q=1.0,
            batch_size=256,
            buffer_size=100_000,
            learning_starts=256,
            update_schedule="per_episode",
            updates_per_episode=1,
            critic_passes=5,
            ddpg_actor_passes=5,
            cacla_actor_passes=15,
            noise_std=1.0,
            noise_final_std=1.0,
            noise_anneal_steps=1,
        ),
        dual=_paper_dual(),
    )


def _paper_dual() -> DualConfig:
    """The dual section read literally: the paper's text, the released code where the text is silent (the
    regions' L2 distance, the error norms and LP's normalisation), every repair of docs/dual-system.md
    ("Mechanisms") off."""
    return DualConfig(
        regions="released",
        e_max=6.0,
        region_prune_after=0,
        reliability="released",
        intrinsic="paper",
        intrinsic_scale=1.0,
        world_models="paper",
        model_batch=1,
        model_memory=0,
        refit_every=0,
        planner="paper",
        plan_lr=1e-3,
        imagination="paper",
    )



def _vector_profile() -> Config:
    """The default profile for tasks with vector observations (``dualsys train --profile auto`` picks it for
    them): the textbook networks and settings under which every learner learns Pendulum-v1 in 20k steps
    (docs/model-free.md, "Learners"). Only the ``net`` and ``agent`` keys below differ from ``default``:
    no learned encoder, 256-256 MLPs (SB3's SAC), batch 256, one learning rate of 1e-3 (RL Zoo's for DDPG, TD3
    and SAC on Pendulum), 1000 uniform warm-up steps and a constant exploration noise of 0.1 (the TD3
    paper's)."""
    config = Config()
    config.net.encoder = "none"
    config.net.mlp_hidden = (256, 256)
    agent = config.agent
    agent.batch_size = 256
    agent.critic_lr = agent.actor_lr = 1e-3
    agent.learning_starts = 1000
    agent.warmup = "uniform"
    agent.noise_std = agent.noise_final_std = 0.1
    return config


PROFILES: dict[str, typing.Callable[[], Config]] = {
    "default": Config,
    "paper": _paper_profile,
    "vector": _vector_profile,
}
"""Named profiles: a zero-argument factory per name (each call returns a fresh Config)."""


def load_config(
    profile: str = "default",
    overrides: Iterable[str] = (),
    file: Path | str | None = None,
) -> Config:
    """Resolve a config: profile, then ``file`` (YAML or JSON, nested sections), then ``key=value`` overrides.

    Raises ConfigError for an unknown profile, an unreadable file, an unknown key or a bad value.
    """
    if profile not in PROFILES:
        raise ConfigError(f"unknown profile {profile!r} (choose from {', '.join(sorted(PROFILES))})")
    config = PROFILES[profile]()
    if file is not None:
        config = Config.from_dict(read_config_file(Path(file)), base=config)
    for item in overrides:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"override {item!r} is not of the form section.key=value")
        set_value(config, key.strip(), raw.strip())
    return resolve_level_defaults(config)


def resolve_level_defaults(config: Config) -> Config:
    """A config with what the task level decides filled in where it is left open (``env.hand`` None: the
    level's hand); `config` itself is not changed."""
    if config.env.hand is not None:
        return config
    return dataclasses.replace(
        config, env=dataclasses.replace(config.env, hand=LEVELS[config.env.level].hand)
    )


def read_config_file(path: Path) -> dict[str, Any]:
    """Read a YAML or JSON config file into a nested dict."""
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    text = path.read_text()
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot parse config file {path}: {exc}".splitlines()[0]) from exc
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path} must hold a mapping of sections")
    return data


def set_value(config: Config, dotted_key: str, raw: Any) -> None:
    """Set ``section.field`` on ``config`` in place, coercing ``raw`` to the field's type."""
    section_name, _, field_name = dotted_key.partition(".")
    section = _section(config, section_name, dotted_key)
    if not field_name or "." in field_name:
        raise ConfigError(f"unknown config key {dotted_key!r} (use section.field, e.g. agent.batch_size)")
    hints = typing.get_type_hints(type(section))
    if field_name not in hints:
        hint = _removed_key_hint(field_name) if section_name == "dual" else None
        if hint is not None:
            raise ConfigError(f"unknown config key {dotted_key!r} ({hint})")
        known = ", ".join(f.name for f in dataclasses.fields(section))
        raise ConfigError(f"unknown config key {dotted_key!r} (fields of {section_name}: {known})")
    setattr(section, field_name, coerce(raw, hints[field_name], dotted_key))


def _section(config: Config, name: str, key: str) -> Any:
    names = [f.name for f in dataclasses.fields(config)]
    if name not in names:
        raise ConfigError(f"unknown config key {key!r} (sections: {', '.join(names)})")
    return getattr(config, name)


def _apply_mapping(config: Config, data: Mapping[str, Any]) -> None:
    for section_name, values in data.items():
        _section(config, str(section_name), str(section_name))
        if not isinstance(values, Mapping):
            raise ConfigError(f"config section {section_name!r} must be a mapping")
        for field_name, value in values.items():
            set_value(config, f"{section_name}.{field_name}", value)


_NONE_WORDS = {"none", "null", "~", ""}
_TRUE_WORDS = {"true", "yes", "on", "1"}
_FALSE_WORDS = {"false", "no", "off", "0"}


def coerce(raw: Any, annotation: Any, key: str) -> Any:
    """Coerce a raw value (string from the CLI, or a YAML/JSON scalar) to ``annotation``."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if type(None) in args and (raw is None or (isinstance(raw, str) and raw.lower() in _NONE_WORDS)):
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return coerce(raw, arg, key)
            except ConfigError as exc:
                errors.append(str(exc))
        raise ConfigError(errors[0] if errors else f"bad value for {key}: {raw!r}")
    if origin is Literal:
        value = str(raw) if not isinstance(raw, str) else raw
        if value not in args:
            raise ConfigError(f"bad value for {key}: {raw!r} (choose from {', '.join(map(str, args))})")
        return value
    if origin is tuple:
        items = raw
        if isinstance(raw, str):
            items = [s for s in raw.strip("()[] ").split(",") if s.strip()]
        if not isinstance(items, list | tuple):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected a comma-separated list)")
        return tuple(coerce(item, args[0], key) for item in items)
    if annotation is bool:
        if isinstance(raw, bool):
            return raw
        if isinstance(raw, str) and raw.lower() in _TRUE_WORDS | _FALSE_WORDS:
            return raw.lower() in _TRUE_WORDS
        raise ConfigError(f"bad value for {key}: {raw!r} (expected true/false)")
    if annotation is int:
        if isinstance(raw, bool):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected an integer)")
        if isinstance(raw, int):
            return raw
        try:
            as_float = float(str(raw).replace("_", ""))
        except ValueError:
            raise ConfigError(f"bad value for {key}: {raw!r} (expected an integer)") from None
        if not as_float.is_integer():
            raise ConfigError(f"bad value for {key}: {raw!r} (expected an integer)")
        return int(as_float)
    if annotation is float:
        if isinstance(raw, bool):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected a number)")
        try:
            return float(str(raw).replace("_", "")) if isinstance(raw, str) else float(raw)
        except (TypeError, ValueError):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected a number)") from None
    if origin is dict or annotation is dict:
        value = yaml.safe_load(raw) if isinstance(raw, str) else raw
        if value is None:
            return {}
        if not isinstance(value, Mapping):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected a mapping, e.g. {{g: 9.8}})")
        return {str(k): v for k, v in value.items()}
    if annotation is str:
        if isinstance(raw, dict | list):
            raise ConfigError(f"bad value for {key}: {raw!r} (expected a string)")
        return str(raw)
    raise ConfigError(f"config key {key} has an unsupported type {annotation!r}")  # pragma: no cover


_POSITIVE_INTS = (
    "run.eval_episodes",
    "run.num_threads",
    "run.smoothing_window",
    "env.max_steps",
    "net.latent_dim",
    "net.critic_hidden",
    "net.actor_hidden",
    "agent.batch_size",
    "agent.buffer_size",
    "agent.updates_per_step",
    "agent.updates_per_episode",
    "agent.critic_passes",
    "agent.ddpg_actor_passes",
    "agent.cacla_actor_passes",
    "agent.noise_anneal_steps",
    "agent.rnd_dim",
    "agent.policy_delay",
    "dual.lp_sigma",
    "dual.lp_window",
    "dual.model_hidden",
    "dual.model_batch",
    "dual.d_max",
    "dual.latent_buffer_size",
    "dual.latent_batch_size",
    "dual.refit_batch",
)
_NON_NEGATIVE = (
    "run.seed",
    "run.eval_every",
    "run.checkpoint_every",
    "agent.learning_starts",
    "agent.lambda_rec",
    "agent.lambda_q",
    "agent.noise_std",
    "agent.rnd_scale",
    "agent.noise_final_std",
    "agent.target_noise",
    "agent.target_noise_clip",
    "dual.plan_steps",
    "dual.fixed_horizon",
    "dual.cmc_horizon",
    "dual.refit_every",
    "dual.region_prune_after",
    "dual.model_memory",
)


_POSITIVE_OR_NONE: tuple[str, ...] = (
    "run.episodes", "run.steps", "run.max_wall_s", "run.checkpoint_every_s", "env.fixed_positions",
    "dual.e_max_relative", "agent.encoder_tau", "dual.imagination_depth", "agent.noise_seq_len",
)
"""Keys that are > 0 or None (`check_config`; the service's overrides schema reads the same tuple)."""

_POSITIVE: tuple[str, ...] = (
    "agent.critic_lr", "agent.actor_lr", "agent.rnd_lr", "agent.alpha_init", "agent.noise_theta",
    "dual.model_lr", "dual.e_max", "dual.plan_lr",
    "dual.imagination_max_ratio",
)
"""Real-valued keys that must be > 0."""


def value_bounds() -> dict[str, dict[str, float]]:
    """Per ``section.key``, the bounds `check_config` enforces, as JSON-schema words: ``ge`` (>=), ``gt``
    (>), ``le`` (<=). A key that may also be None (``_POSITIVE_OR_NONE``) has its bound for when it is set."""
    bounds: dict[str, dict[str, float]] = {}
    for key in _POSITIVE_INTS:
        bounds[key] = {"ge": 1}
    for key in _NON_NEGATIVE:
        bounds[key] = {"ge": 0}
    for key in (*_POSITIVE_OR_NONE, *_POSITIVE):
        bounds[key] = {"gt": 0}
    for key in ("agent.gamma", "agent.tau"):
        bounds[key] = {"ge": 0, "le": 1}
    return bounds


def level_hand_error(level: str, hand: str | None) -> str | None:
    """Why ``env.hand`` = `hand` is refused on task level `level` (`check_config`'s words), or None when the
    level admits it (None, the level's own hand, is always admitted; an unknown level is another check's)."""
    task_level = LEVELS.get(level)
    if task_level is None or hand is None or hand in task_level.hands:
        return None
    return f"level {task_level.name!r} admits {' or '.join(task_level.hands)}, got {hand!r}"


def check_config(config: Config) -> None:
    """Range checks a type cannot express; raises ConfigError naming the key."""

    def value(key: str) -> Any:
        section, name = key.split(".")
        return getattr(getattr(config, section), name)

    for key in _POSITIVE_INTS:
        if value(key) < 1:
            raise ConfigError(f"bad value for {key}: {value(key)!r} (must be >= 1)")
    for key in _NON_NEGATIVE:
        if value(key) < 0:
            raise ConfigError(f"bad value for {key}: {value(key)!r} (must be >= 0)")
    for key in _POSITIVE_OR_NONE:
        if value(key) is not None and value(key) <= 0:
            raise ConfigError(f"bad value for {key}: {value(key)!r} (must be > 0 or none)")
    if not 0.0 <= config.agent.gamma <= 1.0:
        raise ConfigError(f"bad value for agent.gamma: {config.agent.gamma!r} (must be in [0, 1])")
    if not 0.0 <= config.agent.tau <= 1.0:
        raise ConfigError(f"bad value for agent.tau: {config.agent.tau!r} (must be in [0, 1])")
    for key in _POSITIVE:
        if value(key) <= 0:
            raise ConfigError(f"bad value for {key}: {value(key)!r} (must be > 0)")
    if not config.net.conv_channels or min(config.net.conv_channels) < 1:
        raise ConfigError("bad value for net.conv_channels: needs at least one positive channel count")
    if not config.net.mlp_hidden or min(config.net.mlp_hidden) < 1:
        raise ConfigError("bad value for net.mlp_hidden: needs at least one positive layer width")
    if not config.env.id.strip():
        raise ConfigError("bad value for env.id: empty (a gymnasium id, e.g. MountainCarContinuous-v0)")
    level = LEVELS[config.env.level]
    if config.env.hand is not None and config.env.hand not in level.hands:
        raise ConfigError(
            f"bad value for env.hand: level {level.name!r} admits {' or '.join(level.hands)}, "
            f"got {config.env.hand!r}"
        )
    check_dual_combinations(config)
    if config.run.episodes is None and config.run.steps is None and config.run.max_wall_s is None:
        raise ConfigError("the run needs a budget: set run.episodes, run.steps or run.max_wall_s")


def check_dual_combinations(config: Config) -> None:
    """Refuse dual settings that make no sense together, each with a one-line ConfigError naming the fix."""
    dual = config.dual
    if dual.e_max_relative is not None and dual.regions == "repaired":
        raise ConfigError(
            "dual.e_max_relative is a resolution of the raw latent and dual.regions=repaired normalises it: "
            "set dual.regions=released (or paper) with it, or drop dual.e_max_relative"
        )
    if dual.model_batch == 1 and dual.model_memory != 0:
        raise ConfigError(
            "dual.model_memory is the pool each local-model update samples model_batch − 1 transitions from: "
            "with dual.model_batch=1 set dual.model_memory=0"
        )
    if 0 < dual.model_memory < dual.model_batch - 1:
        raise ConfigError(
            f"dual.model_memory={dual.model_memory} holds fewer than the dual.model_batch − 1 = "
            f"{dual.model_batch - 1} older transitions each update takes: set it to 0 (the newest) or >= "
            f"{dual.model_batch - 1}"
        )
    if config.run.algo == "i2a" and dual.arbitration == "model_free":
        raise ConfigError(
            "i2a with dual.arbitration=model_free would imagine without the planner it is built on: for the "
            "dual system without planning use --algo im2c --set dual.arbitration=model_free"
        )
