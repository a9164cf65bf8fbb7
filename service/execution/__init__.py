"""Running jobs: the supervisor thread, its executors, and the code of a job's own process.

- In the supervisor's process (the API process, or the parent process of several API processes, see
  `service.server`): `supervisor.py`, `executors/` (`local`: a process per job; `ray`: a Ray task per
  job), `job_follower.py` and `job_recorder.py` (a running job's events written to the database).
- In a job's own process (`python -m service.execution.worker`, or a Ray task): `worker.py`,
  `executors/ray_task.py`, `job_execution.py` and the kinds' `run` functions (`job_kinds/`); none of
  them opens the database.
- `job_kinds/` is read in the API process too (a submission's `prepare` step) and in the supervisor's
  (`after_success`, `can_resume`).
"""
