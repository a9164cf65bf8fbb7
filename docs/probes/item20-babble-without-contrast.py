"""Probe of item 20 (docs/dual-system.md), throwaway: run from the repository root as
``python docs/probes/item20-babble-without-contrast.py 105,106,107,108,109 20000`` at a commit from a5ecd29 to
db8655e (from 8ce8741 on, `GoalBabbling.choose` is this rule itself with the box widened by 2 e_max, item 21,
and the probe runs that).
The committed progress reading, but a babbled goal acts also where the aim has no contrast (the pull length
floored at 1e-3, as item 20's prototype), scored by the fixed-start check's measure on the same seeds as the
committed rule."""

import copy
import dataclasses
import json
import sys

import torch

import core.dual.checks.planner_aim as planner_aim
from core.config import load_config
from core.dual import goal_babbling

torch.set_num_threads(1)


committed_choose = goal_babbling.GoalBabbling.choose


def choose(self, aim, u, margin):
    """The committed rule, with a babbled goal's length floored at 1e-3, also where the aim has no goal."""
    if aim.goal is None:  # no contrast: babble through a stand-in aim, else aim at nothing (as committed)
        stand_in = copy.copy(aim)
        stand_in.goal, stand_in.weight = aim.centres.mean(axis=0), 0.0
        chosen = committed_choose(self, stand_in, u, margin)
        if not chosen.babbled:
            return aim
    else:
        chosen = committed_choose(self, aim, u, margin)
    if chosen.babbled:
        chosen.weight = max(chosen.weight, 1e-3)
    return chosen


goal_babbling.GoalBabbling.choose = choose
dual = dataclasses.replace(load_config("default").dual, planner="progress")
for seed in [int(s) for s in sys.argv[1].split(",")]:
    measures = planner_aim.fixed_start_measures(dual, int(sys.argv[2]), seed)
    print(json.dumps({"seed": seed, **measures}), flush=True)
