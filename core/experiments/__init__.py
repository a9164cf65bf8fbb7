"""Experiments: the paper's comparisons as data — multi-seed grids of methods × reward modes, run in
parallel (local processes or Ray tasks), resumable, and reported with rliable statistics and Fig. 8-style
learning curves. No HTTP and no CLI here: ``dualsys experiment`` and the job service call these functions.

* :func:`load_experiment` (``spec``) — read and validate an experiment file.
* :func:`expand_cells` / :func:`plan_experiment` — the grid's cells and their run directories.
* :func:`run_experiment` (``runner``) — run what is not done; idempotent and resumable.
* :func:`build_report` / :func:`write_report` (``report``) — statistics, report.md and figures.
"""

from core.experiments.cells import Cell, cell_state, expand_cells, experiment_dir, run_cell
from core.experiments.progress import CellProgress, ExperimentProgress
from core.experiments.report import build_report, write_report
from core.experiments.runner import ExperimentPlan, ExperimentResult, plan_experiment, run_experiment
from core.experiments.runners import CellRunner, register_cell_runner
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec, load_experiment

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
