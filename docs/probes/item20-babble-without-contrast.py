"""Probe of item 20 (docs/dual-system.md), throwaway: run from the repository root as
``python docs/probes/item20-babble-without-contrast.py 105,106,107,108,109 20000`` (commit a5ecd29 or later).
The committed progress reading, but a babbled goal acts also where the aim has no contrast (the pull length
floored at 1e-3, as item 20's prototype), scored by the fixed-start check's measure on the same seeds as the
committed rule."""

import dataclasses
import json
import sys

import numpy as np
import torch

import core.dual.checks.planner_aim as planner_aim
from core.config import load_config
from core.dual import goal_babbling

torch.set_num_threads(1)


def choose(self, aim, u, margin):
    if self.decisions % self.patience == 0:
        dims = aim.centres.shape[1]
        draws = torch.rand(1 + dims, generator=self.generator, dtype=torch.float64).numpy()
        babble, point = float(draws[0]), draws[1:]
        self.goal = None
        if babble < self.share and aim.centres.shape[0] > 0:
            low, high = aim.centres.min(axis=0) - margin, aim.centres.max(axis=0) + margin
            self.goal = low + (high - low) * point
    self.decisions += 1
    if self.goal is not None and float(np.linalg.norm(np.asarray(u).reshape(-1) - self.goal)) < margin:
        self.goal = None
    if self.goal is None:
        return aim
    aim.goal, aim.weight, aim.babbled = self.goal, max(aim.weight, 1e-3), True  # also without a contrast
    return aim


goal_babbling.GoalBabbling.choose = choose
dual = dataclasses.replace(load_config("default").dual, planner="progress")
for seed in [int(s) for s in sys.argv[1].split(",")]:
    measures = planner_aim.fixed_start_measures(dual, int(sys.argv[2]), seed)
    print(json.dumps({"seed": seed, **measures}), flush=True)
