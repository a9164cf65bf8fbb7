"""The function a Ray task runs for one job: a generator streaming its records back to the driver.

The job runs in a thread of the Ray worker; the generator yields each episode record as it comes,
a heartbeat when none came for `heartbeat_s`, and finally the summary.

Acknowledged records, as with the local worker: the task is started with a generator back-pressure
of one object, so each `yield` returns only once the driver has taken that item. After a record
the generator yields a `barrier`; the driver takes the barrier only after it has committed the
record, so when the barrier's `yield` returns the record is in the database, and only then does
`emit` return to the job (which then writes the checkpoint covering it). The driver (the service's
`RayExecutor`) writes them to the database, so metrics flow into the same tables as with the local
executor, and the task itself needs no database access: only the artifact root, which must be a
filesystem the cluster's workers share with the service (the local Ray of `ray.init()` does).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any


def run_job_stream(
    job_id: int,
    kind: str,
    spec: dict[str, Any],
    resolved: dict[str, Any],
    run_dir: str,
    resume: bool,
    heartbeat_s: float,
) -> Iterator[dict[str, Any]]:
    from service.execution.job_execution import execute_job
    from service.execution.json_values import jsonable

    items: queue.Queue[tuple[str, Any]] = queue.Queue()

    def emit(record: dict[str, Any]) -> None:
        committed = threading.Event()
        items.put(("metric", (record, committed)))
        committed.wait()

    def work() -> None:
        try:
            summary = execute_job(
                job_id=job_id,
                kind=kind,
                spec=spec,
                resolved=resolved,
                run_dir=Path(run_dir),
                resume=resume,
                emit=emit,
                should_stop=lambda: False,  # Ray cancels the task's process instead
            )
            items.put(("result", summary))
        except BaseException as error:  # handed to the driver as the task's exception
            items.put(("error", error))

    threading.Thread(target=work, name=f"dualsys-job-{job_id}", daemon=True).start()
    while True:
        try:
            tag, payload = items.get(timeout=heartbeat_s)
        except queue.Empty:
            yield {"type": "heartbeat"}
            continue
        if tag == "metric":
            record, committed = payload
            yield {"type": "metric", "record": jsonable(record)}
            yield {"type": "barrier"}  # returns once the driver has committed the record
            committed.set()
        elif tag == "result":
            yield {"type": "result", "summary": jsonable(payload)}
            return
        else:
            raise payload
