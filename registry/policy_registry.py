"""The policy registry's Python API: register run directories, resolve `name@VERSION|ALIAS`.

    registry = PolicyRegistry.open("sqlite:///dualsys.db", Path("dualsys-artifacts"))
    version = registry.register_run("grasp", Path("runs/i2a-sparse"), tags={"algo": "i2a"})
    registry.set_alias("grasp", "champion", version.version)
    registry.resolve("grasp@champion").checkpoint   # -> Path of the stored best.pt

Registration copies the run directory's files into the artifact store
(`policies/<name>/v<version>/`) first, under a hidden staging folder, then allocates the next
version number and renames the folder in one database transaction, so a failure leaves neither a
half-written version row nor a half-copied folder. Version numbers are `max + 1` inside a
write-locked transaction (SQLite `BEGIN IMMEDIATE`; elsewhere the unique constraint plus a retry).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, selectinload

from registry.artifact_store import ArtifactStore, artifact_kind, sha256_of
from registry.database import Database
from registry.errors import InvalidName, InvalidRunDirectory, PolicyNotFound, VersionNotFound
from registry.models import Policy, PolicyAlias, PolicyArtifact, PolicyVersion, PolicyVersionTag
from registry.records import ArtifactRecord, PolicyOverview, PolicyRecord, PolicyVersionRecord
from registry.references import check_alias, check_policy_name, check_tag_key, parse_policy_ref
from registry.run_directory import read_run_directory
from registry.settings import RegistrySettings

_REGISTER_RETRIES = 5


class PolicyRegistry:
    """Named, versioned policies over a database and an artifact store."""

    def __init__(self, database: Database, store: ArtifactStore) -> None:
        self.database = database
        self.store = store

    @classmethod
    def open(cls, database_url: str, artifact_root: Path, *, migrate: bool = True) -> PolicyRegistry:
        """Connect (and by default bring the registry tables to the newest migration)."""
        database = Database(database_url)
        if migrate:
            from registry.migrate import upgrade_registry  # alembic is only needed here

            upgrade_registry(database.engine)
        return cls(database, ArtifactStore(artifact_root))

    @classmethod
    def from_settings(cls, settings: RegistrySettings | None = None) -> PolicyRegistry:
        """The registry the `DUALSYS_DATABASE_URL` / `DUALSYS_ARTIFACTS` settings point at."""
        settings = settings or RegistrySettings()
        return cls.open(settings.database_url, settings.artifacts)

    # ---------------------------------------------------------------- registration
    def register_run(
        self,
        name: str,
        run_dir: Path,
        *,
        source_job_id: int | None = None,
        parent: str | None = None,
        tags: Mapping[str, str] | None = None,
        description: str = "",
    ) -> PolicyVersionRecord:
        """Register the run directory `run_dir` as the next version of policy `name`."""
        check_policy_name(name)
        tag_items = {check_tag_key(str(k)): str(v) for k, v in (tags or {}).items()}
        contents = read_run_directory(run_dir)
        if parent is not None:
            self.resolve(parent)  # fail before copying anything if the parent is unknown
        area = f"policies/{name}"
        staging = self.store.staging_dir(area)
        try:
            ArtifactStore.copy_tree(contents.files, staging)
            digests = {f.name: sha256_of(staging / f.name) for f in contents.files}
            for attempt in range(_REGISTER_RETRIES):
                try:
                    version = self._commit_version(
                        name=name,
                        staging=staging,
                        contents_files=[(f.name, f.kind, f.size) for f in contents.files],
                        digests=digests,
                        source_job_id=source_job_id,
                        source_run_dir=str(contents.path),
                        config=contents.config,
                        metrics=contents.metrics,
                        parent=parent,
                        tags=tag_items,
                        description=description,
                    )
                    return self.get_version(name, version)
                except IntegrityError:
                    if attempt == _REGISTER_RETRIES - 1:
                        raise
            raise AssertionError("unreachable")  # pragma: no cover
        finally:
            if staging.exists():
                ArtifactStore.remove_tree(staging)

    def _commit_version(
        self,
        *,
        name: str,
        staging: Path,
        contents_files: list[tuple[str, str, int]],
        digests: dict[str, str],
        source_job_id: int | None,
        source_run_dir: str,
        config: dict,
        metrics: dict,
        parent: str | None,
        tags: dict[str, str],
        description: str,
    ) -> int:
        final: Path | None = None
        try:
            with self.database.write() as session:
                # the policy row is the lock that serialises version numbers on PostgreSQL (SQLite's write
                # transaction already holds the whole database); a racing first insert is retried
                policy = session.scalar(select(Policy).where(Policy.name == name).with_for_update())
                if policy is None:
                    policy = Policy(name=name, description="")
                    session.add(policy)
                    session.flush()
                current = session.scalar(
                    select(func.max(PolicyVersion.version)).where(PolicyVersion.policy_id == policy.id)
                )
                number = (current or 0) + 1
                parent_row = self._version_row(session, parent) if parent else None
                row = PolicyVersion(
                    policy_id=policy.id,
                    version=number,
                    source_job_id=source_job_id,
                    source_run_dir=source_run_dir,
                    config=config,
                    metrics=metrics,
                    parent_id=parent_row.id if parent_row else None,
                    description=description,
                )
                session.add(row)
                session.flush()
                relative_folder = f"policies/{name}/v{number}"
                for file_name, kind, size in contents_files:
                    session.add(
                        PolicyArtifact(
                            version_id=row.id,
                            name=file_name,
                            kind=kind,
                            path=f"{relative_folder}/{file_name}",
                            size=size,
                            sha256=digests[file_name],
                        )
                    )
                for key, value in tags.items():
                    session.add(PolicyVersionTag(version_id=row.id, key=key, value=value))
                session.flush()
                final = self.store.root / relative_folder
                if final.exists():  # left over by a crash between rename and commit
                    ArtifactStore.remove_tree(final)
                os.replace(staging, final)
            return number
        except BaseException:
            if final is not None and final.exists() and not staging.exists():
                os.replace(final, staging)  # give the files back to staging, which is then removed
            raise

    def add_artifact(self, ref: str, source: Path, *, name: str | None = None) -> PolicyVersionRecord:
        """Copy the file `source` into version `ref` (e.g. an exported ONNX), replacing a same-named one."""
        source = Path(source)
        if not source.is_file():
            raise InvalidRunDirectory(f"artifact {source} is not a file")
        record = self.resolve(ref)
        artifact_name = name or source.name
        relative_folder = f"policies/{record.name}/v{record.version}"
        target = self.store.confine(artifact_name, base=self.store.root / relative_folder)
        target.parent.mkdir(parents=True, exist_ok=True)
        temporary = target.with_name(f".{target.name}.tmp")
        temporary.write_bytes(source.read_bytes())
        os.replace(temporary, target)
        stored_name = target.relative_to(self.store.root / relative_folder).as_posix()
        with self.database.write() as session:
            row = self._version_row(session, record.ref)
            session.merge(
                PolicyArtifact(
                    version_id=row.id,
                    name=stored_name,
                    kind=artifact_kind(stored_name),
                    path=f"{relative_folder}/{stored_name}",
                    size=target.stat().st_size,
                    sha256=sha256_of(target),
                )
            )
        return self.get_version(record.name, record.version)

    # ---------------------------------------------------------------- aliases and tags
    def set_alias(self, name: str, alias: str, version: int) -> PolicyVersionRecord:
        """Point `name@alias` at `version` (creating or moving the alias)."""
        check_alias(alias)
        with self.database.write() as session:
            row = self._version_row(session, f"{name}@{int(version)}")
            existing = session.get(PolicyAlias, (row.policy_id, alias))
            if existing is None:
                session.add(PolicyAlias(policy_id=row.policy_id, alias=alias, version_id=row.id))
            else:
                existing.version_id = row.id
        return self.get_version(name, int(version))

    def delete_alias(self, name: str, alias: str) -> None:
        with self.database.write() as session:
            policy = self._policy_row(session, name)
            existing = session.get(PolicyAlias, (policy.id, alias))
            if existing is None:
                raise VersionNotFound(f"policy {name!r} has no alias {alias!r}")
            session.delete(existing)

    def set_tag(self, ref: str, key: str, value: str) -> PolicyVersionRecord:
        check_tag_key(key)
        with self.database.write() as session:
            row = self._version_row(session, ref)
            session.merge(PolicyVersionTag(version_id=row.id, key=key, value=str(value)))
            name, number = row.policy.name, row.version
        return self.get_version(name, number)

    # ---------------------------------------------------------------- reading
    def resolve(self, ref: str) -> PolicyVersionRecord:
        """The version `ref` (`name`, `name@latest`, `name@3`, `name@champion`) points at."""
        with self.database.read() as session:
            return self._record(session, self._version_row(session, ref))

    def get_version(self, name: str, version: int) -> PolicyVersionRecord:
        return self.resolve(f"{name}@{int(version)}")

    def lineage(self, ref: str) -> list[PolicyVersionRecord]:
        """`ref`'s version, then its parent, grandparent, ... (cycles are impossible: parents are older)."""
        chain: list[PolicyVersionRecord] = []
        with self.database.read() as session:
            row: PolicyVersion | None = self._version_row(session, ref)
            while row is not None and len(chain) < 1000:
                chain.append(self._record(session, row))
                row = row.parent
        return chain

    def list_policies(self) -> list[PolicyRecord]:
        """Every policy with its aliases and newest version number (versions themselves omitted)."""
        with self.database.read() as session:
            policies = session.scalars(
                select(Policy)
                .options(selectinload(Policy.aliases).selectinload(PolicyAlias.version))
                .order_by(Policy.name)
            ).all()
            latest = dict(
                session.execute(
                    select(PolicyVersion.policy_id, func.max(PolicyVersion.version)).group_by(
                        PolicyVersion.policy_id
                    )
                ).all()
            )
            return [
                PolicyRecord(
                    name=p.name,
                    description=p.description,
                    created_at=p.created_at,
                    latest_version=latest.get(p.id),
                    aliases={a.alias: a.version.version for a in p.aliases},
                )
                for p in policies
            ]

    def policy_overviews(self) -> dict[str, PolicyOverview]:
        """Per policy with at least one version: its version count, and its newest version's creation time
        and source job (one query, for listings)."""
        newest = (
            select(
                PolicyVersion.policy_id,
                func.count().label("versions"),
                func.max(PolicyVersion.version).label("top"),
            )
            .group_by(PolicyVersion.policy_id)
            .subquery()
        )
        query = (
            select(Policy.name, newest.c.versions, PolicyVersion.created_at, PolicyVersion.source_job_id)
            .join(newest, newest.c.policy_id == Policy.id)
            .join(
                PolicyVersion,
                (PolicyVersion.policy_id == Policy.id) & (PolicyVersion.version == newest.c.top),
            )
        )
        with self.database.read() as session:
            rows = session.execute(query).all()
        return {
            name: PolicyOverview(name, int(versions), created, job_id)
            for name, versions, created, job_id in rows
        }

    def versions_from_job(self, job_id: int) -> list[str]:
        """`name@version` of every version registered from the service's job `job_id`, by name and version."""
        query = (
            select(Policy.name, PolicyVersion.version)
            .join(PolicyVersion, PolicyVersion.policy_id == Policy.id)
            .where(PolicyVersion.source_job_id == job_id)
            .order_by(Policy.name, PolicyVersion.version)
        )
        with self.database.read() as session:
            return [f"{name}@{version}" for name, version in session.execute(query).all()]

    def get_policy(self, name: str) -> PolicyRecord:
        """A policy with all its versions."""
        with self.database.read() as session:
            policy = self._policy_row(session, name)
            versions = session.scalars(
                self._version_query()
                .where(PolicyVersion.policy_id == policy.id)
                .order_by(PolicyVersion.version)
            ).all()
            return PolicyRecord(
                name=policy.name,
                description=policy.description,
                created_at=policy.created_at,
                latest_version=versions[-1].version if versions else None,
                aliases={a.alias: a.version.version for a in policy.aliases},
                versions=[self._record(session, v) for v in versions],
            )

    # ---------------------------------------------------------------- internals
    @staticmethod
    def _version_query():  # type: ignore[no-untyped-def]
        return select(PolicyVersion).options(
            selectinload(PolicyVersion.policy),
            selectinload(PolicyVersion.tags),
            selectinload(PolicyVersion.artifacts),
            selectinload(PolicyVersion.parent).selectinload(PolicyVersion.policy),
        )

    @staticmethod
    def _policy_row(session: Session, name: str) -> Policy:
        check_policy_name(name)
        policy = session.scalar(select(Policy).where(Policy.name == name))
        if policy is None:
            raise PolicyNotFound(f"no registered policy named {name!r}")
        return policy

    def _version_row(self, session: Session, ref: str) -> PolicyVersion:
        parsed = parse_policy_ref(ref)
        policy = self._policy_row(session, parsed.name)
        query = self._version_query().where(PolicyVersion.policy_id == policy.id)
        if parsed.version is not None:
            row = session.scalar(query.where(PolicyVersion.version == parsed.version))
            if row is None:
                raise VersionNotFound(f"policy {parsed.name!r} has no version {parsed.version}")
            return row
        if parsed.alias is not None:
            alias = session.get(PolicyAlias, (policy.id, parsed.alias))
            if alias is None:
                raise VersionNotFound(f"policy {parsed.name!r} has no alias {parsed.alias!r}")
            row = session.scalar(query.where(PolicyVersion.id == alias.version_id))
            assert row is not None
            return row
        row = session.scalar(query.order_by(PolicyVersion.version.desc()).limit(1))
        if row is None:
            raise VersionNotFound(f"policy {parsed.name!r} has no versions")
        return row

    def _record(self, session: Session, row: PolicyVersion) -> PolicyVersionRecord:
        aliases = session.scalars(
            select(PolicyAlias.alias).where(PolicyAlias.version_id == row.id).order_by(PolicyAlias.alias)
        ).all()
        return PolicyVersionRecord(
            name=row.policy.name,
            version=row.version,
            created_at=row.created_at,
            source_job_id=row.source_job_id,
            source_run_dir=row.source_run_dir,
            config=dict(row.config or {}),
            metrics=dict(row.metrics or {}),
            parent=f"{row.parent.policy.name}@{row.parent.version}" if row.parent else None,
            description=row.description,
            tags={t.key: t.value for t in row.tags},
            aliases=list(aliases),
            artifacts=[
                ArtifactRecord(
                    name=a.name,
                    kind=a.kind,
                    path=self.store.root / a.path,
                    size=a.size,
                    sha256=a.sha256,
                )
                for a in row.artifacts
            ],
        )


