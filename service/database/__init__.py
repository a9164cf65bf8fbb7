"""The service's tables and everything that queries them.

`models.py` (SQLAlchemy tables), `migrations/` (Alembic, version table `alembic_version_service`) and
`migrate.py` (`alembic upgrade head` at start), `job_store.py` (the queue's operations),
`experiment_store.py` (experiments and their cells), `job_inserter.py` (the API's batched job inserts).

Used by the API processes and by the supervisor's process (`service.execution`), never by a job's own
process. It imports nothing of `service.api`, `service.execution` or `service.ui`.
"""
