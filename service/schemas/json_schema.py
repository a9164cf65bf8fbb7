"""Small edits of generated JSON schemas, so the OpenAPI document says exactly what is enforced."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, model_validator

MAX_SAFE_INTEGER = 2**53 - 1
"""The largest integer every JSON client reads exactly (JavaScript's Number.MAX_SAFE_INTEGER); ids and
counts are bounded by it, so a bound never sits where a client's float rounding blurs it."""


def closed_mapping(schema: dict[str, Any]) -> None:
    """`dict[KeyWithPattern, V]`: pydantic writes `patternProperties`, which leaves other keys allowed in
    JSON Schema; pydantic refuses them, so say `propertyNames` + `additionalProperties` instead."""
    patterns = schema.pop("patternProperties", None)
    if not patterns:
        return
    (pattern, values), *rest = patterns.items()
    assert not rest, "one key pattern per mapping"
    schema["propertyNames"] = {"pattern": pattern}
    schema["additionalProperties"] = values


def _integral_floats_as_ints(value: Any) -> Any:
    """`3.0` → `3` in a request's top level and its lists: JSON Schema's `integer` includes `3.0`, a
    strict int does not (and a strict float takes the int)."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, list):
        return [_integral_floats_as_ints(item) for item in value]
    return value


class StrictRequest(BaseModel):
    """A request body that accepts exactly its JSON schema: unknown keys and values of another JSON type
    are refused, never converted (`false` is not 0, `"5"` is not 5), except that an integral number is
    an integer, as in JSON Schema."""

    model_config = ConfigDict(extra="forbid", strict=True)

    @model_validator(mode="before")
    @classmethod
    def _json_schema_integers(cls, data: Any) -> Any:
        if isinstance(data, dict):
            return {key: _integral_floats_as_ints(value) for key, value in data.items()}
        return data
