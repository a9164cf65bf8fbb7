"""Run the six mechanism checks of a profile and collect their figures (`dualsys diagnose mechanisms`).

Each check lives in its own module of this package and shows one dual-system mechanism doing its job on a
controlled problem (docs/dual-system.md, "Mechanisms"); `GOALS` states what each figure should reach with the
repairs on (the ``default`` profile). ``quick`` runs smaller sizes of the same checks (the test suite's).
"""

from __future__ import annotations

from typing import Any

import torch

from core.config import load_config
from core.dual.checks.imagination import imagination_check
from core.dual.checks.intrinsic import intrinsic_check
from core.dual.checks.planner import planner_check
from core.dual.checks.regions import regions_check
from core.dual.checks.reliability import reliability_check
from core.dual.checks.world_model import world_model_check

GOALS = {
    "world_model": "error_ratio_to_no_change <= 0.5",
    "reliability": "trusted_when_improving >= 0.9, trusted_when_accurate >= 0.9, "
                   "trusted_when_unlearnable <= 0.1",
    "intrinsic": "learnable_share > learned_share and > noise_share, "
                 "and >= 1.5 x learnable_share_without_rint",
    "planner": "toward_reward_share >= 0.9, shift_over_noise_std >= 0.2",
    "regions": "max / min of nodes_by_latent_scale <= 2",
    "imagination": "critic_error_true_model < critic_error_real_only, "
                   "critic_error_no_change_model <= 1.1 x critic_error_real_only",
}
"""The goal of each check's figures (issue #19)."""


def run_mechanism_checks(profile: str = "default", quick: bool = False) -> dict[str, Any]:
    """The six checks on ``profile``'s config; one dict with the key order of the JSON contract."""
    config = load_config(profile)
    dual = config.dual
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return {
            "profile": profile,
            "world_model": world_model_check(dual, steps=2500 if quick else 3000, seeds=1 if quick else 2),
            "reliability": reliability_check(dual, seeds=2 if quick else 3),
            "intrinsic": intrinsic_check(dual, steps=4000 if quick else 6000, seeds=1 if quick else 5),
            "planner": planner_check(config, starts=60 if quick else 200,
                                     transitions=1500 if quick else 3000),
            "regions": regions_check(dual, states=2000 if quick else 4000),
            "imagination": imagination_check(dual, seeds=1 if quick else 3, updates=500 if quick else 1000),
        }
    finally:
        torch.set_num_threads(threads)
