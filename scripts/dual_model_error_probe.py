"""Probe: why the dual system's local models predict SAC-AE's latent worse than "nothing changes".

Grid 5 (the hard sparse grasp, SAC-AE) found the models' Eq. 8 error at 1.36-1.58× the no-change predictor's
over each run, so the arbitration almost never picked the planner (docs/results.md, grid 5). This probe has
two halves:

``record``: run one grid cell's config (a dual-system cell) on a tuning seed and write, in order, everything
the dual system's world models were given: every φ_t the map saw (``DualSystem.locate``), every real
transition they learnt from (``DualSystem.learn``) with the grasp's shoulder angle before and after it,
every refit batch (``DualSystem.refit_on``), and the seed the world models were built from. It wraps those
methods (and ``NicoGraspEnv.step``) from outside, so the run is the same run as without the probe.

``replay``: feed that stream to `LocalWorldModels` again, offline, under the recorded settings or a
variant of them (``--set dual.KEY=VALUE``, ``--variant``), and split each transition's error before its
update into its latent and reward parts, beside the no-change predictor's, the size of the change the
model predicted against the true one, the node's age (its Adam steps), and where the arm was: the share of
transitions that change nothing, how many of those had the arm out of the camera's view, and the error
ratio of the moves seen by the camera. Replaying the recorded settings
from the recorded seed reproduces the run's errors exactly (checked, printed), so a variant's
figures differ from the run's only by the variant. A variant changes the models alone: the stream (the
encoder's latents and the agent's actions) is the recorded one.

    OMP_NUM_THREADS=1 python scripts/dual_model_error_probe.py record \\
        results/study3-hard-sparse/SAC+IM2C/sparse/seed-1/config.yaml --seed 101 --steps 6000 --out probe-101
    python scripts/dual_model_error_probe.py replay probe-101                      # recorded settings
    python scripts/dual_model_error_probe.py replay probe-101 --variant zero_change_head
    python scripts/dual_model_error_probe.py replay probe-101 --set dual.model_lr=1e-4
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import load_config
from core.dual.dual_system import DualSystem, StepStart
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.nico_grasp import NicoGraspEnv
from core.runs.trainer import train

VARIANTS = ("none", "zero_change_head")
COLUMNS = ("error", "no_change_error", "latent_part", "reward_part", "predicted_change", "true_change",
           "node_age", "run_error", "run_no_change_error", "scale_s", "angle", "next_angle")
"""One row per replayed transition: its Eq. 8 error before the update, the no-change predictor's, the error's
latent and reward parts, ‖φ̂′ − φ‖ and ‖φ′ − φ‖, the node's Adam steps, the recorded run's two errors, the
models' unit s, and the shoulder angle before and after (degrees)."""
OUT_OF_VIEW_DEG = -7.0
"""Below this shoulder angle the grasp's camera does not see the arm (docs/environment.md, "What the camera
sees of the arm": the same image from −100° to about −10°)."""


