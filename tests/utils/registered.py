"""Factory: a policy version in a live service's registry, registered through the Python API.

Over REST a version is registered only from a succeeded job with a checkpoint (a training run); the
dashboard tests need versions in seconds, so they register a small real run directory
(`tests.utils.run_dirs.make_run_dir`) on the service's own SQLite file and artifact root, as
`dualsys registry register NAME RUN_DIR` does.
"""

from __future__ import annotations

import itertools
from pathlib import Path

from registry import PolicyRegistry
from registry.records import PolicyVersionRecord
from tests.utils.live_service import LiveService
from tests.utils.run_dirs import make_run_dir

_runs = itertools.count(1)


def register_version(
    service: LiveService,
    name: str,
    *,
    source_job_id: int | None = None,
    parent: str | None = None,
    tags: dict[str, str] | None = None,
    description: str = "",
) -> PolicyVersionRecord:
    run_dir = make_run_dir(service.folder / "runs" / f"{name}-{next(_runs)}", seed=next(_runs))
    registry = PolicyRegistry.open(service.settings["database_url"], Path(service.settings["artifacts"]))
    try:
        return registry.register_run(
            name, run_dir, source_job_id=source_job_id, parent=parent, tags=tags, description=description
        )
    finally:
        registry.database.dispose()
