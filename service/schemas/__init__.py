"""Pydantic schemas of the REST API, one module per resource (jobs, job specs, policies, errors).

Shared by several processes, hence beside `api/` rather than in it: the API processes validate requests
with them, the job kinds (`service.execution`, in a job's own process too) re-read their specs with them,
and the CLI builds `dualsys jobs` overrides with them. They import nothing else of the service.
"""
