"""Validated job specs: each holds the same options as the matching CLI command.

- `train` mirrors `dualsys train`: algo, reward, seed, episodes|steps, profile, overrides, ac.
  A field left out (None) keeps the profile's value: defaults live in `core.config` only.
- `align` mirrors `dualsys align`: policy, pairs_dir, epochs, batch_size, name.
- `eval` mirrors `dualsys eval`: policy, trials, max_steps, domain, seed, onnx.
- `export` mirrors `dualsys export`: policy, out (an ONNX file name inside the job's run directory).
- `probe` is the service's own diagnostic kind (documented in docs/service.md): it emits
  synthetic episode records and JSON checkpoints at a set pace, so an operator can check the
  queue, workers, heartbeats, cancel and resume of an installation without training anything.

Unknown fields are refused (422 naming the field). `policy` takes `name`, `name@VERSION` or
`name@ALIAS`; the service resolves it to a version at submission.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any, Literal

from pydantic import Field, ValidationInfo, field_validator

from registry.references import POLICY_NAME, POLICY_REF
from service.schemas.config_overrides import check_overrides, overrides_json_schema
from service.schemas.json_schema import StrictRequest

ONNX_FILE_NAME = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,95}\.onnx$"
"""A plain file name ending in .onnx (no folders), at most 101 characters."""


class SpecBase(StrictRequest):
    """A job spec: exactly its JSON schema (service.schemas.json_schema.StrictRequest)."""


def _override_text(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return ",".join(str(item) for item in value)
    return str(value)


def _choices(names: Callable[[], Any]) -> Callable[[dict[str, Any]], None]:
    """A `json_schema_extra` that lists the values a string field accepts (known when the schema is
    built: the method registry and the profiles live in core)."""

    def extra(schema: dict[str, Any]) -> None:
        choices = names()
        if choices is None:
            return
        target = next((b for b in schema.get("anyOf", []) if b.get("type") == "string"), schema)
        target["enum"] = sorted(choices)

    return extra


def _overrides_schema(schema: dict[str, Any]) -> None:
    description = schema.get("description")
    schema.clear()
    schema.update(overrides_json_schema(), description=description)


class TrainSpec(SpecBase):
    """`dualsys train` options; None keeps the profile's value (see core.config).

    As in `dualsys train` (dualsys_cli/train.py), the named options are applied after `overrides`.
    """

    algo: str | None = Field(
        default=None,
        min_length=1,
        max_length=32,
        description="Method name (--algo).",
        json_schema_extra=_choices(lambda: _algo_names()),
    )
    reward: Literal["dense", "sparse"] | None = Field(
        default=None, description="Extrinsic reward (--reward)."
    )
    seed: int | None = Field(default=None, ge=0, le=2**31 - 1, description="Run seed (--seed).")
    episodes: int | None = Field(default=None, ge=1, le=10_000_000, description="Training episodes.")
    steps: int | None = Field(default=None, ge=1, le=1_000_000_000, description="Training env steps.")
    minutes: float | None = Field(
        default=None, gt=0, le=525_600, description="Wall-clock budget (--minutes)."
    )
    profile: str = Field(
        default="auto",
        min_length=1,
        max_length=32,
        description="Config profile; auto (as `dualsys train`): vector for a task with vector observations, "
        "default otherwise.",
        json_schema_extra=_choices(lambda: _config_profiles()),
    )
    overrides: dict[str, Any] = Field(
        default_factory=dict,
        max_length=200,
        description='Config overrides with typed values, e.g. {"agent.batch_size": 32, "net.conv_channels": '
        "[8, 8]}; every key of core.config with its type and range.",
        json_schema_extra=_overrides_schema,
    )
    ac: Literal["ddpg", "cacla", "td3", "sac"] | None = Field(
        default=None, description="The learner (--ac): ddpg, cacla, td3 or sac."
    )

    @field_validator("profile")
    @classmethod
    def _known_profile(cls, value: str) -> str:
        profiles = _config_profiles()
        if profiles is not None and value not in profiles:
            raise ValueError(f"unknown profile {value!r} (choose from {', '.join(sorted(profiles))})")
        return value

    @field_validator("algo")
    @classmethod
    def _known_algo(cls, value: str | None) -> str | None:
        names = _algo_names()
        if value is not None and names is not None and value not in names:
            raise ValueError(f"unknown algo {value!r} (choose from {', '.join(sorted(names))})")
        return value

    @field_validator("overrides")
    @classmethod
    def _valid_overrides(cls, value: dict[str, Any], info: ValidationInfo) -> dict[str, Any]:
        check_overrides(value)  # keys, JSON types and ranges, as the schema states them
        items = [f"{key}={_override_text(raw)}" for key, raw in value.items()]
        message = _config_error(info.data.get("profile", "default"), items)
        if message:
            raise ValueError(message)
        return value

    def config_overrides(self) -> list[str]:
        """The spec as `key=value` overrides of `core.config.load_config` (options after overrides)."""
        items = [f"{key}={_override_text(raw)}" for key, raw in self.overrides.items()]
        options = {
            "run.algo": self.algo,
            "env.reward_mode": self.reward,
            "run.seed": self.seed,
            "run.episodes": self.episodes,
            "run.steps": self.steps,
            "agent.ac": self.ac,
        }
        if self.minutes is not None:
            options["run.max_wall_s"] = self.minutes * 60.0
        items += [f"{key}={_override_text(value)}" for key, value in options.items() if value is not None]
        if self.episodes is None and (self.steps is not None or self.minutes is not None):
            items.append("run.episodes=none")  # as `dualsys train`: --steps/--minutes alone set the budget
        return items


class AlignSpec(SpecBase):
    """`dualsys align` options: fine-tune a policy's encoder on paired sim/real images (Section 4.2)."""

    policy: str = Field(
        pattern=POLICY_REF.pattern, description="Source policy: name, name@VERSION or name@ALIAS."
    )
    pairs_dir: str = Field(
        pattern=r"^[^\x00]+$",
        min_length=1,
        max_length=4096,
        description="Folder of paired sim/real images on the server (404 when there is none).",
    )
    epochs: int | None = Field(default=None, ge=1, le=100_000)
    batch_size: int | None = Field(default=None, ge=1, le=65_536)
    name: str | None = Field(
        default=None, pattern=POLICY_NAME.pattern, description="Registered name of the aligned policy."
    )


