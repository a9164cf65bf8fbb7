"""The API process's layer: the REST app (`app.py`), one router per resource, errors, presenters, events and
limits. The dependencies it shares with the dashboard (`service.ui`, which it never imports) are
`service.deps`; `service.server.create_app` installs the dashboard beside it.

Run by each API process (`dualsys serve`, one by default, `api_processes` under `service.server`). It
reaches the rest of the service through `service.database` (queries and inserts) and, from
`service.execution`, only the supervisor (started by the app when `run_jobs`) and the job kinds (a
submission's `prepare` step).
"""
