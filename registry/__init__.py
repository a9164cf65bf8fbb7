"""dualsys registry: named, versioned policies (MLflow vocabulary) over SQLAlchemy and an artifact store.

Knows no HTTP; the job service (`service/`) and the CLI (`dualsys registry ...`) sit on top.
"""

from registry.errors import (
    InvalidName,
    InvalidRunDirectory,
    PathOutsideRoot,
    PolicyNotFound,
    RegistryError,
    VersionNotFound,
)
from registry.policy_registry import PolicyRegistry, opened_registry, resolve_checkpoint
from registry.records import ArtifactRecord, PolicyRecord, PolicyVersionRecord
from registry.references import PolicyRef, parse_policy_ref
from registry.settings import RegistrySettings

__all__ = [
    "ArtifactRecord",
    "InvalidName",
    "InvalidRunDirectory",
    "PathOutsideRoot",
    "PolicyNotFound",
    "PolicyRecord",
    "PolicyRef",
    "PolicyRegistry",
    "PolicyVersionRecord",
    "RegistryError",
    "RegistrySettings",
    "VersionNotFound",
    "opened_registry",
    "parse_policy_ref",
    "resolve_checkpoint",
]
