"""`/policies`: the registry over REST (register from a finished job, aliases, tags, downloads)."""

from __future__ import annotations

import re
from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Response, status
from fastapi.responses import FileResponse

from registry.artifact_store import ARTIFACT_NAME
from registry.errors import InvalidRunDirectory, VersionNotFound
from registry.references import ALIAS_NAME, NOT_AN_ALIAS, POLICY_NAME, SELECTOR, TAG_KEY
from service.api.links import link, linked
from service.database import job_store
from service.deps import MutationAuth, StateDep
from service.errors import JobConflict, SpecRejected
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
DOT_SEGMENT = re.compile(r"(?:^|/)\.{1,2}(?:/|$)")
Name = Annotated[str, Path(pattern=POLICY_NAME.pattern, description="Policy name.")]
Alias = Annotated[
    str,
    Path(
        pattern=ALIAS_NAME.pattern,
        description="Alias name, e.g. champion (not a version number, not `latest`).",
        # enforced by the registry (422); pydantic's pattern engine has no look-ahead to say it there
        json_schema_extra={"not": {"pattern": NOT_AN_ALIAS.pattern}},
    ),
]
Selector = Annotated[
    str, Path(pattern=SELECTOR.pattern, description="A version number (3 or v3), `latest` or an alias.")
]
TagKey = Annotated[
    str,
    Path(
        pattern=TAG_KEY.pattern,
        description="Tag key (may contain `/`; no `.` or `..` segment).",
        json_schema_extra={"not": {"pattern": DOT_SEGMENT.pattern}},
    ),
]
ArtifactName = Annotated[
    str, Path(pattern=ARTIFACT_NAME.pattern, description="A stored file's name, e.g. checkpoints/best.pt.")
]
ERRORS = {
    400: {"model": ErrorPublic},
    401: {"model": ErrorPublic},
    404: {"model": ErrorPublic},
    409: {"model": ErrorPublic},
    422: {"model": ErrorPublic},
}


def _version_links(name: str, version: str) -> dict[str, dict]:
    """What can be done with the version `name@version` (runtime expressions)."""
    return {
        "GetVersion": link("get_version", "The version.", name=name, version=version),
        "SetAlias": link("set_alias", "Point an alias at it.", name=name),
        "SetTag": link("set_tag", "Tag it.", name=name, version=version),
        "DownloadArtifact": link(
            "download_policy_artifact",
            "Download its first stored file.",
            name=name,
            version=version,
            artifact="$response.body#/artifacts/0/name",
        ),
    }


@router.get(
    "",
    response_model=PoliciesPublic,
    responses={
        **ERRORS,
        **linked(
            200,
            "Every policy.",
            GetPolicy=link("get_policy", "The first policy.", name="$response.body#/data/0/name"),
            RegisterVersion=link(
                "register_version", "Register a job as its next version.", name="$response.body#/data/0/name"
            ),
        ),
    },
)
def list_policies(state: StateDep) -> PoliciesPublic:
    records = state.registry.list_policies()
    return PoliciesPublic(data=[PolicyPublic.of(r) for r in records], count=len(records))


@router.get(
    "/{name}",
    response_model=PolicyPublic,
    responses={
        **ERRORS,
        **linked(
            200,
            "The policy and its versions.",
            GetLatestVersion=link(
                "get_version",
                "Its newest version.",
                name="$response.body#/name",
                version="$response.body#/latest_version",
            ),
        ),
    },
)
def get_policy(name: Name, state: StateDep) -> PolicyPublic:
    return PolicyPublic.of(state.registry.get_policy(name))


@router.post(
    "/{name}/versions",
    status_code=status.HTTP_201_CREATED,
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses={
        **ERRORS,
        **linked(
            201, "The new version.", **_version_links("$response.body#/name", "$response.body#/version")
        ),
    },
)
def register_version(name: Name, body: VersionCreate, state: StateDep) -> PolicyVersionPublic:
    """Register a succeeded job's run directory as the next version of `name`."""
    job = job_store.get_job(state.database, job_id=body.job_id)
    if job.status != "succeeded":
        raise JobConflict(
            f"job {job.id} is {job.status}; only a succeeded job can be registered", field="job_id"
        )
    run_dir = state.registry.store.confine(job.run_dir)
    try:
        record = state.registry.register_run(
            name,
            run_dir,
            source_job_id=job.id,
            parent=body.parent,
            tags={"job_kind": job.kind, **body.tags},
            description=body.description,
        )
    except InvalidRunDirectory as error:  # the job's state (what it wrote), not the request, is at fault
        raise JobConflict(f"job {job.id} ({job.kind}): {error}", field="job_id") from None
    return PolicyVersionPublic.of(record)


@router.get(
    "/{name}/versions/{version}",
    response_model=PolicyVersionPublic,
    responses={
        **ERRORS,
        **linked(200, "The version.", **_version_links("$response.body#/name", "$response.body#/version")),
    },
)
def get_version(name: Name, version: Selector, state: StateDep) -> PolicyVersionPublic:
    """A version by number, or by alias (`/policies/grasp/versions/champion`)."""
    return PolicyVersionPublic.of(state.registry.resolve(f"{name}@{version}"))


@router.put(
    "/{name}/aliases/{alias}",
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses={
        **ERRORS,
        **linked(
            200,
            "The version the alias now points at.",
            GetByAlias=link(
                "get_version", "Resolve the alias.", name="$request.path.name", version="$request.path.alias"
            ),
            DeleteAlias=link(
                "delete_alias", "Delete the alias.", name="$request.path.name", alias="$request.path.alias"
            ),
        ),
    },
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
    "/{name}/versions/{version}/tags/{key:path}",
    response_model=PolicyVersionPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def set_tag(name: Name, version: Selector, key: TagKey, body: TagSet, state: StateDep) -> PolicyVersionPublic:
    if DOT_SEGMENT.search(key):  # as the schema says (a client that does not normalise the URL sends them)
        raise SpecRejected(f"key: tag key {key!r} has a '.' or '..' segment", field="key")
    return PolicyVersionPublic.of(state.registry.set_tag(f"{name}@{version}", key, body.value))


@router.get(
    "/{name}/versions/{version}/artifacts/{artifact:path}",
    response_class=FileResponse,
    responses={**ERRORS, 200: {"content": {"application/octet-stream": {}}}},
)
def download_policy_artifact(
    name: Name, version: Selector, artifact: ArtifactName, state: StateDep
) -> FileResponse:
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