@contextmanager
def opened_registry(settings: RegistrySettings | None = None) -> Iterator[PolicyRegistry]:
    """`PolicyRegistry.from_settings` that disposes of its engine afterwards."""
    registry = PolicyRegistry.from_settings(settings)
    try:
        yield registry
    finally:
        registry.database.dispose()


def resolve_checkpoint(policy: str, settings: RegistrySettings | None = None) -> Path:
    """A checkpoint path from either an existing file/run directory path or a `name@ref` reference.

    This is the one entry point for commands that take a policy (`eval`, `export`, `align`):
    an existing path wins; otherwise the text is a registry reference resolved through the
    registry the settings point at.
    """
    candidate = Path(policy).expanduser()
    if candidate.is_file():
        return candidate
    if candidate.is_dir():
        contents = read_run_directory(candidate)
        for preferred in ("checkpoints/best.pt", "checkpoints/latest.pt"):
            if (candidate / preferred).is_file():
                return candidate / preferred
        return next(f.path for f in contents.files if f.kind in ("checkpoint", "onnx"))
    try:
        parse_policy_ref(policy)
    except InvalidName as error:
        raise InvalidName(
            f"{policy!r} is neither an existing path nor a policy reference ({error})"
        ) from error
    with opened_registry(settings) as registry:
        record = registry.resolve(policy)
    if record.checkpoint is None:
        raise InvalidRunDirectory(f"policy {record.ref} has no checkpoint artifact")
    return record.checkpoint
