"""A train spec's `overrides` as an exact contract: every config key with its JSON type and range.

The keys, types and choices come from `core.config`'s dataclasses (so a key added there, such as
`env.id`, is accepted and documented without a change here); the ranges from `core.config.value_bounds`,
the bounds `core.config.check_config` enforces. Values are typed JSON (`{"agent.batch_size": 32}`, not
`"32"`): the OpenAPI schema says what the service accepts, and a generated client can trust it. Text such
as the CLI's `--set agent.batch_size=32` is turned into typed values with `typed_overrides` (the config's
own coercion) before it is sent.

What the types cannot say is stated separately: the budget keys take no `null` here (a train spec's
`steps` or `minutes` lifts the episode limit, as `dualsys train --steps` does), and `env.hand` must be
one the `env.level` admits (`core.config.level_hand_error`), written as a `not` clause per excluded pair.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from functools import cache
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, StrictBool, StrictFloat, StrictInt, StrictStr, create_model

import core.config as config_module
from service.schemas.json_schema import MAX_SAFE_INTEGER, StrictRequest

NOT_NULL = ("run.episodes", "run.steps", "run.max_wall_s")
"""Budget keys: with `null` refused here, a train job always has a budget (check_config's last rule)."""


def _value_type(annotation: Any, key: str, bounds: dict[str, float]) -> Any:
    """The pydantic type of one key's JSON value (strict: no "32" for 32, no 1 for true)."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        assert len(inner) == 1, f"{key}: unions other than X | None are not supported"
        value = _value_type(inner[0], key, bounds)
        return value if key in NOT_NULL else value | None
    if origin is Literal:
        return annotation
    if origin is tuple:  # net.conv_channels: a non-empty list of positive ints
        channel = Annotated[StrictInt, Field(ge=1, le=2**31 - 1)]
        return Annotated[list[channel], Field(min_length=1, max_length=64)]
    if annotation is bool:
        return StrictBool
    if annotation is int:
        return Annotated[StrictInt, Field(le=MAX_SAFE_INTEGER, **(bounds or {"ge": -MAX_SAFE_INTEGER}))]
    if annotation is float:
        return Annotated[StrictFloat, Field(allow_inf_nan=False, **bounds)]
    if key == "run.algo":  # check_config's caller (resolve_algo) accepts only registered methods
        return Literal[tuple(algo_names())]  # type: ignore[valid-type]
    if key == "env.id":  # the trainer builds only registered gymnasium ids (core.envs.gym_env)
        return Literal[tuple(env_ids())]  # type: ignore[valid-type]
    if origin is dict or annotation is dict:  # env.kwargs: gymnasium.make's keyword arguments
        return Annotated[dict[StrictStr, Any], Field(max_length=64)]
    if annotation is str:
        return Annotated[StrictStr, Field(max_length=256)]
    raise TypeError(f"config key {key} has a type the service cannot describe: {annotation!r}")


@cache
def algo_names() -> tuple[str, ...]:
    """The methods `core.runs.methods.resolve_algo` accepts (importing the registry imports torch)."""
    from core.runs.methods import ALGOS

    return tuple(sorted(ALGOS))


@cache
def env_ids() -> tuple[str, ...]:
    """The gymnasium ids `env.id` accepts here: every id registered once dualsys's envs (and, where the dmc
    extra is installed, dm_control's through shimmy) are imported."""
    from core.envs.gym_env import registered_ids

    return tuple(registered_ids())


@cache
def config_annotations() -> dict[str, Any]:
    """`section.key` → its annotation, for every field of every config section."""
    hints = typing.get_type_hints(config_module.Config)
    found: dict[str, Any] = {}
    for section in dataclasses.fields(config_module.Config):
        section_type = hints[section.name]
        section_hints = typing.get_type_hints(section_type, vars(config_module))
        for item in dataclasses.fields(section_type):
            found[f"{section.name}.{item.name}"] = section_hints[item.name]
    return found


def _choices(key: str) -> list[Any]:
    """The literal values a `Literal[...]` (or `Literal[...] | None`) config key takes."""
    args = typing.get_args(config_annotations().get(key, type(None)))
    return [value for arg in args for value in typing.get_args(arg)] or list(args)


def _hand_rules() -> list[dict[str, Any]]:
    """One `not` clause per (level, hand) pair the level does not admit."""
    rules = []
    for name in _choices("env.level"):
        for hand in _choices("env.hand"):
            if isinstance(hand, str) and config_module.level_hand_error(name, hand):
                rules.append(
                    {
                        "not": {
                            "required": ["env.level", "env.hand"],
                            "properties": {"env.level": {"const": name}, "env.hand": {"const": hand}},
                        }
                    }
                )
    return rules


@cache
def overrides_model() -> type[BaseModel]:
    """A pydantic model whose fields are the config keys (aliases `section.key`); unknown keys refused."""
    bounds = config_module.value_bounds()
    fields: dict[str, Any] = {}
    for key, annotation in config_annotations().items():
        value = _value_type(annotation, key, bounds.get(key, {}))
        fields[key.replace(".", "__")] = (value, Field(default=None, alias=key))
    return create_model(  # type: ignore[call-overload, no-any-return]
        "ConfigOverrides", __base__=StrictRequest, **fields
    )


def check_overrides(values: dict[str, Any]) -> None:
    """ValueError naming the first bad key (unknown, wrong type, out of range, hand vs level)."""
    from pydantic import ValidationError

    try:
        overrides_model().model_validate(values)
    except ValidationError as error:
        first = error.errors()[0]
        key = ".".join(str(p) for p in first["loc"][:1]) or "overrides"
        if first["type"] == "extra_forbidden":
            raise ValueError(f"unknown config key {key!r}") from None
        raise ValueError(f"{key}: {first['msg']}") from None
    level, hand = values.get("env.level"), values.get("env.hand")
    if isinstance(level, str) and isinstance(hand, str):
        message = config_module.level_hand_error(level, hand)
        if message:
            raise ValueError(f"env.hand: {message}")


@cache
def overrides_json_schema() -> dict[str, Any]:
    """The JSON schema of `overrides`: a closed object, one property per config key."""
    schema = overrides_model().model_json_schema(by_alias=True)
    assert "$defs" not in schema, "override values are plain JSON types"
    properties = {
        key: {k: v for k, v in value.items() if k not in ("title", "default")}
        for key, value in schema["properties"].items()
    }
    closed: dict[str, Any] = {
        "type": "object",
        "properties": properties,
        "additionalProperties": False,
        "maxProperties": 200,
    }
    rules = _hand_rules()
    if rules:
        closed["allOf"] = rules
    return closed


def typed_overrides(pairs: dict[str, str]) -> dict[str, Any]:
    """`{"agent.batch_size": "32"}` → `{"agent.batch_size": 32}` with the config's own coercion
    (`true`, `none`, `16,32`); a key or value it cannot read is passed on as text, so the service's
    answer names it."""
    annotations = config_annotations()
    typed: dict[str, Any] = {}
    for key, raw in pairs.items():
        annotation = annotations.get(key)
        if annotation is None:
            typed[key] = raw
            continue
        try:
            value = config_module.coerce(raw, annotation, key)
        except config_module.ConfigError:
            typed[key] = raw
            continue
        typed[key] = list(value) if isinstance(value, tuple) else value
    return typed
