"""Experiment files: a comparison as data (methods × reward modes × seeds at one env-step budget).

An experiment file is YAML::

    name: table1                    # folder name of the experiment: [A-Za-z0-9._-]
    description: Table 1 of the paper (optional)
    profile: default                # core.config profile every cell starts from
    env: dualsys/NicoGrasp-v0       # optional: the gymnasium id of every cell (env.id; default NicoGrasp)
    env_kwargs: {}                  # optional: gymnasium.make keyword arguments (env.kwargs; not NicoGrasp)
    level: released                 # NicoGrasp's task level (env.level): released | paper | hard
    rewards: [dense, sparse]        # NicoGrasp's reward modes (env.reward_mode); another env: [task]
    seeds: 5                        # N (seeds 0..N-1) or an explicit list [0, 1, 7]
    steps: 150000                   # env-step budget of every cell (run.steps); never wall-clock
    eval_every: 200                 # greedy evaluation every N training episodes (run.eval_every)
    eval_episodes: 25               # episodes per greedy evaluation (run.eval_episodes)
    baseline: DDPG                  # optional: label every method is compared with
    smoothing: {dense: 250, sparse: 375}   # optional: learning-curve windows in episodes (Fig. 8)
    episode_measures: [env/noise_share]    # optional: metrics.csv columns the report summarises per cell
                                    # (their mean over the second half of the training episodes)
    return_goal: 90                 # optional: a greedy return that counts as solved; the report adds the
                                    # env step of the first greedy evaluation reaching it (diagnostic)
    overrides: {agent.batch_size: 64}      # optional: config key=value for every method
    methods:
      - label: DDPG                 # folder and legend name: [A-Za-z0-9+._-]
        algo: ddpg                  # a method of core.runs.methods (or of a registered cell runner)
      - label: DDPG+IM2C
        algo: im2c
        ac: ddpg                    # the learner of a dual-system method: ddpg | cacla | td3 | sac
        overrides: {dual.intrinsic_scale: 0.1}

``overrides`` take the same keys as ``dualsys train --set``. The keys the experiment sets per cell
(algo, ac, reward, level, seed and the budget) cannot be overridden. :func:`load_experiment` checks
everything a run would check — every cell's resolved config included — before anything is written, and
raises :class:`ExperimentError` with one line naming the offending key.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from core.config import NICO_GRASP_ID, ConfigError
from core.task_levels import LEVELS as TASK_LEVELS

LEVELS: tuple[str, ...] = tuple(TASK_LEVELS)
"""Task levels an experiment may name (``env.level``)."""

REWARDS: tuple[str, ...] = ("dense", "sparse")
"""Reward modes of Section 4.1.2 (``env.reward_mode``)."""

TASK_REWARD = "task"
"""The one reward "mode" of an env other than NicoGrasp: its own reward (a cell folder's reward part)."""

ACTOR_RULES: tuple[str, ...] = ("ddpg", "cacla", "td3", "sac")
"""Actor updates a method may name with ``ac`` (``agent.ac``)."""

DEFAULT_SMOOTHING: dict[str, int] = {"dense": 250, "sparse": 375, "task": 10}
"""Sliding windows (episodes) of the learning curves: Fig. 8's for NicoGrasp; 10 for another task's own
reward (MountainCarContinuous-v0's episodes are up to 999 steps: 50 in a 50k-step run)."""

RESERVED_KEYS: dict[str, str] = {
    "run.algo": "the method's 'algo'",
    "agent.ac": "the method's 'ac'",
    "run.seed": "'seeds'",
    "run.steps": "'steps'",
    "run.episodes": "'steps' (cells have a step budget only)",
    "run.max_wall_s": "'steps' (budgets are never wall-clock)",
    "run.eval_every": "'eval_every'",
    "run.eval_episodes": "'eval_episodes'",
    "env.reward_mode": "'rewards'",
    "env.level": "'level'",
    "env.id": "'env'",
    "env.kwargs": "'env_kwargs'",
    "run.num_threads": "the runner (every cell is single-threaded)",
}
"""Config keys the experiment sets for each cell, and the file key that sets them."""

TOP_KEYS: tuple[str, ...] = (
    "name",
    "description",
    "profile",
    "env",
    "env_kwargs",
    "level",
    "rewards",
    "seeds",
    "steps",
    "eval_every",
    "eval_episodes",
    "baseline",
    "smoothing",
    "episode_measures",
    "return_goal",
    "overrides",
    "methods",
)
METHOD_KEYS: tuple[str, ...] = ("label", "algo", "ac", "overrides")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
_LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9+._-]*$")


