"""Errors a registry user can cause. Each message names the policy, version, alias or path at fault."""

from __future__ import annotations


class RegistryError(Exception):
    """Base class: a user error about policies (bad name, unknown version, bad run directory)."""

    def __str__(self) -> str:  # KeyError subclasses would otherwise print their message quoted
        return str(self.args[0]) if self.args else ""


class InvalidName(RegistryError, ValueError):
    """A policy name, alias, tag key or policy reference is malformed."""


class PolicyNotFound(RegistryError, KeyError):
    """No registered policy has this name."""


class VersionNotFound(RegistryError, KeyError):
    """The policy exists but has no such version or alias."""


class InvalidRunDirectory(RegistryError, ValueError):
    """A run directory cannot be registered (missing, or holds no checkpoint)."""


class PathOutsideRoot(RegistryError, PermissionError):
    """A requested artifact path would leave the artifact root."""
