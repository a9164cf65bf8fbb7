"""dualsys job service, grouped by the process that runs each part (see docs/service.md, Layout).

- `service.api` — the API process(es): the REST app (`api/app.py`), routes, errors, presenters, server-sent
  events, the body size limit.
- `service.ui` — the dashboard's pages, served by the same API process(es); neither it nor `service.api`
  imports the other (what both need is `deps.py`; `server.create_app` puts them together).
- `service.execution` — the supervisor thread (claims, starts, follows and recovers jobs; it runs in the
  API process, or in the parent process when `api_processes > 1`), its executors, and what runs inside a
  job's own process (`execution/worker.py`, a Ray task): the job kinds.
- `service.database` — the tables, their migrations and the queries on them (job and experiment
  stores, the API's batched job inserts), used by the API processes and the supervisor; a job's process
  never opens the database.

Beside them, modules that belong to no single process:
- `schemas/` — the request and spec models: the API validates requests with them, the job kinds read
  their specs from them and `dualsys jobs` builds overrides with them (under `api/` they would make
  `execution` import the API layer);
- `deps.py` — the dependencies the API's routes and the dashboard's pages share (service state, bearer
  token), below both;
- `settings.py` — `DUALSYS_*` settings, read by every service process;
- `errors.py` — the errors a client can cause, raised in every layer and mapped to HTTP by `api/errors.py`;
- `server.py` — the launcher (`dualsys serve`, `python -m service.server`): composes the API process's app
  (`create_app`: the API and the dashboard), starts uvicorn with the API process(es) and, with several, runs
  the supervisor in the parent process;
- `client.py` — the HTTP client, run in the user's process (`dualsys jobs`, benchmarks); it imports
  nothing else of the service.
"""