# ---------------------------------------------------------------------------------------------- record
def record(config_path: Path, seed: int, steps: int, out: Path, overrides: list[str]) -> None:
    config = load_config("default", [f"run.seed={seed}", f"run.steps={steps}", *overrides], file=config_path)
    events: list[tuple[str, Any]] = []
    initial: dict[str, Any] = {}
    locate, learn, refit = DualSystem.locate, DualSystem.learn, DualSystem.refit_on
    env_step = NicoGraspEnv.step
    shoulder: dict[str, float] = {}

    def step_recorded(env: NicoGraspEnv, action: Any) -> Any:
        """The grasp's shoulder angle before and after the step (degrees): where the transition happened.
        Read by the next `learn_recorded`, which follows the training env's step (evaluations run between
        episodes)."""
        before = math.degrees(env._shoulder_angle())
        out = env_step(env, action)
        shoulder.update(before=before, after=math.degrees(env._shoulder_angle()))
        return out

    def locate_recorded(dual: DualSystem, phi: torch.Tensor) -> StepStart:
        if not initial:
            initial.update(seed=dual.world.bank.generator.initial_seed(), latent_dim=dual.world.latent_dim,
                           action_dim=dual.world.action_dim, regions=dual.world.regions)
        events.append(("locate", phi[0].clone()))
        return locate(dual, phi)

    def learn_recorded(dual: DualSystem, start: StepStart, next_phi: torch.Tensor, transition: Any) -> float:
        r_int = learn(dual, start, next_phi, transition)
        events.append(("learn", (next_phi[0].clone(), np.asarray(transition.action, dtype=np.float32),
                                 float(transition.reward), bool(transition.terminated),
                                 dual.counters.errors[-1], dual.counters.naive_errors[-1],
                                 shoulder.get("before", math.nan), shoulder.get("after", math.nan))))
        return r_int

    def refit_recorded(dual: DualSystem, batch: Any, latents: torch.Tensor) -> None:
        events.append(("refit", (latents.clone(), batch.action.clone(), batch.reward_ext.clone(),
                                 batch.terminated.clone())))
        refit(dual, batch, latents)

    DualSystem.locate, DualSystem.learn, DualSystem.refit_on = locate_recorded, learn_recorded, refit_recorded
    NicoGraspEnv.step = step_recorded
    summary = train(config, out, command="dual model error probe")
    with (out / "stream.pkl").open("wb") as f:
        pickle.dump({**initial, "events": events}, f)
    print(summary)


# ---------------------------------------------------------------------------------------------- replay
def zero_change_head(world: LocalWorldModels) -> None:
    """Variant: every model (and every model a new node gets) starts predicting "no change" (the latent
    head's weights and biases at 0), as the delta model's reward head already does."""
    bank = world.bank
    fresh = bank._fresh

    def fresh_zeroed(count: int) -> torch.Tensor:
        out = fresh(count)
        for key in ("wm", "bm"):
            out[:, bank._slices[key]] = 0.0
        return out

    bank._fresh = fresh_zeroed
    bank.theta[:, bank._slices["wm"]] = 0.0
    bank.theta[:, bank._slices["bm"]] = 0.0


def replay(out: Path, overrides: list[str], variant: str) -> dict[str, Any]:
    with (out / "stream.pkl").open("rb") as f:
        stream = pickle.load(f)
    exact = not overrides and variant == "none"
    # The run's own config.yaml (written by `train`), the variant's changes parsed as the CLI parses them.
    dual = load_config("default", overrides, file=out / "config.yaml").dual
    world = LocalWorldModels(dual, stream["latent_dim"],
                             stream["action_dim"], regions=stream["regions"],
                             generator=torch.Generator().manual_seed(stream["seed"]),
                             readings=resolve(dual))
    if variant == "zero_change_head":
        zero_change_head(world)
    rows: list[tuple[float, ...]] = []
    node, phi = 0, None
    for kind, payload in stream["events"]:
        if kind == "locate":
            phi = payload
            node = world.observe_state(phi)
        elif kind == "learn":
            next_phi, action, reward, terminated, run_error, run_naive, angle, next_angle = payload
            a = torch.as_tensor(action).reshape(1, -1)
            before = world.bank.predict(torch.tensor([node]), phi.reshape(1, -1), a)
            target_latent, target_reward = next_phi.reshape(1, -1), torch.tensor([float(reward)])
            # Eq. 8 with one side exact: the latent part (true reward) and the reward part (true latent).
            latent_part = float(world.bank.errors(before.next_latent, target_reward, target_latent,
                                                  target_reward)[0])
            reward_part = float(world.bank.errors(target_latent, before.reward, target_latent,
                                                  target_reward)[0])
            no_change = (phi.reshape(1, -1), torch.zeros(1))  # φ̂′ = φ, r̂ = 0
            naive = float(world.bank.errors(*no_change, target_latent, target_reward)[0])
            age = int(world.bank.steps[node])
            feedback = world.learn_transition(node, phi, a, reward, next_phi, terminated)
            rows.append((feedback.error, naive, latent_part, reward_part,
                         float((before.next_latent[0] - phi).norm()), float((next_phi - phi).norm()),
                         age, run_error, run_naive, float(world.bank.latent_scale), angle, next_angle))
        elif world.config.refit_every:
            latents, action, reward, terminated = payload
            count = action.shape[0]
            world.refit(latents[:count], action, reward, latents[count:], terminated)
    table = np.array(rows)
    return summarise({name: table[:, i] for i, name in enumerate(COLUMNS)}, exact)


