"""Cell runners: the code that trains one cell of an experiment.

A cell runner turns (experiment, method, reward, seed) into a resolved config (a plain nested dict, stored
as the cell's ``config.yaml``) and trains it into a run directory, resuming from ``checkpoints/latest.pt``
when asked. Every method of ``core.runs.methods`` runs through :data:`TRAINER_RUNNER` (the shared
``core.runs.trainer.train`` loop); the Stable-Baselines3 peers have their own (``sb3_peer``), and
``dispatch`` says which runner an ``algo`` takes.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from core.config import ConfigError
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec

if TYPE_CHECKING:
    from core.config import Config

EpisodeCallback = Callable[[dict[str, Any]], None]

IGNORED_FOR_COMPARISON: frozenset[str] = frozenset(
    {"run.device", "run.num_threads", "run.checkpoint_every", "run.checkpoint_every_s"}
)
"""Resolved-config keys that do not change a cell's results, so a rerun may change them freely."""


class CellRunner(Protocol):
    """What the experiment runner needs from an algorithm family."""

    def resolve(self, spec: ExperimentSpec, method: MethodSpec, reward: str, seed: int) -> dict[str, Any]:
        """The cell's full resolved config as a nested dict; raises ConfigError naming a bad key."""
        ...

    def normalise(self, stored: Mapping[str, Any]) -> dict[str, Any]:
        """A stored config.yaml brought to the current schema (defaults for keys added since)."""
        ...

    def train(
        self,
        config: Mapping[str, Any],
        run_dir: Path,
        *,
        resume: bool,
        should_stop: Callable[[], bool] | None,
        on_episode: EpisodeCallback | None,
        command: str,
    ) -> dict[str, Any]:
        """Train (or resume) the cell into ``run_dir``; returns the summary written to summary.json."""
        ...


class ConfigCellRunner:
    """What the cell runners of ``core.config`` configs share; a subclass gives ``resolve`` (usually through
    :meth:`_checked_config`) and :meth:`training_function`.

    ``normalise`` brings a stored config.yaml to the ``Config`` schema; ``train`` rebuilds the ``Config``
    and hands it, with the run directory and the keyword arguments of :meth:`CellRunner.train`, to the
    training function.
    """

    def training_function(self) -> Callable[..., dict[str, Any]]:
        """``f(config, run_dir, *, resume, on_episode, should_stop, command) -> summary``, the signature of
        ``core.runs.trainer.train``."""
        raise NotImplementedError

    def normalise(self, stored: Mapping[str, Any]) -> dict[str, Any]:
        from core.config import Config
        from core.dual.readings import upgrade_stored

        return Config.from_dict(upgrade_stored(stored)).to_dict()

    def train(self, config: Mapping[str, Any], run_dir: Path, **options: Any) -> dict[str, Any]:
        """:meth:`CellRunner.train`; ``options`` are its ``resume``, ``should_stop``, ``on_episode`` and
        ``command``, passed on as they come."""
        from core.config import Config
        from core.dual.readings import upgrade_stored

        return self.training_function()(Config.from_dict(upgrade_stored(config)), run_dir, **options)

    @staticmethod
    def _checked_config(method: MethodSpec, reward: str, build: Callable[[], Config]) -> dict[str, Any]:
        """``build()``'s config, checked, as the cell's nested dict; a ConfigError (from either) becomes the
        ExperimentError that names the method and the reward."""
        from core.config import check_config

        try:
            config = build()
            check_config(config)
        except ConfigError as exc:
            raise ExperimentError(f"method {method.label!r}, {reward} reward: {exc}") from None
        return config.to_dict()


class TrainerRunner(ConfigCellRunner):
    """Cells of the methods in ``core.runs.methods``: ``core.config`` + ``core.runs.trainer.train``."""

    def training_function(self) -> Callable[..., dict[str, Any]]:
        from core.runs.trainer import train

        return train

    def resolve(self, spec: ExperimentSpec, method: MethodSpec, reward: str, seed: int) -> dict[str, Any]:
        from core.config import load_config
        from core.runs.methods import resolve_algo

        extra = {"agent.ac": method.ac} if method.ac is not None else {}
        items = cell_overrides(spec, method, reward, seed, algo=method.algo, extra=extra)

        def build() -> Config:
            config = resolve_algo(load_config(spec.profile, items))
            if method.ac is not None and config.agent.ac != method.ac:
                raise ConfigError(
                    f"bad value for ac: {method.algo} always uses the {config.agent.ac} actor update"
                )
            return config

        return self._checked_config(method, reward, build)


def _raw(value: Any) -> str:
    """A YAML value as the text of a ``--set key=value`` override."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return ",".join(str(item) for item in value)
    return str(value)


def cell_overrides(
    spec: ExperimentSpec,
    method: MethodSpec,
    reward: str,
    seed: int,
    *,
    algo: str,
    extra: Mapping[str, Any] | None = None,
) -> list[str]:
    """The ``key=value`` overrides of one cell: the file's and the method's, then what the experiment sets
    per cell (algo, seed, the env-step budget, evaluation; NicoGrasp's level and reward, or another env's id
    and kwargs; single-threaded), then `extra`."""
    cell_keys: dict[str, Any] = {
        "run.algo": algo,
        "run.seed": seed,
        "run.steps": spec.steps,
        "run.episodes": "none",
        "run.max_wall_s": "none",
        "run.eval_every": spec.eval_every,
        "run.eval_episodes": spec.eval_episodes,
        "run.num_threads": 1,
        **(
            {"env.reward_mode": reward, "env.level": spec.level}
            if spec.nico_grasp
            else {"env.id": spec.env, "env.kwargs": json.dumps(dict(spec.env_kwargs))}
        ),
        **(extra or {}),
    }
    merged = {**spec.overrides, **method.overrides}
    return [f"{key}={_raw(value)}" for key, value in (*merged.items(), *cell_keys.items())]


TRAINER_RUNNER = TrainerRunner()
