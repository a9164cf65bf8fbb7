"""Greedy evaluation of a dual-system run's whole controller beside its actor alone.

A run's greedy evaluation (``core.runs.trainer.evaluate``) deploys the actor μ(f(s)): ``act(obs,
explore=False)``. In training the dual agents act through the meta-controller instead (Algorithm 2 lines
10-19: locate the region, arbitrate, plan with the world models when model-based) and then explore around
that action (line 20). This probe loads a finished run's final checkpoint (``checkpoints/latest.pt``: the
learner, the world models and the ITM regions) and evaluates, on the trainer's evaluation starts
(``EVAL_SEED + k``), both

* ``actor``: the deployed policy, as the run's own evaluation (its return must equal the run's final
  ``eval/return``: ``reproduces_run`` says whether it does), and
* ``controller``: lines 10-19 without line 20's exploration (the meta-controller's action, planned where it
  arbitrates model-based). Arbitration keeps its own rules (its draws, if any, come from the agent's
  generator), and locating may add ITM nodes, as in training; nothing of it is written back.

It answers whether a dual run's controller does better than the actor it trains, which the run's greedy
figure cannot show. A probe for docs/results.md, not part of the product's evaluation.

    python scripts/dual_controller_eval.py RUN_DIR [RUN_DIR ...] [--episodes 10] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import load_config
from core.envs.gym_env import make_env
from core.runs.methods import make_agent
from core.runs.run_dir import load_checkpoint
from core.runs.trainer import evaluate


class Controller:
    """Algorithm 2 lines 9-19 of a dual agent as a greedy policy (no line 20)."""

    def __init__(self, agent: Any) -> None:
        self.agent = agent

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        phi = self.agent.encode(obs)
        start = self.agent.dual.locate(phi)
        action, _ = self.agent.dual.decide(start, self.agent.actor)
        return np.asarray(action, dtype=np.float32), {}


def evaluate_run(run_dir: Path, episodes: int) -> dict[str, Any]:
    config = load_config("default", file=run_dir / "config.yaml")
    torch.manual_seed(config.run.seed)
    adapted = make_env(config.env)
    agent = make_agent(config, adapted.spec, np.random.default_rng(config.run.seed))
    if not hasattr(agent, "dual"):
        raise SystemExit(f"{run_dir}: {config.run.algo} has no dual system")
    agent.load_state_dict(load_checkpoint(run_dir / "checkpoints" / "latest.pt")["agent"])
    eval_env = make_env(config.env, evaluation=True).env
    rule = config.env.success
    actor = evaluate(agent, eval_env, episodes, success_rule=rule)["eval/return"]
    controller = evaluate(Controller(agent), eval_env, episodes, success_rule=rule)["eval/return"]
    run_eval_return = json.loads((run_dir / "summary.json").read_text())["eval_return"]
    return {"run": str(run_dir), "actor": actor, "controller": controller, "run_eval_return": run_eval_return,
            "reproduces_run": abs(actor - run_eval_return) <= 1e-6}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--json", type=Path, default=None, help="write the results here as well")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    results = []
    for run_dir in args.runs:
        result = evaluate_run(run_dir, args.episodes)
        results.append(result)
        print(json.dumps(result), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
