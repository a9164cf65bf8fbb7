"""Service errors a client can cause; the API maps each to a status code and a JSON body."""

from __future__ import annotations


class ServiceError(Exception):
    """A user-level error with an HTTP status; `field` names the offending request field if any."""

    status_code = 400

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class JobNotFound(ServiceError):
    status_code = 404


class JobConflict(ServiceError):
    """The job's state forbids the request (cancel a finished job, delete a running one)."""

    status_code = 409


class SpecRejected(ServiceError):
    """A request whose content breaks a rule the schema cannot state (a bad experiment file)."""

    status_code = 422


class SpecTargetNotFound(ServiceError):
    """A spec names something the service does not have (a policy, a version, a pairs folder): 404, as
    for a path that names it. A schema-valid request is never a 422."""

    status_code = 404


class SpecTargetConflict(ServiceError):
    """A spec names something whose state forbids the job (a policy version with no checkpoint)."""

    status_code = 409


class LostOwnership(RuntimeError):
    """A worker found that its job was recovered or cancelled by someone else: it must stop."""
