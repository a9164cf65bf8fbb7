"""The API process's layer: the FastAPI app (`app.py`), one router per resource, shared dependencies,
errors, presenters, events and limits.

Run by each API process (`dualsys serve`, one by default, `api_processes` under `service.server`). It
reaches the rest of the service through `service.database` (queries and inserts) and, from
`service.execution`, only the supervisor (started by the app when `run_jobs`) and the job kinds (a
submission's `prepare` step).
"""
