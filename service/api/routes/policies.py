"""`/policies`: the registry over REST (register from a finished job, aliases, tags, downloads)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Response, status
from fastapi.responses import FileResponse

from registry.errors import VersionNotFound
from registry.references import ALIAS_NAME, POLICY_NAME
from service import job_store
from service.api.deps import MutationAuth, StateDep
from service.errors import JobConflict
from service.schemas.errors import ErrorPublic
from service.schemas.policies import (
    AliasSet,
    PoliciesPublic,
    PolicyPublic,
    PolicyVersionPublic,
    TagSet,
    VersionCreate,
)

router = APIRouter(prefix="/policies", tags=["policies"])
Name = Annotated[str, Path(pattern=POLICY_NAME.pattern, description="Policy name.")]
Alias = Annotated[str, Path(pattern=ALIAS_NAME.pattern, description="Alias name, e.g. champion.")]
Selector = Annotated[str, Path(max_length=40, description="A version number or an alias.")]
ERRORS = {
    400: {"model": ErrorPublic},
    401: {"model": ErrorPublic},
    404: {"model": ErrorPublic},
    409: {"model": ErrorPublic},
    422: {"model": ErrorPublic},
}


@router.get("", response_model=PoliciesPublic, responses=ERRORS)
def list_policies(state: StateDep) -> PoliciesPublic:
    records = state.registry.list_policies()
    return PoliciesPublic(data=[PolicyPublic.of(r) for r in records], count=len(records))


@router.get("/{name}", response_model=PolicyPublic, responses=ERRORS)
def get_policy(name: Name, state: StateDep) -> PolicyPublic:
    return PolicyPublic.of(state.registry.get_policy(name))


@router.post(
    "/{name}/versions",
    status_code=status.HTTP_201_CREATED,
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def register_version(name: Name, body: VersionCreate, state: StateDep) -> PolicyVersionPublic:
    """Register a succeeded job's run directory as the next version of `name`."""
    job = job_store.get_job(state.database, job_id=body.job_id)
    if job.status != "succeeded":
        raise JobConflict(
            f"job {job.id} is {job.status}; only a succeeded job can be registered", field="job_id"
        )
    run_dir = state.registry.store.confine(job.run_dir)
    record = state.registry.register_run(
        name,
        run_dir,
        source_job_id=job.id,
        parent=body.parent,
        tags={"job_kind": job.kind, **body.tags},
        description=body.description,
    )
    return PolicyVersionPublic.of(record)


@router.get("/{name}/versions/{version}", response_model=PolicyVersionPublic, responses=ERRORS)
def get_version(name: Name, version: Selector, state: StateDep) -> PolicyVersionPublic:
    """A version by number, or by alias (`/policies/grasp/versions/champion`)."""
    return PolicyVersionPublic.of(state.registry.resolve(f"{name}@{version}"))


@router.put(
    "/{name}/aliases/{alias}",
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def set_alias(name: Name, alias: Alias, body: AliasSet, state: StateDep) -> PolicyVersionPublic:
    """Point `name@alias` at a version (creates or moves the alias)."""
    return PolicyVersionPublic.of(state.registry.set_alias(name, alias, body.version))


@router.delete(
    "/{name}/aliases/{alias}",
    status_code=status.HTTP_204_NO_CONTENT,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def delete_alias(name: Name, alias: Alias, state: StateDep) -> Response:
    state.registry.delete_alias(name, alias)
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.put(
    "/{name}/versions/{version}/tags/{key}",
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def set_tag(name: Name, version: Selector, key: str, body: TagSet, state: StateDep) -> PolicyVersionPublic:
    return PolicyVersionPublic.of(state.registry.set_tag(f"{name}@{version}", key, body.value))


@router.get(
    "/{name}/versions/{version}/artifacts/{artifact:path}",
    response_class=FileResponse,
    responses={**ERRORS, 200: {"content": {"application/octet-stream": {}}}},
)
def download_policy_artifact(name: Name, version: Selector, artifact: str, state: StateDep) -> FileResponse:
    """Download one stored file of a version (only names the version records)."""
    record = state.registry.resolve(f"{name}@{version}")
    try:
        stored = record.artifact(artifact)
    except KeyError:
        raise HTTPException(status_code=404, detail=f"{record.ref} has no artifact {artifact!r}") from None
    path = state.registry.store.confine(state.registry.store.relative(stored.path))
    if not path.is_file():
        raise VersionNotFound(f"{record.ref}: stored file {artifact!r} is missing from the artifact store")
    return FileResponse(path, filename=path.name, media_type="application/octet-stream")