def summarise(col: dict[str, np.ndarray], exact: bool) -> dict[str, Any]:
    """The replayed transitions' figures over the late half (``col``: one array per name of `COLUMNS`)."""
    error, naive = col["error"], col["no_change_error"]
    latent, reward = col["latent_part"], col["reward_part"]
    predicted, true, age = col["predicted_change"], col["true_change"], col["node_age"]
    angle, next_angle = col["angle"], col["next_angle"]
    count = len(error)
    half = count // 2
    late = slice(half, None)
    young = age < 50
    index = np.arange(count)
    in_view = (angle >= OUT_OF_VIEW_DEG) & (next_angle >= OUT_OF_VIEW_DEG)

    def ratio(part: slice | np.ndarray) -> float:
        return float(error[part].mean() / naive[part].mean())

    result: dict[str, Any] = {
        "transitions": count,
        "ratio_all": ratio(slice(None)), "ratio_late_half": ratio(late),
        "late": {
            "model_error": float(error[late].mean()), "no_change_error": float(naive[late].mean()),
            "latent_part": float(latent[late].mean()), "reward_part": float(reward[late].mean()),
            "predicted_change_norm": float(np.median(predicted[late])),
            "true_change_norm": float(np.median(true[late])),
            "share_young_nodes": float(young[late].mean()),
            "ratio_young": ratio(np.where(young & (index >= half))[0]),
            "ratio_old": ratio(np.where(~young & (index >= half))[0]),
            "scale_s": float(col["scale_s"][late].mean()),
            "share_still": float((true[late] == 0).mean()),
            "ratio_still": ratio(np.where((true == 0) & (index >= half))[0]),
            "ratio_moving": ratio(np.where((true > 0) & (index >= half))[0]),
            "model_error_still": float(error[late][true[late] == 0].mean()),
            "predicted_change_norm_still": float(np.median(predicted[late][true[late] == 0])),
            "still_with_arm_out_of_view": float(np.mean(np.maximum(angle, next_angle)[late][true[late] == 0]
                                                        < OUT_OF_VIEW_DEG)),
            "still_at_window_edge": float(np.mean(np.minimum(np.abs(angle), np.abs(next_angle))[late]
                                                  [true[late] == 0] > 99.5)),
            "moving_from_out_of_view": float(np.mean(angle[late][true[late] > 0] < OUT_OF_VIEW_DEG)),
            "ratio_moving_in_view": ratio(np.where((true > 0) & (index >= half) & in_view)[0]),
        },
    }
    if exact:
        same = [np.allclose(mine, run, rtol=1e-5, atol=1e-7)
                for mine, run in ((error, col["run_error"]), (naive, col["run_no_change_error"]))]
        result["reproduces_run"] = all(same)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="run a dual cell on a tuning seed, record its models' stream")
    rec.add_argument("config", type=Path, help="a grid cell's config.yaml (a dual-system cell)")
    rec.add_argument("--seed", type=int, required=True, help="a tuning seed (>= 100)")
    rec.add_argument("--steps", type=int, required=True)
    rec.add_argument("--out", type=Path, required=True)
    rec.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    rep = sub.add_parser("replay", help="replay a recorded stream through the world models, or a variant")
    rep.add_argument("out", type=Path)
    rep.add_argument("--set", action="append", default=[], metavar="dual.KEY=VALUE")
    rep.add_argument("--variant", choices=VARIANTS, default="none")
    args = parser.parse_args()
    if args.command == "record":
        if args.seed < 100:
            parser.error("record on a tuning seed (>= 100); seeds 1-5 are the reporting seeds")
        record(args.config, args.seed, args.steps, args.out, args.set)
    else:
        print(json.dumps(replay(args.out, args.set, args.variant), indent=1))


if __name__ == "__main__":
    main()
