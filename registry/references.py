"""Policy references: `name`, `name@VERSION`, `name@ALIAS` (MLflow's vocabulary, see STYLE.md).

Decisions (documented in docs/service.md):
- a bare `name` and `name@latest` mean the newest version; `latest` is therefore not a valid alias;
- a version is a positive integer (`name@3`; `name@v3` is accepted too); an alias starts with a
  letter, so `name@3` is never ambiguous.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from registry.errors import InvalidName

POLICY_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
ALIAS_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,31}$")
TAG_KEY = re.compile(r"^[A-Za-z0-9_.:/-]{1,64}$")
RESERVED_ALIASES = frozenset({"latest"})
_VERSION = re.compile(r"^v?([1-9][0-9]{0,8})$")
MAX_VERSION = 999_999_999
"""The largest version number a reference can name (nine digits)."""

# The same rules as regular expressions for an OpenAPI schema (no look-around: pydantic's engine has none)
SELECTOR = re.compile(r"^(?:v?[1-9][0-9]{0,8}|[A-Za-z][A-Za-z0-9_-]{0,31})$")
"""What may follow `name@`: a version (`3`, `v3`), `latest` or an alias."""
POLICY_REF = re.compile(
    r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}(?:@(?:v?[1-9][0-9]{0,8}|[A-Za-z][A-Za-z0-9_-]{0,31}))?$"
)
"""`name`, `name@VERSION`, `name@ALIAS` (`parse_policy_ref` accepts exactly these)."""
NOT_AN_ALIAS = re.compile(r"^(?:v?[1-9][0-9]{0,8}|[Ll][Aa][Tt][Ee][Ss][Tt])$")
"""Names of the alias form that `check_alias` refuses: version numbers and `latest`."""


def check_policy_name(name: str) -> str:
    """Return `name` if it is a valid policy name, else raise InvalidName."""
    if not isinstance(name, str) or not POLICY_NAME.match(name):
        raise InvalidName(
            f"invalid policy name {name!r}: use 1-64 letters, digits, '_', '.', '-', "
            "starting with a letter or digit"
        )
    return name


def check_alias(alias: str) -> str:
    """Return `alias` if it is a valid alias name, else raise InvalidName."""
    if not isinstance(alias, str) or not ALIAS_NAME.match(alias) or _VERSION.match(alias):
        raise InvalidName(
            f"invalid alias {alias!r}: use 1-32 letters, digits, '_', '-', starting with a letter"
        )
    if alias.lower() in RESERVED_ALIASES:
        raise InvalidName(f"alias {alias!r} is reserved (it always means the newest version)")
    return alias


def check_tag_key(key: str) -> str:
    """Return `key` if it is a valid tag key, else raise InvalidName."""
    if not isinstance(key, str) or not TAG_KEY.match(key):
        raise InvalidName(f"invalid tag key {key!r}: use 1-64 letters, digits or '_.:/-'")
    return key


@dataclass(frozen=True)
class PolicyRef:
    """A parsed reference: exactly one of `version` / `alias` is set, or neither (= newest)."""

    name: str
    version: int | None = None
    alias: str | None = None

    def __str__(self) -> str:
        if self.version is not None:
            return f"{self.name}@{self.version}"
        if self.alias is not None:
            return f"{self.name}@{self.alias}"
        return self.name


def parse_policy_ref(text: str) -> PolicyRef:
    """Parse `name`, `name@latest`, `name@3`, `name@v3` or `name@champion` into a PolicyRef."""
    if not isinstance(text, str) or not text.strip():
        raise InvalidName("empty policy reference: expected NAME, NAME@VERSION or NAME@ALIAS")
    name, sep, selector = text.strip().partition("@")
    check_policy_name(name)
    if not sep or selector.lower() == "latest":
        return PolicyRef(name=name)
    match = _VERSION.match(selector)
    if match:
        return PolicyRef(name=name, version=int(match.group(1)))
    if not ALIAS_NAME.match(selector):
        raise InvalidName(
            f"invalid policy reference {text!r}: "
            "expected NAME, NAME@VERSION (a positive integer) or NAME@ALIAS"
        )
    return PolicyRef(name=name, alias=selector)
