"""The train spec's `overrides` schema (service/schemas/config_overrides.py) says what core.config
enforces: every bound it states is the bound `check_config` applies (the value on the bound is accepted,
the next one beyond refused), and every config key is in it, so a rule changed in core shows up here."""

from __future__ import annotations

import pytest

from core.config import ConfigError, check_config, load_config
from service.schemas.config_overrides import config_annotations, overrides_json_schema

PROPERTIES = overrides_json_schema()["properties"]


def _numeric(schema: dict) -> dict:
    """The number branch of a property's schema (`anyOf` with null for the optional ones)."""
    for branch in schema.get("anyOf", [schema]):
        if branch.get("type") in ("integer", "number"):
            return branch
    return {}


COMPANIONS = {"dual.e_max_relative": ["dual.regions=released"], "dual.model_batch": ["dual.model_memory=0"]}
"""Keys whose bound is probed beside the setting `core.config.check_dual_combinations` asks of them (a
raw-latent resolution needs a raw-latent map; one sample per update samples no older transition)."""


def _accepted(key: str, value: float) -> bool:
    text = str(int(value)) if float(value).is_integer() else repr(value)
    try:
        check_config(load_config("default", [*COMPANIONS.get(key, []), f"{key}={text}"]))
    except ConfigError:
        return False
    return True


def test_every_config_key_has_a_property() -> None:
    assert set(PROPERTIES) == set(config_annotations())


@pytest.mark.parametrize(
    "key", sorted(k for k, v in PROPERTIES.items() if {"minimum", "exclusiveMinimum"} & set(_numeric(v)))
)
def test_lower_bounds_are_check_configs(key: str) -> None:
    schema = _numeric(PROPERTIES[key])
    step = 1 if schema["type"] == "integer" else 1e-9
    if "minimum" in schema:
        assert _accepted(key, schema["minimum"]), f"{key} = its minimum is refused"
        assert not _accepted(key, schema["minimum"] - step), f"{key} below its minimum is accepted"
    else:
        bound = schema["exclusiveMinimum"]
        assert not _accepted(key, bound), f"{key} = its exclusive minimum is accepted"
        assert _accepted(key, bound + step), f"{key} just above its exclusive minimum is refused"


@pytest.mark.parametrize("key", sorted(k for k, v in PROPERTIES.items() if "maximum" in _numeric(v)))
def test_upper_bounds_that_core_sets_are_check_configs(key: str) -> None:
    schema = _numeric(PROPERTIES[key])
    if schema["maximum"] >= 2**53 - 1:  # the JSON-safe integer limit, not a rule of core
        return
    step = 1 if schema["type"] == "integer" else 1e-9
    assert _accepted(key, schema["maximum"])
    assert not _accepted(key, schema["maximum"] + step)


def test_unbounded_numbers_are_unbounded_in_core_too() -> None:
    """A numeric key without a lower bound in the schema takes a negative value in core."""
    for key, schema in PROPERTIES.items():
        number = _numeric(schema)
        if number and not {"minimum", "exclusiveMinimum"} & set(number) and key != "run.algo":
            assert _accepted(key, -1 if number["type"] == "integer" else -0.5), key