class EvalSpec(SpecBase):
    """`dualsys eval` options: the 8-step grasp-trial evaluator (Table 2 protocol)."""

    policy: str = Field(pattern=POLICY_REF.pattern, description="Policy: name, name@VERSION or name@ALIAS.")
    trials: int = Field(default=25, ge=1, le=100_000)
    max_steps: int = Field(default=8, ge=1, le=10_000)
    domain: Literal["sim", "real"] = "sim"
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    onnx: bool = Field(default=False, description="Evaluate the exported ONNX instead of the checkpoint.")


class ExportSpec(SpecBase):
    """`dualsys export` options: encoder + actor to ONNX, checked against PyTorch."""

    policy: str = Field(pattern=POLICY_REF.pattern, description="Policy: name, name@VERSION or name@ALIAS.")
    out: str = Field(
        default="policy.onnx",
        pattern=ONNX_FILE_NAME,
        description="ONNX file name inside the job's run directory (a plain name ending in .onnx).",
    )


class ProbeSpec(SpecBase):
    """The diagnostic kind: `episodes` synthetic records, one every `interval_s` seconds."""

    episodes: int = Field(default=5, ge=1, le=100_000)
    interval_s: float = Field(default=0.1, ge=0.0, le=60.0)
    fail_at_episode: int | None = Field(
        default=None,
        ge=1,
        le=100_000,
        description="Raise an error at this episode (beyond `episodes`: the run ends first and succeeds).",
    )


SPEC_MODELS: dict[str, type[SpecBase]] = {
    "train": TrainSpec,
    "align": AlignSpec,
    "eval": EvalSpec,
    "export": ExportSpec,
    "probe": ProbeSpec,
}


# ------------------------------------------------------------------ checks against core.config
def _config_profiles() -> set[str] | None:
    try:
        from core.config import PROFILES
        from core.runs.profile_choice import AUTO_PROFILE
    except ImportError:  # pragma: no cover - core not installed
        return None
    return {*PROFILES, AUTO_PROFILE}


def _algo_names() -> set[str] | None:
    """Method names the trainer knows (`core.runs.methods.ALGOS`), or None if unavailable."""
    try:
        from core.runs.methods import ALGOS
    except ImportError:
        return None
    return set(ALGOS)


def _config_error(profile: str, overrides: list[str]) -> str | None:
    try:
        from core.config import ConfigError, load_config
        from core.runs.profile_choice import AUTO_PROFILE
    except ImportError:  # pragma: no cover - core not installed
        return None
    try:
        # auto's choice needs the env built: prepare_train resolves it
        known = (_config_profiles() or {profile}) - {AUTO_PROFILE}
        load_config(profile if profile in known else "default", overrides)
    except ConfigError as error:
        return str(error)
    return None


def warm_up_validators() -> None:
    """Import what the train-spec validators need (the method registry imports torch), then move
    every object allocated so far out of the garbage collector's sight (`gc.freeze`): with torch
    loaded, each full collection would otherwise walk millions of long-lived objects and stall
    requests for tens of milliseconds."""
    import gc

    _config_profiles()
    _algo_names()
    with contextlib.suppress(ImportError):  # POST /experiments validates with it
        import core.experiments  # noqa: F401
    gc.collect()
    gc.freeze()
