"""dualsys registry: named, versioned policies (MLflow vocabulary) over SQLAlchemy and an artifact store.

Knows no HTTP; the job service (`service/`) and the CLI (`dualsys registry ...`) sit on top.
Names are imported lazily (PEP 562), so `import registry.references` stays light for job processes
that never touch the database.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "InvalidName": "registry.errors",
    "InvalidRunDirectory": "registry.errors",
    "PathOutsideRoot": "registry.errors",
    "PolicyNotFound": "registry.errors",
    "RegistryError": "registry.errors",
    "VersionNotFound": "registry.errors",
    "PolicyRegistry": "registry.policy_registry",
    "opened_registry": "registry.policy_registry",
    "resolve_checkpoint": "registry.policy_registry",
    "ArtifactRecord": "registry.records",
    "PolicyRecord": "registry.records",
    "PolicyVersionRecord": "registry.records",
    "PolicyRef": "registry.references",
    "parse_policy_ref": "registry.references",
    "RegistrySettings": "registry.settings",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'registry' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
