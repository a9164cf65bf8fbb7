"""Schemathesis hooks for the service's OpenAPI schema (`SCHEMATHESIS_HOOKS=tests.utils.schemathesis_hooks`).

The schema marks an experiment file's text with `format: dualsys-experiment` (JSON Schema cannot state
YAML's rules); this teaches schemathesis to write such files: tiny valid grids with a generated name,
methods, rewards and seeds, so POST /experiments is tested with files the service must accept.
"""

from __future__ import annotations

import schemathesis
import yaml
from hypothesis import strategies as st

from service.schemas.experiments import EXPERIMENT_FORMAT
from tests.utils.experiment_files import TINY_CELL_OVERRIDES

_METHODS = [
    {"label": "DDPG", "algo": "ddpg"},
    {"label": "CACLA", "algo": "cacla"},
    {"label": "IM2C", "algo": "im2c"},
]


@st.composite
def experiment_files(draw: st.DrawFn) -> str:
    methods = draw(
        st.lists(st.sampled_from(_METHODS), min_size=1, max_size=2, unique_by=lambda m: m["label"])
    )
    data = {
        "name": draw(st.from_regex(r"[A-Za-z0-9][A-Za-z0-9._-]{0,20}", fullmatch=True)),
        "rewards": draw(st.lists(st.sampled_from(["dense", "sparse"]), min_size=1, max_size=2, unique=True)),
        "seeds": draw(st.integers(min_value=1, max_value=2)),
        "steps": draw(st.integers(min_value=20, max_value=200)),
        "eval_every": 0,
        "eval_episodes": 1,
        "overrides": TINY_CELL_OVERRIDES,
        "methods": methods,
    }
    return yaml.safe_dump(data, sort_keys=False)


schemathesis.openapi.format(EXPERIMENT_FORMAT, experiment_files())
