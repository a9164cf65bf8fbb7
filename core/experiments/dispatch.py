"""Which cell runner trains a method: the shared trainer for the methods of ``core.runs.methods``, the
Stable-Baselines3 runner for the SB3 peers, or a runner a user registers for an algorithm family of their own.
"""

from __future__ import annotations

from core.experiments.runners import TRAINER_RUNNER, CellRunner
from core.experiments.sb3_peer import SB3Runner
from core.experiments.sb3_settings import SB3_ALGOS
from core.experiments.spec import ExperimentError
from core.runs.methods import ALGOS

CELL_RUNNERS: dict[str, CellRunner] = {name: SB3Runner(name) for name in SB3_ALGOS}
"""Runners of the algo names outside ``core.runs.methods``."""


def register_cell_runner(algo: str, runner: CellRunner) -> None:
    """Run cells whose method has ``algo`` with ``runner`` (replaces an earlier registration)."""
    CELL_RUNNERS[algo] = runner


def runner_for(algo: str, where: str = "algo") -> CellRunner:
    """The runner of ``algo``: a registered family first, then the shared trainer for the methods."""
    if algo in CELL_RUNNERS:
        return CELL_RUNNERS[algo]
    if algo in ALGOS:
        return TRAINER_RUNNER
    known = sorted({*ALGOS, *CELL_RUNNERS})
    raise ExperimentError(f"bad value for {where}: unknown algo {algo!r} (choose from {', '.join(known)})")