class ExperimentError(ConfigError):
    """A user-caused problem with an experiment file or directory (one line, names the key)."""


@dataclass(frozen=True)
class MethodSpec:
    """One method of the comparison: a label, a registered algo, its actor rule and config overrides."""

    label: str
    algo: str
    ac: str | None = None
    overrides: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"label": self.label, "algo": self.algo}
        if self.ac is not None:
            out["ac"] = self.ac
        if self.overrides:
            out["overrides"] = dict(self.overrides)
        return out


@dataclass(frozen=True)
class ExperimentSpec:
    """A validated experiment file (see the module docstring for the keys)."""

    name: str
    methods: tuple[MethodSpec, ...]
    rewards: tuple[str, ...]
    seeds: tuple[int, ...]
    steps: int
    level: str = "released"
    profile: str = "default"
    env: str = NICO_GRASP_ID
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    eval_every: int = 200
    eval_episodes: int = 25
    baseline: str | None = None
    smoothing: Mapping[str, int] = field(default_factory=lambda: dict(DEFAULT_SMOOTHING))
    overrides: Mapping[str, Any] = field(default_factory=dict)
    description: str = ""
    episode_measures: tuple[str, ...] = ()
    return_goal: float | None = None

    @property
    def nico_grasp(self) -> bool:
        """Whether the cells run NicoGrasp (levels and dense/sparse rewards apply)."""
        return self.env == NICO_GRASP_ID

    def method(self, label: str) -> MethodSpec:
        for method in self.methods:
            if method.label == label:
                return method
        raise ExperimentError(f"experiment {self.name!r} has no method {label!r}")

    def to_dict(self) -> dict[str, Any]:
        """The file's keys, normalised (what the runner stores as experiment.yaml)."""
        out: dict[str, Any] = {"name": self.name}
        if self.description:
            out["description"] = self.description
        out["profile"] = self.profile
        if not self.nico_grasp:
            out["env"] = self.env
            if self.env_kwargs:
                out["env_kwargs"] = dict(self.env_kwargs)
        if self.nico_grasp:
            out["level"] = self.level  # another env has no task level (read_experiment refuses one)
        out.update(
            {
                "rewards": list(self.rewards),
                "seeds": list(self.seeds),
                "steps": self.steps,
                "eval_every": self.eval_every,
                "eval_episodes": self.eval_episodes,
            }
        )
        if self.baseline is not None:
            out["baseline"] = self.baseline
        out["smoothing"] = dict(self.smoothing)
        if self.episode_measures:
            out["episode_measures"] = list(self.episode_measures)
        if self.return_goal is not None:
            out["return_goal"] = self.return_goal
        if self.overrides:
            out["overrides"] = dict(self.overrides)
        out["methods"] = [method.to_dict() for method in self.methods]
        return out

    def to_yaml(self) -> str:
        return yaml.safe_dump(self.to_dict(), sort_keys=False, allow_unicode=True)


def read_experiment(source: Path | str | Mapping[str, Any]) -> ExperimentSpec:
    """Read and validate an experiment's keys: a path to a YAML file, YAML text, or an already-parsed mapping.

    This checks the file's own keys; ``core.experiments.cells.load_experiment`` also resolves every method's
    config, as ``dualsys train`` would. A report reads a stored experiment.yaml with this alone. Raises
    :class:`ExperimentError`.
    """
    return _parse(_read(source))


