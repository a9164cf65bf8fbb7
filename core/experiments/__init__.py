"""Experiments: the paper's comparisons as data — multi-seed grids of methods × reward modes, run in
parallel (local processes or Ray tasks), resumable, and reported with rliable statistics and Fig. 8-style
learning curves. No HTTP and no CLI here: ``dualsys experiment`` and the job service call these functions.
May import every other package of ``core`` (it sits on ``core.runs``); nothing in ``core`` imports it.
Inside, the modules stack: spec → runners → sb3_zoo → sb3_settings → sb3_peer → dispatch → cells →
runner/local/ray → report → archive.

* :func:`load_experiment` (``cells``) — read and validate an experiment file, every cell's config resolved.
* :func:`expand_cells` / :func:`plan_experiment` — the grid's cells and their run directories.
* :func:`run_experiment` (``runner``) — run what is not done; idempotent and resumable.
* :func:`build_report` / :func:`write_report` (``report``) — statistics, report.md and figures.
* :func:`~core.experiments.archive.archive_experiment` — the done cells' numbers, no checkpoints, for git.
"""

from core.experiments.cells import Cell, cell_state, expand_cells, experiment_dir, load_experiment, run_cell
from core.experiments.dispatch import register_cell_runner
from core.experiments.progress import CellProgress, ExperimentProgress
from core.experiments.report import build_report, write_report
from core.experiments.runner import ExperimentPlan, ExperimentResult, plan_experiment, run_experiment
from core.experiments.runners import CellRunner
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec

__all__ = [
    "Cell",
    "CellProgress",
    "CellRunner",
    "ExperimentError",
    "ExperimentPlan",
    "ExperimentProgress",
    "ExperimentResult",
    "ExperimentSpec",
    "MethodSpec",
    "build_report",
    "cell_state",
    "expand_cells",
    "experiment_dir",
    "load_experiment",
    "plan_experiment",
    "register_cell_runner",
    "run_cell",
    "run_experiment",
    "write_report",
]
