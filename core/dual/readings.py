"""The readings of each dual-system mechanism: one config field per mechanism names one of them.

Each mechanism of docs/dual-system.md ("Mechanisms") is read in up to three ways: ``paper`` (the literal
text), ``released`` (the authors' released code, where it differs from the text) and ``repaired`` (the
``default`` profile: the repairs of the mechanisms issue). A reading is a frozen record of the choices it
makes (the values of the switches it replaced); `resolve` selects one per mechanism from a `DualConfig`, once,
where the dual system is built (`LocalWorldModels`, `MetaController`, the mechanism checks), and the code
reads the record. Numbers (e_max, learning rates, sizes) stay config fields; the held-out reliability's own
constants are `HeldOut`.

- regions (`Regions`): paper — raw latent, squared L2; released — raw latent, L2; repaired — the latent
  divided by its running RMS spread, L2.
- world_models (`WorldModels`): paper — raw latent, φ̂′ itself, linear heads, a fresh model per new node;
  released — as paper with sigmoid/tanh heads; repaired — φ / s, the change in units of s, linear heads, a
  new node copies its parent's model.
- reliability (`Reliability`): paper — LP ≥ 0 of squared errors, not normalised, a new node unreliable;
  released — LP ≥ 0 of error norms, divided by the max mean, the oldest mean 0; repaired — the held-out
  verdict, error norms.
- intrinsic (`Intrinsic`): paper (= the released code) — −c·LP of the source region; paper_centred — the
  same minus its mean over the live regions (a control); repaired — +c·held-out progress of the destination
  region.
- planner (`Planner`): paper — (R* − Σ r̂)², plain gradient, only the executed action clipped; released —
  ½ Σ (1 − r̂)², otherwise paper; repaired — (R* − Σ r̂)², normalised steps, every plan action clipped;
  progress — the predicted return plus c · the learning progress of the regions the plan reaches, maximised,
  steps and clip as repaired, and where the models are not trusted the plan steered toward that goal alone;
  a fifth of its goals babbled past the map's edge (`core.dual.goal_babbling`); novelty — the same with the
  regions' prediction error instead of progress; disagreement — with an ensemble's variance; babbling — the
  progress planner with only its babbled goals; each of them adds the learner's value at the plan's end
  (item 23); value — the predicted return and that terminal value, no aim.
- imagination (`Imagination`): paper (= the released code) — the act-time rollout in B_latent, all kept, no
  termination head; repaired — learn-time rollouts, the no-change gate, a termination head;
  repaired_no_termination — repaired without the head, the one combination a shipped experiment ran that is
  no reading of text or code (`IMAGINATION`).

The ``paper`` profile is the text where it is explicit and the code where it is silent: regions and
reliability ``released`` (L2 distance and error norms, LP normalised by its max), the rest ``paper``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from core.config import (
    OLD_DUAL_CONSTANTS,
    OLD_DUAL_REJECTED,
    OLD_DUAL_SWITCHES,
    ConfigError,
    DualConfig,
    coerce,
)


@dataclass(frozen=True)
class Regions:
    """Where the ITM lives and how it measures (Section 2.3.1).

    ``space``: the raw latent, or the latent divided by its running RMS spread (e_max then in units of the
    spread; ``dual.e_max_relative``, a raw-latent resolution, is refused with the latter). ``distance``
    compared with e_max: L2 (released code) or squared L2 (the text)."""

    space: Literal["latent", "normalised"]
    distance: Literal["l2", "squared"]

    @property
    def normalised(self) -> bool:
        """Whether the map lives in φ / s (s the latent's running RMS spread)."""
        return self.space == "normalised"


@dataclass(frozen=True)
class WorldModels:
    """The local models M_n, R_n (Eq. 5, Section 4.1.1).

    ``space``: what they read and predict, the raw latent or φ / its RMS spread s in units of s. ``target``:
    φ̂′ itself (Eq. 5) or the change, φ̂′ = φ + M_n(φ, a). ``output``: linear heads (Section 4.1.1) or a
    sigmoid latent and tanh reward (released code; only with the absolute model in raw latent units, where a
    (0, 1) range can be meant). ``new_node``: a new ITM node's model freshly initialised (released code) or a
    copy of its parent's."""

    space: Literal["latent", "normalised"]
    target: Literal["absolute", "delta"]
    output: Literal["linear", "released"]
    new_node: Literal["fresh", "parent"]

    @property
    def normalised(self) -> bool:
        """Whether the models read φ / s and predict in units of s."""
        return self.space == "normalised"


@dataclass(frozen=True)
class HeldOut:
    """The held-out reliability's constants (`core.dual.reliability.HeldOutReliability`), used wherever a
    repaired reading reads held-out verdicts: the repaired reliability, intrinsic reward and imagination gate.
    Never changed by a profile or a shipped experiment (they were the config keys ``dual.heldout_size``,
    ``heldout_every``, ``reliability_lag``, ``reliability_z`` and ``accurate_ratio``).

    ``size``: held-out transitions kept per node (its newest, a ring); every ``every``-th real transition of a
    node goes there instead of its training data; parameters are snapshotted every ``lag`` model updates
    (progress compares with one L..2L updates old); ``z``: the margin, in standard errors of the paired
    held-out difference, for "improving" and "worsening"; a model is accurate when its held-out error is at
    most ``accurate_ratio`` of the no-change predictor's."""

    size: int = 48
    every: int = 4
    lag: int = 100
    z: float = 3.0
    accurate_ratio: float = 0.5


@dataclass(frozen=True)
class Reliability:
    """Arbitration's reliability and the Eq. 8-9 error stream (Section 2.3.2).

    ``signal``: LP ≥ 0 of the error stream (Eq. 9), or the held-out error and progress verdict (`HeldOut`).
    ``error_norm``: Eq. 8 as norms (released code) or squared norms (as printed). ``lp_normalise``: divide
    LP by the max of the history of means (released code). ``lp_warmup``, before W+1 window means exist: the
    oldest mean counts as 0, so a new node starts with LP < 0 (released code), or the node is unreliable
    with r_int = 0 (the text's Eq. 9)."""

    signal: Literal["lp", "heldout"]
    error_norm: Literal["l2", "squared"]
    lp_normalise: bool
    lp_warmup: Literal["zero_oldest", "unreliable"]

    @property
    def squared(self) -> bool:
        """Whether Eq. 8's errors are squared norms (as printed) rather than norms."""
        return self.error_norm == "squared"

    @property
    def held_out(self) -> bool:
        """Whether arbitration reads the held-out verdict (else LP ≥ 0 of the error stream)."""
        return self.signal == "heldout"


@dataclass(frozen=True)
class Intrinsic:
    """r_int (Alg. 2 line 22): ``signal`` −c·LP of the error stream, or +c·held-out progress / the latent's
    spread; ``region`` whose signal rewards a transition: the one it started in, or the one the action led
    into."""

    signal: Literal["neg_lp", "neg_lp_centred", "progress"]
    region: Literal["source", "destination"]

    @property
    def from_lp(self) -> bool:
        """Whether r_int is −c·LP of the error stream (Eq. 9), else the held-out progress."""
        return self.signal != "progress"

    @property
    def centred(self) -> bool:
        """Whether the mean over the live regions is removed (``paper_centred``)."""
        return self.signal == "neg_lp_centred"

    @property
    def at_destination(self) -> bool:
        """Whether the region the action led into is rewarded (else the one the transition started in)."""
        return self.region == "destination"


@dataclass(frozen=True)
class Planner:
    """Gradient MPC (Eq. 6-7).

    ``objective``: (R* − Σ r̂)² (Eq. 6), ½ Σ (1 − r̂)² (released code), or −Σ r̂, the predicted return
    maximised (with an aim). ``optimiser``, Eq. 7's step: the plain gradient, or the gradient scaled to length
    α (a step in action units). ``clip``: only the executed action to [−1, 1], or every plan action after
    every step (a projection). ``aim``: what the plan seeks beside the predicted reward, c · Σ_h
    g(φ̃_{h+1}) with c = ``dual.intrinsic_scale``, g the pull toward where the regions' values, averaged
    over map neighbours and capped at each region's own, peak, and φ̃ the latents the start node's action map
    predicts (`core.dual.region_goal.RegionGoal.plan_term`); where the models are not trusted, an aiming
    planner steers toward that goal alone (`core.dual.planning.steer_plan`). One value per region: none;
    ``progress`` — the region's learning progress (`core.dual.lagged_progress`: the growth of the current
    model's gain over a lagged copy's, each gain the share of the action-free least-squares predictor's error
    the model removes, on the region's held-out transitions); ``novelty`` —
    the region's model error over its no-change error (prediction-error curiosity: large where the model
    is wrong, noise included); ``disagreement`` — the variance of an ensemble of the region's models
    (Plan2Explore, MAX: epistemic uncertainty)."""

    objective: Literal["sum", "per_step", "return"]
    optimiser: Literal["sgd", "normalised"]
    clip: Literal["executed", "every_step"]
    aim: Literal["none", "progress", "novelty", "disagreement"] = "none"
    goals: Literal["aim", "aim_and_babbled", "babbled"] = "aim"
    """Where the pull points (`core.dual.goal_babbling`): the aim's goal alone; the aim's goal with a share of
    goals drawn uniformly past the map's edge in its place; or only those babbled goals (none in between:
    the actor acts), with the aim's contrast as the pull's length."""
    terminal: bool = False
    """Whether the learner's value at the plan's end, γ^H V(φ̂_H), joins the predicted return (only with
    ``objective="return"``; `core.dual.planning.TerminalValue`, docs/dual-system.md item 23): with it the
    extrinsic term sees past the plan's d_max steps, so once the critic has learnt a reward the plan is pulled
    where the actor already goes. It joins from the run's first positive extrinsic reward on
    (`core.dual.dual_system.DualSystem.terminal_value`, item 24): before, V is not flat (SAC's soft value
    carries the entropy bonus) and the normalised step gave its gradient a full share of the step (item 23's
    noisy-TV cells)."""

    def __post_init__(self) -> None:
        if self.terminal and self.objective != "return":
            raise ValueError("a terminal value joins the predicted return only (objective='return')")

    @property
    def babbles(self) -> bool:
        """Whether some goals are babbled past the map's edge."""
        return self.goals != "aim"


@dataclass(frozen=True)
class Imagination:
    """I2A's imagined transitions (Alg. 3 lines 13-21, 35-36).

    ``source``: the act-time rollout stored in B_latent (line 17), or rollouts from the pixel minibatch's
    states, encoded by the current encoder, made at each update and never stored. ``gate``: keep every
    imagined transition, or one with probability clip(1 − ratio / max_ratio, 0, 1), ratio its node's
    held-out error / the no-change error (``dual.imagination_max_ratio``). ``termination``: a termination head
    on each local model (BCE on the real ``terminated``) for imagined ``done`` flags."""

    source: Literal["act_time", "learn_time"]
    gate: Literal["none", "no_change_ratio"]
    termination: bool

    @property
    def at_learn_time(self) -> bool:
        """Whether imagined transitions are rolled out at each update (else stored at act time, line 17)."""
        return self.source == "learn_time"

    @property
    def gated(self) -> bool:
        """Whether an imagined transition is kept with its node's no-change-ratio probability."""
        return self.gate == "no_change_ratio"


REGIONS: dict[str, Regions] = {
    "paper": Regions(space="latent", distance="squared"),
    "released": Regions(space="latent", distance="l2"),
    "repaired": Regions(space="normalised", distance="l2"),
}
WORLD_MODELS: dict[str, WorldModels] = {
    "paper": WorldModels(space="latent", target="absolute", output="linear", new_node="fresh"),
    "released": WorldModels(space="latent", target="absolute", output="released", new_node="fresh"),
    "repaired": WorldModels(space="normalised", target="delta", output="linear", new_node="parent"),
}
RELIABILITY: dict[str, Reliability] = {
    "paper": Reliability(signal="lp", error_norm="squared", lp_normalise=False, lp_warmup="unreliable"),
    "released": Reliability(signal="lp", error_norm="l2", lp_normalise=True, lp_warmup="zero_oldest"),
    "repaired": Reliability(signal="heldout", error_norm="l2", lp_normalise=True, lp_warmup="zero_oldest"),
}
INTRINSIC: dict[str, Intrinsic] = {
    "paper": Intrinsic(signal="neg_lp", region="source"),
    "paper_centred": Intrinsic(signal="neg_lp_centred", region="source"),
    "repaired": Intrinsic(signal="progress", region="destination"),
}
"""``paper_centred`` is no reading of the text or the code: the paper's r_int with its mean over the live
regions removed, a control that keeps only its dependence on the region (issue 29, "what explores")."""
PLANNER: dict[str, Planner] = {
    "paper": Planner(objective="sum", optimiser="sgd", clip="executed"),
    "released": Planner(objective="per_step", optimiser="sgd", clip="executed"),
    "repaired": Planner(objective="sum", optimiser="normalised", clip="every_step"),
    "progress": Planner(objective="return", optimiser="normalised", clip="every_step", aim="progress",
                        goals="aim_and_babbled", terminal=True),
    "novelty": Planner(objective="return", optimiser="normalised", clip="every_step", aim="novelty",
                       goals="aim_and_babbled", terminal=True),
    "disagreement": Planner(objective="return", optimiser="normalised", clip="every_step",
                            aim="disagreement", goals="aim_and_babbled", terminal=True),
    "babbling": Planner(objective="return", optimiser="normalised", clip="every_step", aim="progress",
                        goals="babbled", terminal=True),
    "value": Planner(objective="return", optimiser="normalised", clip="every_step", terminal=True),
}
"""``progress`` and ``novelty`` are no reading of the text or the code: planners that aim before the first
reward (issue 50; docs/dual-system.md, "A planner that aims"). ``novelty`` is the ablation that replaces
learning progress by prediction error; ``disagreement`` the peer that aims at the models' uncertainty;
``babbling`` the ablation that removes the progress goal and keeps the babbled ones; ``value`` the ablation
that turns the aim off and keeps the rest (the predicted return and the terminal value: item 23's planner with
its progress term off)."""
IMAGINATION: dict[str, Imagination] = {
    "paper": Imagination(source="act_time", gate="none", termination=False),
    "repaired": Imagination(source="learn_time", gate="no_change_ratio", termination=True),
    "repaired_no_termination": Imagination(source="learn_time", gate="no_change_ratio", termination=False),
}
"""``repaired_no_termination`` is no reading of the text or the code: the repaired imagination without the
termination head, what the literal IM2C of experiments/mountaincar-repairs.yaml (IM2C-no-repair) and
mountaincar-controls.yaml ran (they turned ``model_termination`` off and left the imagination keys at their
defaults). For IM2C, which does not imagine, it means no termination head and the held-out sets the gate
reads: every 4th real transition of a node is held out from its model's training, unlike in the ``paper``
profile."""


@dataclass(frozen=True)
class Readings:
    """The reading of every mechanism of one `DualConfig` (`resolve`)."""

    regions: Regions
    world_models: WorldModels
    reliability: Reliability
    intrinsic: Intrinsic
    planner: Planner
    imagination: Imagination
    held_out: HeldOut = field(default_factory=HeldOut)

    @property
    def needs_heldout(self) -> bool:
        """Whether a reading uses held-out verdicts (reliability, intrinsic progress, imagination gate)."""
        return (self.reliability.held_out or not self.intrinsic.from_lp or self.imagination.gated
                or self.planner.aim in ("novelty", "progress"))


def resolve(dual: DualConfig) -> Readings:
    """The readings ``dual`` names (``dual.regions``, ``dual.world_models``, ...)."""
    return Readings(
        regions=REGIONS[dual.regions],
        world_models=WORLD_MODELS[dual.world_models],
        reliability=RELIABILITY[dual.reliability],
        intrinsic=INTRINSIC[dual.intrinsic],
        planner=PLANNER[dual.planner],
        imagination=IMAGINATION[dual.imagination],
    )


TABLES: dict[str, dict[str, Any]] = {
    "regions": REGIONS,
    "world_models": WORLD_MODELS,
    "reliability": RELIABILITY,
    "intrinsic": INTRINSIC,
    "planner": PLANNER,
    "imagination": IMAGINATION,
}
"""Each mechanism's field and its readings."""


PIXEL_BUFFER_ALGOS = ("i2a", "la-imagination")
"""The methods whose stored ``dual.pixel_buffer_size`` sized their real replay (B_pixel): a stored config of
one of them takes it as ``agent.buffer_size``; the others ignored it."""


def upgrade_stored(stored: Mapping[str, Any]) -> dict[str, Any]:
    """A stored config (a run's config.yaml, a checkpoint's config) written with the old dual switches,
    in the readings' words: each mechanism's old values (the old default where a key is absent) become the
    reading that holds exactly them. Raises ConfigError for old values that are no reading. A config in the
    new words comes back unchanged; user input (`core.config.load_config`) is never upgraded. A stored
    ``dual.pixel_buffer_size`` becomes the ``agent.buffer_size`` of the methods it sized
    (`PIXEL_BUFFER_ALGOS`)."""
    data = {section: dict(values) if isinstance(values, Mapping) else values
            for section, values in stored.items()}
    dual = data.get("dual")
    if not isinstance(dual, dict):
        return data
    if "pixel_buffer_size" in dual:  # I2A's own B_pixel size, now agent.buffer_size for every method
        pixel = dual.pop("pixel_buffer_size")
        run = data.get("run")
        if isinstance(run, Mapping) and run.get("algo") in PIXEL_BUFFER_ALGOS:
            data["agent"] = {**dict(data.get("agent") or {}), "buffer_size": pixel}
    old_reliability = dual.get("reliability") in ("lp", "heldout")
    old = {key for key in (*OLD_DUAL_SWITCHES, *OLD_DUAL_CONSTANTS, *OLD_DUAL_REJECTED) if key in dual}
    if not old_reliability:
        old.discard("reliability")
    if not old:
        return data
    for key, value in OLD_DUAL_REJECTED.items():
        if key in dual and dual.pop(key) != value:
            raise ConfigError(f"stored dual.{key} is a removed reading (only {value!r} remains)")
    for key, attribute in OLD_DUAL_CONSTANTS.items():
        if key in dual:
            constant = getattr(HeldOut(), attribute)
            if coerce(dual.pop(key), type(constant), f"dual.{key}") != constant:
                raise ConfigError(f"stored dual.{key} differs from HeldOut.{attribute} = {constant}")
    for name, table in TABLES.items():
        keys = [key for key, (field_name, _) in OLD_DUAL_SWITCHES.items() if field_name == name]
        if not any(key in old for key in keys):
            continue
        hints = {f.name: f.type for f in dataclasses.fields(next(iter(table.values())))}
        wanted = dataclasses.asdict(table["repaired"])  # the old defaults
        for key in keys:
            if key in dual and (key != "reliability" or old_reliability):
                attribute = OLD_DUAL_SWITCHES[key][1]
                value = dual.pop(key)
                wanted[attribute] = value if hints[attribute] != "bool" else coerce(value, bool, key)
        if name == "world_models" and not (wanted["target"] == "absolute" and wanted["space"] == "latent"):
            wanted["output"] = "linear"  # the old rule: sigmoid heads only for the absolute raw-latent model
        matches = [reading for reading, values in table.items() if dataclasses.asdict(values) == wanted]
        if not matches:
            raise ConfigError(f"stored dual settings {wanted} are no reading of dual.{name}")
        dual[name] = matches[0]
    return data
