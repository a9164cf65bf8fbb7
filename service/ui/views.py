"""What the dashboard shows of a job: plain dicts for the templates, computed from job rows.

A job row (ORM object or Core row) holds the spec as submitted and, for `train`, the resolved config
(`resolved.config`, sections `run`, `env`, `agent`, ...). The jobs table reads method, task, reward, level
and seed from the resolved config first, then from the spec (`spec.algo`, `spec.overrides`), so a
key added to the config later (`env.level`) shows up without a change here. Reward modes and task levels
are NicoGrasp's: another task (`env.id`, e.g. MountainCarContinuous-v0) shows its own reward (`task`, as
its summaries name it) and no level.

"Current success" is the greedy evaluation's success rate (`eval/success_rate`, the paper's measure)
when the job has one, else the training episodes' success over the last `TRAIN_WINDOW` episodes,
labelled as such. Finished train jobs carry it in their summary; for queued and running jobs
`SuccessTracker` reads only the metric rows written since its last look, so polling the jobs page
costs a few rows per running job instead of its history.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from core.config import NICO_GRASP_ID
from registry.database import Database
from service.database import job_store
from service.database.models import FINISHED_STATUSES

TRAIN_WINDOW = 100
"""Training episodes averaged for the fallback success figure (as the summary's `..._last100`)."""
FIRST_LOOK_ROWS = 1000
"""How far back the first look at a running job goes for its last greedy evaluation."""
MAX_TRACKED = 500
"""Jobs remembered by `SuccessTracker` before it forgets all but the ones on the page it serves."""
RELEASED_LEVEL = "released"
"""What the table shows for a NicoGrasp train job whose config names no `env.level` (the released task)."""
TASK_REWARD = "task"
"""What the table shows as the reward of another task: the env's own (`EnvConfig.reward_label`)."""

STATUS_ORDER = ("queued", "running", "succeeded", "failed", "cancelled")


def _config_value(job: Any, section: str, key: str) -> Any:
    config = (job.resolved or {}).get("config") or {}
    value = (config.get(section) or {}).get(key) if isinstance(config, Mapping) else None
    if value is not None:
        return value
    spec = job.spec or {}
    overrides = spec.get("overrides") or {}
    return overrides.get(f"{section}.{key}")


def job_method(job: Any) -> str | None:
    algo = _config_value(job, "run", "algo") or (job.spec or {}).get("algo")
    ac = _config_value(job, "agent", "ac") or (job.spec or {}).get("ac")
    if algo and ac and algo in ("ddpg", "cacla", "td3", "sac") and ac != algo:
        return f"{algo} ({ac})"
    return algo


def job_env(job: Any) -> str | None:
    """The train job's gymnasium id (NicoGrasp unless its config or overrides name another)."""
    env = _config_value(job, "env", "id") or (job.spec or {}).get("env")
    if env is not None:
        return str(env)
    return NICO_GRASP_ID if job.kind == "train" else None


def _other_task(job: Any) -> bool:
    env = job_env(job)
    return env is not None and env != NICO_GRASP_ID


def job_reward(job: Any) -> str | None:
    if _other_task(job):
        return TASK_REWARD
    return _config_value(job, "env", "reward_mode") or (job.spec or {}).get("reward")


def job_level(job: Any) -> str | None:
    """NicoGrasp's task level; None for another task (levels are NicoGrasp's) and for other kinds."""
    if _other_task(job):
        return None
    level = _config_value(job, "env", "level") or (job.spec or {}).get("level")
    if level is not None:
        return str(level)
    return RELEASED_LEVEL if job.kind == "train" else None


def job_seed(job: Any) -> int | None:
    seed = _config_value(job, "run", "seed")
    return seed if seed is not None else (job.spec or {}).get("seed")


def age_text(moment: datetime | None, now: datetime | None = None) -> str:
    """`42 s`, `7 min`, `3 h`, `12 d` since `moment` (UTC)."""
    if moment is None:
        return ""
    now = now or datetime.now(UTC)
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=UTC)
    seconds = max(0.0, (now - moment).total_seconds())
    if seconds < 60:
        return f"{int(seconds)} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min"
    if seconds < 86400:
        return f"{int(seconds // 3600)} h"
    return f"{int(seconds // 86400)} d"