def _read(source: Path | str | Mapping[str, Any]) -> Mapping[str, Any]:
    if isinstance(source, Mapping):
        return source
    text: str
    origin = "experiment"
    if isinstance(source, Path) or ("\n" not in source and source.strip().endswith((".yaml", ".yml"))):
        path = Path(source)
        if not path.is_file():
            raise ExperimentError(f"experiment file not found: {path}")
        text, origin = path.read_text(), str(path)
    else:
        text = source
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ExperimentError(f"cannot parse {origin}: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, Mapping):
        raise ExperimentError(f"{origin} must be a YAML mapping of experiment keys")
    return data


def _parse(data: Mapping[str, Any]) -> ExperimentSpec:
    unknown = [str(key) for key in data if key not in TOP_KEYS]
    if unknown:
        raise ExperimentError(f"unknown key {unknown[0]!r} (experiment keys: {', '.join(TOP_KEYS)})")
    required = ["name", "methods", "seeds", "steps"]
    if data.get("env", NICO_GRASP_ID) == NICO_GRASP_ID:
        required.append("rewards")
    for key in required:
        if data.get(key) is None:
            what = {
                "steps": "the env-step budget of every cell",
                "seeds": "a seed count or list",
                "rewards": "a list of reward modes (dense, sparse)",
                "methods": "a list of methods",
                "name": "the experiment's folder name",
            }[key]
            raise ExperimentError(f"missing key {key!r} ({what})")
    name = _string(data["name"], "name")
    if not _NAME.match(name):
        raise ExperimentError(f"bad value for name: {name!r} (letters, digits, '.', '_', '-')")
    level = _string(data.get("level", "released"), "level")
    if level not in LEVELS:
        raise ExperimentError(f"bad value for level: {level!r} (choose from {', '.join(LEVELS)})")
    profile = _string(data.get("profile", "default"), "profile")
    from core.config import PROFILES

    if profile not in PROFILES:
        raise ExperimentError(f"bad value for profile: {profile!r} (choose from {', '.join(PROFILES)})")
    env = _string(data.get("env", NICO_GRASP_ID), "env")
    env_kwargs = data.get("env_kwargs") or {}
    if not isinstance(env_kwargs, Mapping):
        raise ExperimentError("bad value for env_kwargs: expected a mapping of gymnasium.make arguments")
    if env == NICO_GRASP_ID:
        if env_kwargs:
            raise ExperimentError("bad value for env_kwargs: NicoGrasp takes level, rewards and overrides")
        rewards = _rewards(data["rewards"])
    else:
        if "level" in data:
            raise ExperimentError(f"unknown key 'level' for env {env!r} (task levels are NicoGrasp's)")
        rewards = _task_rewards(data.get("rewards", [TASK_REWARD]), env)
    seeds = _seeds(data["seeds"])
    steps = _positive_int(data["steps"], "steps")
    eval_every = _int(data.get("eval_every", 200), "eval_every", minimum=0)
    eval_episodes = _positive_int(data.get("eval_episodes", 25), "eval_episodes")
    overrides = _overrides(data.get("overrides") or {}, "overrides")
    methods = _methods(data["methods"])
    smoothing = dict(DEFAULT_SMOOTHING)
    raw_smoothing = data.get("smoothing") or {}
    if not isinstance(raw_smoothing, Mapping):
        raise ExperimentError("bad value for smoothing: expected a mapping {dense: N, sparse: N}")
    for reward, window in raw_smoothing.items():
        if reward not in (*REWARDS, TASK_REWARD):
            raise ExperimentError(
                f"unknown key 'smoothing.{reward}' (reward modes: {', '.join((*REWARDS, TASK_REWARD))})"
            )
        smoothing[str(reward)] = _positive_int(window, f"smoothing.{reward}")
    baseline = data.get("baseline")
    if baseline is not None:
        baseline = _string(baseline, "baseline")
        if baseline not in {method.label for method in methods}:
            raise ExperimentError(f"bad value for baseline: {baseline!r} is not a method label")
    description = _string(data.get("description", ""), "description")
    measures = data.get("episode_measures") or []
    if not isinstance(measures, list) or not all(isinstance(m, str) and m for m in measures):
        raise ExperimentError("bad value for episode_measures: expected a list of metrics.csv column names")
    return_goal = data.get("return_goal")
    if return_goal is not None:
        number = isinstance(return_goal, int | float) and not isinstance(return_goal, bool)
        if not number or not math.isfinite(return_goal):
            raise ExperimentError(f"bad value for return_goal: {return_goal!r} (expected a number)")
        return_goal = float(return_goal)
    return ExperimentSpec(
        name=name,
        methods=methods,
        rewards=rewards,
        seeds=seeds,
        steps=steps,
        level=level,
        profile=profile,
        env=env,
        env_kwargs=dict(env_kwargs),
        eval_every=eval_every,
        eval_episodes=eval_episodes,
        baseline=baseline,
        smoothing=smoothing,
        overrides=overrides,
        description=description,
        episode_measures=tuple(measures),
        return_goal=return_goal,
    )


def _string(value: Any, key: str) -> str:
    if not isinstance(value, str | int | float) or isinstance(value, bool):
        raise ExperimentError(f"bad value for {key}: {value!r} (expected a string)")
    return str(value)


def _int(value: Any, key: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ExperimentError(f"bad value for {key}: {value!r} (expected an integer)")
    try:
        number = float(str(value).replace("_", ""))
    except ValueError:
        raise ExperimentError(f"bad value for {key}: {value!r} (expected an integer)") from None
    if not number.is_integer() or number < minimum:
        raise ExperimentError(f"bad value for {key}: {value!r} (expected an integer >= {minimum})")
    return int(number)


def _positive_int(value: Any, key: str) -> int:
    return _int(value, key, minimum=1)


def _rewards(value: Any) -> tuple[str, ...]:
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items:
        raise ExperimentError("bad value for rewards: expected a non-empty list of dense/sparse")
    rewards: list[str] = []
    for item in items:
        if item not in REWARDS:
            raise ExperimentError(f"bad value for rewards: {item!r} (choose from {', '.join(REWARDS)})")
        if item in rewards:
            raise ExperimentError(f"bad value for rewards: {item!r} is listed twice")
        rewards.append(item)
    return tuple(rewards)


def _task_rewards(value: Any, env: str) -> tuple[str, ...]:
    items = [value] if isinstance(value, str) else value
    if items != [TASK_REWARD]:
        raise ExperimentError(
            f"bad value for rewards: {value!r} (env {env!r} has its own reward: leave rewards out or [task])"
        )
    return (TASK_REWARD,)


def _seeds(value: Any) -> tuple[int, ...]:
    if isinstance(value, list):
        seeds = tuple(_int(item, "seeds", minimum=0) for item in value)
        if len(set(seeds)) != len(seeds):
            raise ExperimentError(f"bad value for seeds: {value!r} (a seed is listed twice)")
    else:
        seeds = tuple(range(_int(value, "seeds", minimum=0)))
    if not seeds:
        raise ExperimentError("bad value for seeds: an experiment needs at least one seed")
    return seeds


def _overrides(value: Any, key: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ExperimentError(f"bad value for {key}: expected a mapping of section.key: value")
    out: dict[str, Any] = {}
    for item, raw in value.items():
        dotted = str(item)
        if dotted in RESERVED_KEYS:
            raise ExperimentError(f"{key}: {dotted} is set by the experiment ({RESERVED_KEYS[dotted]})")
        if isinstance(raw, Mapping):
            raise ExperimentError(f"bad value for {key}.{dotted}: expected a scalar or a list")
        out[dotted] = list(raw) if isinstance(raw, tuple) else raw
    return out


def _methods(value: Any) -> tuple[MethodSpec, ...]:
    if not isinstance(value, list) or not value:
        raise ExperimentError("bad value for methods: expected a non-empty list of {label, algo, ...}")
    methods: list[MethodSpec] = []
    for index, item in enumerate(value):
        where = f"methods[{index}]"
        if not isinstance(item, Mapping):
            raise ExperimentError(f"bad value for {where}: expected a mapping with label and algo")
        unknown = [str(key) for key in item if key not in METHOD_KEYS]
        if unknown:
            raise ExperimentError(
                f"unknown key '{where}.{unknown[0]}' (method keys: {', '.join(METHOD_KEYS)})"
            )
        for key in ("label", "algo"):
            if item.get(key) is None:
                raise ExperimentError(f"missing key '{where}.{key}'")
        label = _string(item["label"], f"{where}.label")
        if not _LABEL.match(label):
            raise ExperimentError(
                f"bad value for {where}.label: {label!r} (letters, digits, '+', '.', '_', '-')"
            )
        if label in {method.label for method in methods}:
            raise ExperimentError(f"bad value for {where}.label: {label!r} is used twice")
        ac = item.get("ac")
        if ac is not None and ac not in ACTOR_RULES:
            raise ExperimentError(f"bad value for {where}.ac: {ac!r} (choose from {', '.join(ACTOR_RULES)})")
        methods.append(
            MethodSpec(
                label=label,
                algo=_string(item["algo"], f"{where}.algo"),
                ac=ac,
                overrides=_overrides(item.get("overrides") or {}, f"{where}.overrides"),
            )
        )
    return tuple(methods)