def _finite(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


@dataclass(frozen=True)
class Success:
    value: float
    source: str  # "eval" (greedy evaluation) or "train" (training episodes)
    note: str

    @property
    def text(self) -> str:
        return f"{self.value:.2f}"


def summary_success(summary: Mapping[str, Any] | None) -> Success | None:
    """The figure a finished job recorded in its summary (`success_rate`, else training success)."""
    if not summary:
        return None
    value = _finite(summary.get("success_rate"))
    if value is not None:
        return Success(value, "eval", "greedy evaluation (final)")
    value = _finite(summary.get("train_success_rate_last100"))
    if value is not None:
        return Success(value, "train", "training episodes, last 100")
    return None


@dataclass
class _Seen:
    attempt: int
    episode: int = 0
    eval_value: float | None = None
    eval_episode: int = 0
    successes: deque[float] = field(default_factory=lambda: deque(maxlen=TRAIN_WINDOW))


class SuccessTracker:
    """Per-process memory of each active job's last evaluation and recent training successes."""

    def __init__(self) -> None:
        self._seen: dict[int, _Seen] = {}
        self._lock = threading.Lock()

    def current(self, database: Database, jobs: Iterable[Any]) -> dict[int, Success]:
        jobs = list(jobs)
        out: dict[int, Success] = {}
        active = []
        for job in jobs:
            recorded = summary_success(job.summary) if job.status in FINISHED_STATUSES else None
            if recorded is not None:
                out[job.id] = recorded
            elif job.progress_episode > 0:
                active.append(job)
        with self._lock:
            for job in jobs:
                if job.status in FINISHED_STATUSES:
                    self._seen.pop(job.id, None)
            if len(self._seen) > MAX_TRACKED:  # jobs that finished while nobody looked at them
                keep = {job.id for job in active}
                self._seen = {k: v for k, v in self._seen.items() if k in keep}
            if active:
                self._read_new_rows(database, active)
            for job in active:
                seen = self._seen.get(job.id)
                if seen is None:
                    continue
                if seen.eval_value is not None:
                    out[job.id] = Success(
                        seen.eval_value, "eval", f"greedy evaluation at episode {seen.eval_episode}"
                    )
                elif seen.successes:
                    mean = sum(seen.successes) / len(seen.successes)
                    out[job.id] = Success(mean, "train", f"training episodes, last {len(seen.successes)}")
        return out

    def _read_new_rows(self, database: Database, jobs: list[Any]) -> None:
        since: dict[int, int] = {}
        for job in jobs:
            seen = self._seen.get(job.id)
            if seen is None or seen.attempt != job.attempt or seen.episode > job.progress_episode:
                # first look, or a resumed attempt that may have rewritten episodes: start over
                seen = self._seen[job.id] = _Seen(attempt=job.attempt)
                seen.episode = max(0, job.progress_episode - FIRST_LOOK_ROWS)
            if seen.episode < job.progress_episode:
                since[job.id] = seen.episode
        for job_id, episode, data in job_store.metrics_after(database, since=since):
            seen = self._seen[job_id]
            seen.episode = max(seen.episode, episode)
            value = _finite(data.get("eval/success_rate"))
            if value is not None:
                seen.eval_value, seen.eval_episode = value, episode
            success = _finite(data.get("charts/success"))
            if success is not None:
                seen.successes.append(success)


def job_row(job: Any, success: Success | None, now: datetime) -> dict[str, Any]:
    """One line of the jobs table."""
    total = job.progress_total
    episode = job.progress_episode
    fraction = min(1.0, episode / total) if total else None
    return {
        "id": job.id,
        "kind": job.kind,
        "method": job_method(job),
        "env": job_env(job),
        "reward": job_reward(job),
        "level": job_level(job),
        "seed": job_seed(job),
        "status": job.status,
        "cancel_requested": bool(job.cancel_requested),
        "episode": episode,
        "total": total,
        "fraction": fraction,
        "success": success,
        "age": age_text(job.created_at, now),
        "created_at": job.created_at,
        "reason": job.reason,
    }


def flatten_config(config: Mapping[str, Any]) -> list[tuple[str, list[tuple[str, Any]]]]:
    """`{"run": {"algo": "i2a"}}` → `[("run", [("algo", "i2a")])]`, sections in order, keys sorted."""
    sections = []
    for section, values in config.items():
        if isinstance(values, Mapping):
            sections.append((str(section), sorted((str(k), v) for k, v in values.items())))
        else:
            sections.append((str(section), [("", values)]))
    return sections


DIAGNOSTIC_LAYOUT: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("model error", "prediction error", ("dual/model_error",)),
    (
        "model-based vs model-free decisions",
        "decisions per episode",
        ("dual/mb_decisions", "dual/mf_decisions"),
    ),
    ("planning horizon", "steps", ("dual/horizon",)),
    ("ITM size", "nodes", ("dual/itm_nodes",)),
    ("imagined transitions", "per episode", ("dual/imagined",)),
    (
        "intrinsic reward: per step, and over the regions (mean, spread)",
        "reward",
        ("dual/intrinsic_reward", "dual/region_rint_mean", "dual/region_rint_std"),
    ),
    (
        "critic's start-state value vs discounted return earned",
        "discounted return",
        ("charts/start_value", "charts/discounted_return", "eval/start_value", "eval/discounted_return"),
    ),
)
"""The job page's diagnostics panels: (title, y-axis unit, metric keys drawn together)."""

VALUE_LABELS = {
    "charts/start_value": "critic's value of the start state",
    "charts/discounted_return": "discounted return earned",
    "eval/start_value": "greedy: critic's value of the start",
    "eval/discounted_return": "greedy: discounted return earned",
}
"""Legend names of the overestimation pairs (the diagnostics PNG does not draw them)."""


def diagnostic_groups() -> list[dict[str, Any]]:
    """The panels with the legend names of `core.dual.diagnostics_panel` (the learning-curve PNG's) and of
    `VALUE_LABELS`: every drawn series has a name a person reads, never a metrics.csv column.

    A key that panel draws but the layout does not name gets a panel of its own, so the browser never
    shows less than the PNG.
    """
    from core.dual.diagnostics_panel import PANEL_KEYS

    labels = {**dict(PANEL_KEYS), **VALUE_LABELS}
    groups = [
        {"title": title, "unit": unit, "series": [[key, labels[key]] for key in keys]}
        for title, unit, keys in DIAGNOSTIC_LAYOUT
    ]
    placed = {key for _, _, keys in DIAGNOSTIC_LAYOUT for key in keys}
    groups += [
        {"title": label, "unit": "", "series": [[key, label]]}
        for key, label in PANEL_KEYS
        if key not in placed
    ]
    return groups
