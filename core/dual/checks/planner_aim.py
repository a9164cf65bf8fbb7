"""Check: a planner that aims at learning progress goes where a model is improving, then moves on, and is not
drawn to noise (``dual.planner = progress``; issue 50).

Purpose: before the first extrinsic reward a planner whose objective holds only the predicted reward has
nothing to aim at (its optimal plan is to stand still under an action cost). The ``progress`` reading adds
a pull toward the regions of largest learning progress (`core.dual.planning.optimise_plan` with a
`RegionGoal`), so the planner should steer toward the region whose dynamics are being learnt, leave it once
it is learnt, and spend no more time in a noisy TV than a random walk does. The ``novelty`` reading
(prediction error in place of progress) is the contrast: prediction error stays high in the noise, so it
should be drawn there; ``disagreement`` (an ensemble's variance, Plan2Explore's aim) is the peer that aims at
uncertainty rather than progress.

The controlled problem is `core.envs.three_regions.ThreeRegionsEnv` (a trivial, a learnable and a noise
third of the square), with no extrinsic reward. The dual system is the agents' own: φ = the observation (the
encoder is the identity), `LocalWorldModels` learns from every real transition, `MetaController` decides
(model-based when the region is trusted: Alg. 1's rollout of a random actor, uniform actions as the random
walk's, then K gradient steps on the reading's objective), and the executed action is the plan's first
action, clipped; when the region is not trusted the action is uniform random. The baseline is that random
walk: without an aim a plan is its actions unchanged, so a planner differs from the walk by its aim alone
(with a zero actor and N(0, 0.3²) noise, the first design, a planner without an aim stood nearly still and
the walk outran it; docs/dual-system.md, item 11).

A run is episodes of `EPISODE` steps, each from a uniform start, the world models persisting. Figures,
averaged over seeds: each planner's share of steps in the learnable region over the first and the second
half of the run, its share in the noise over the whole run, and the random walk's; and each planner's mean
paired difference to the walk of the same seed with its exact sign-flip p.

`aim_signals` checks what the planners aim at before any planner acts: under uniform visits (a random walk
restarted at a uniform position every ``reset_every`` steps, the same transitions fed to one world per aim),
the mean value each aim gives the nodes of each third, every ``every`` steps. The issue's requirement on the
signal: large where a model is improving, about zero where it has converged and where the target is noise.
`aim_signal_summary` averages it over seeds and counts, per report step, the seeds whose top-valued third is
each third. ``python -m core.dual.checks.planner_aim signals --seeds 100-104`` prints that summary as JSON
lines; ``… check --seeds 100-109`` the shares above; ``… machinery --seeds 100-109`` the same planner
aiming at the truth (`OracleAimWorld`: 1 on the learnable third's nodes), gated by arbitration and planning
everywhere — whether the planner can use an aim at all, apart from any signal.

`fixed_start_check` asks what the uniform starts above cannot (docs/dual-system.md, items 19-20): the planners
alone on the noisy TV itself (`core.envs.noisy_tv.NoisyTVEnv`: 200-step episodes from the fixed start (−0.9,
0), the default layout), scored with the loop's measure — late-half coverage of the cells outside the noise
and late-half noise share (`late_half_measures`) — against the random walk of the same seed. From a fixed
start the map grows only where the planner has been, so an aim that can only point at the map's nodes keeps it
at home.
``… fixed --seeds 105-109 --planners progress,babbling --per-seed`` prints it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Iterator, Sequence

import numpy as np
import torch

from core.config import DualConfig
from core.dual.meta_controller import MetaController
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.noisy_tv import NoisyTVEnv, late_half_measures
from core.envs.three_regions import REGIONS, ThreeRegionsEnv, region_of

CHECK_ENV = {"frequency": 1.0, "action_gain": 1.0, "layout": ("learnable", "trivial", "noise")}
"""The check's ThreeRegions: a learnable screen sin(x + a_x)·cos(y − a_y) that the local models learn within
the check's budget (`learnability`: under uniform visits its error ratio to "nothing changes" falls from 0.47
at 1 500 steps to 0.28 at 6 000, mean of seeds 100-104; at the environment's default, f = k = 2, it stayed at
0.41-0.45), in the left third, so
that a goal at the map's centre (where a value-weighted centre of nearly equal values lies) is the trivial
third, not the learnable one (docs/dual-system.md)."""
CHECK_KINDS = np.array([REGIONS.index(name) for name in CHECK_ENV["layout"]])
"""`REGIONS` index of the check's left, middle and right third."""


EPISODE = 500
"""Steps per episode of the planners' runs (`visits`): each episode starts at a uniform position and the world
models persist across episodes. One episode per run (until item 13 of docs/dual-system.md) let the random
walk's share of the learnable third range 0.00-0.73 by seed over 8 000 steps, too wide for ten seeds to tell
planners apart; at speed 0.05 an aimed plan crosses the square in 40 steps, a walk about 0.65 in 500."""


def check_env(steps: int) -> ThreeRegionsEnv:
    """The check's environment (`CHECK_ENV`), one episode of ``steps`` steps."""
    return ThreeRegionsEnv(max_steps=steps, **CHECK_ENV)


def _random_actor(rng: np.random.Generator):
    """The check's actor: a uniform action for each latent (the random walk's), from the run's generator."""
    def actor(phi: torch.Tensor) -> torch.Tensor:
        rows = phi.reshape(-1, 3).shape[0]
        return torch.from_numpy(rng.uniform(-1.0, 1.0, size=(rows, 2)).astype(np.float32))
    return actor


def _thirds(centres: np.ndarray, unit: float) -> np.ndarray:
    """The region (`REGIONS` index, the check's layout) each node lies in, from its map coordinates and the
    map's unit."""
    return CHECK_KINDS[region_of(centres[:, 0] * unit)]


class OracleAimWorld(LocalWorldModels):
    """The machinery check's world: the aim is the truth — 1 at the nodes in the learnable third, 0
    elsewhere — so what the planner does with it measures the planner (gate, field, horizon), not a signal;
    ``plan_everywhere`` also trusts every region (the arbitration gate removed)."""

    def __init__(self, *args, plan_everywhere: bool = False, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.plan_everywhere = plan_everywhere

    def reliable(self, node: int) -> bool:
        return True if self.plan_everywhere else super().reliable(node)

    def aim_values(self, aim: str, regions: np.ndarray) -> np.ndarray:
        assert self.itm is not None and self.scale is not None
        centres, unit = self.itm.weights(regions), float(self.scale.scale)
        return (_thirds(centres, unit) == REGIONS.index("learnable")).astype(np.float64)


def _planner_world(dual: DualConfig | None, seed: int, oracle: str | None = None) -> LocalWorldModels | None:
    """The world models of the planner of ``dual`` (None: the random walk, no world), seeded by ``seed``; with
    ``oracle`` = ``gated`` or ``everywhere``, aiming at the truth (`OracleAimWorld`)."""
    if dual is None:
        return None
    generator = torch.Generator().manual_seed(seed)
    if oracle is None:
        return LocalWorldModels(dual, 3, 2, generator=generator, readings=resolve(dual))
    return OracleAimWorld(dual, 3, 2, generator=generator, readings=resolve(dual),
                          plan_everywhere=oracle == "everywhere")


def _drive(env: ThreeRegionsEnv, world: LocalWorldModels | None, steps: int, seed: int,
           ) -> Iterator[tuple[np.ndarray, dict, bool]]:
    """Run ``steps`` steps on ``env`` (reset whenever an episode ends) with the planner of ``world``
    (`_planner_world`; None: the random walk); yield each step's new observation, its info and whether the
    planner chose its action."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    meta = None if world is None else MetaController(world, world.config)
    actor = _random_actor(rng)
    for _ in range(steps):
        phi = torch.from_numpy(obs.astype(np.float32))
        action = rng.uniform(-1.0, 1.0, size=2)
        planned = False
        if world is not None and meta is not None:
            node = world.observe_state(phi)
            decision = meta.decide(phi, node, actor)
            if decision.model_based:
                planned = True
                action = decision.action.numpy().astype(np.float64)
        nxt, _, terminated, truncated, info = env.step(action.astype(np.float32))
        if world is not None:
            world.learn_transition(node, phi, torch.from_numpy(action.astype(np.float32)), 0.0,
                                   torch.from_numpy(nxt.astype(np.float32)))
        yield nxt, info, planned
        obs = nxt
        if terminated or truncated:
            obs, _ = env.reset()


def visits(dual: DualConfig | None, steps: int, seed: int, oracle: str | None = None,
           episode: int = EPISODE) -> tuple[np.ndarray, np.ndarray]:
    """Region index of every step's new position, and whether the planner chose the step's action: the
    planner of ``dual`` (None: the random walk); with ``oracle`` = ``gated`` or ``everywhere``, aiming at the
    truth (`OracleAimWorld`). Episodes of ``episode`` steps, each from a uniform start."""
    env = check_env(min(steps, episode))
    regions = np.zeros(steps, dtype=np.int64)
    planned = np.zeros(steps, dtype=bool)
    for step, (nxt, _, chose) in enumerate(_drive(env, _planner_world(dual, seed, oracle), steps, seed)):
        regions[step], planned[step] = int(env.region_at(nxt[0])), chose
    return regions, planned


def fixed_start_measures(dual: DualConfig | None, steps: int, seed: int) -> dict[str, float | int]:
    """The noisy TV's measures of one run of the planner of ``dual`` (None: the random walk) on
    `NoisyTVEnv` itself — 200-step episodes from the fixed start (−0.9, 0), the default layout (trivial |
    learnable | noise), no reward, no learner beside the planner: ``late/coverage_rest`` and
    ``late/noise_share`` of the episodes that start in the second half of ``steps`` (`late_half_measures`,
    the loop's measure), ``planned``, the share of steps the planner chose, and for a planner that babbles
    ``babbled_picks`` (babbled goals drawn) and ``dropped_at_once`` (the share of them drawn within e_max of
    the agent, so reached at once; `GoalBabbling`). The check of items 19-21 of docs/dual-system.md: with a
    fixed start the map grows only where the planner has been."""
    env = NoisyTVEnv()
    rows: list[dict[str, float]] = []
    planned = length = 0
    world = _planner_world(dual, seed)
    for step, (_, info, chose) in enumerate(_drive(env, world, steps, seed), start=1):
        planned, length = planned + chose, length + 1
        if "episode_diagnostics" in info:
            rows.append({"global_step": step, "charts/length": length, **info["episode_diagnostics"]})
            length = 0
    measures = late_half_measures(rows, budget=steps)
    out = {"coverage_rest": round(measures["late/coverage_rest"], 4),
           "noise_share": round(measures["late/noise_share"], 4), "planned": round(planned / steps, 4)}
    babbling = None if world is None else world.goal_babbling
    if babbling is not None:
        out.update(babbled_picks=babbling.picks,
                   dropped_at_once=round(babbling.dropped_at_once / max(babbling.picks, 1), 4))
    return out


def _shares(visited: tuple[np.ndarray, np.ndarray]) -> dict[str, float]:
    regions, planned = visited
    half = regions.size // 2
    learnable, noise = REGIONS.index("learnable"), REGIONS.index("noise")
    return {
        "learnable_share_first_half": float((regions[:half] == learnable).mean()),
        "learnable_share_second_half": float((regions[half:] == learnable).mean()),
        "noise_share": float((regions == noise).mean()),
        "planned": float(planned.mean()),
    }


def _uniform_visits(worlds: list[LocalWorldModels], steps: int, seed: int, reset_every: int,
                    every: int) -> Iterator[int]:
    """Feed each world the same uniform-random-action transitions of the check's environment, restarted at a
    uniform position every ``reset_every`` steps; yield the step number every ``every`` steps."""
    env = check_env(steps)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    for step in range(1, steps + 1):
        phi = torch.from_numpy(obs.astype(np.float32))
        action = rng.uniform(-1.0, 1.0, size=2).astype(np.float32)
        nxt, _, _, _, _ = env.step(action)
        for world in worlds:
            node = world.observe_state(phi)
            world.learn_transition(node, phi, torch.from_numpy(action), 0.0, torch.from_numpy(nxt))
        obs = nxt
        if step % reset_every == 0:
            obs, _ = env.reset()
        if step % every == 0:
            yield step


AIMS = ("progress", "novelty", "disagreement")
"""The aiming planners' readings (`core.dual.readings.Planner.aim`)."""


def aim_signals(dual: DualConfig, steps: int = 9000, seed: int = 100, reset_every: int = 200,
                every: int = 1000) -> list[dict[str, float | int | str]]:
    """Each aim's mean value over the live nodes of each third under uniform visits (module docstring): one
    row per (report step, aim) with ``step``, ``aim`` and the ``trivial``/``learnable``/``noise`` means (NaN
    where a third has no node yet)."""
    worlds = {}
    for aim in AIMS:
        config = dataclasses.replace(dual, planner=aim)
        worlds[aim] = LocalWorldModels(config, 3, 2, generator=torch.Generator().manual_seed(seed),
                                       readings=resolve(config))
    rows: list[dict[str, float | int | str]] = []
    for step in _uniform_visits(list(worlds.values()), steps, seed, reset_every, every):
        for aim, world in worlds.items():
            goal = world.aim_goal(aim)
            values = np.zeros(0) if goal is None else goal.values
            third = np.zeros(0) if goal is None else _thirds(goal.centres, goal.unit)
            row: dict[str, float | int | str] = {"step": step, "aim": aim}
            for index, name in enumerate(REGIONS):
                chosen = values[third == index]
                row[name] = round(float(chosen.mean()), 4) if chosen.size else float("nan")
            rows.append(row)
    return rows


def _test_transitions(env: ThreeRegionsEnv, count: int, seed: int) -> tuple[torch.Tensor, ...]:
    """``count`` transitions from uniform positions, screens and actions: (φ, a, φ′, third of φ′)."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)  # the noise third's screens come from the env's generator
    starts, screens = rng.uniform(-1.0, 1.0, size=(count, 2)), rng.uniform(-1.0, 1.0, size=count)
    actions = rng.uniform(-1.0, 1.0, size=(count, 2))
    positions, new = env.transitions(starts, screens, actions)
    phi = torch.tensor(np.c_[starts, screens], dtype=torch.float32)
    nxt = torch.tensor(np.c_[positions, new], dtype=torch.float32)
    regions = torch.from_numpy(env.region_at(positions[:, 0]))
    return phi, torch.tensor(actions, dtype=torch.float32), nxt, regions


def learnability(dual: DualConfig, steps: int = 6000, seed: int = 100, reset_every: int = 200,
                 every: int = 1500, test_size: int = 3000) -> list[dict[str, float | int]]:
    """The check's premise, measured before any aim is judged: under uniform visits (as `aim_signals`), the
    local models' Eq. 8 error over that of "nothing changes", per third of the new position, on one fixed
    set of ``test_size`` uniform test transitions (each predicted by the node its start falls in), every
    ``every`` steps. The learnable third should fall well below 1 in the budget; the noise third cannot fall
    below about 0.5 (a model of the noise's mean). The trivial third is left out: its screen keeps whatever
    value the point carried in, so uniform test screens there lie off what its models saw, and "nothing
    changes" is exact."""
    world = LocalWorldModels(dual, 3, 2, generator=torch.Generator().manual_seed(seed),
                             readings=resolve(dual))
    phi, actions, nxt, third = _test_transitions(check_env(1), test_size, seed)
    no_change = ((nxt - phi) ** 2).sum(dim=1)
    rows: list[dict[str, float | int]] = []
    for step in _uniform_visits([world], steps, seed, reset_every, every):
        with torch.no_grad():
            nodes = torch.from_numpy(np.asarray(world.nearest_many(phi), dtype=np.int64))
            errors = ((world.bank.predict(nodes, phi, actions).next_latent - nxt) ** 2).sum(dim=1)
        row: dict[str, float | int] = {"step": step, "nodes": world.num_nodes}
        for name in ("learnable", "noise"):
            chosen = third == REGIONS.index(name)
            row[name] = round(float(errors[chosen].sum() / no_change[chosen].sum()), 3)
        rows.append(row)
    return rows


PAIRED = ("learnable_share_first_half", "learnable_share_second_half", "noise_share")
"""The shares each planner is compared on with the random walk of the same seed."""


def exact_sign_flip_p(differences: Sequence[float]) -> float:
    """Two-sided exact p of the mean of paired differences under the null of symmetry about 0: the share of
    all 2ⁿ sign flips whose |mean| is at least the observed one (n ≤ 20)."""
    d = np.asarray(differences, dtype=np.float64)
    if d.size > 20:
        raise ValueError(f"exact sign flips over {d.size} pairs: at most 20")
    signs = 1 - 2 * ((np.arange(2**d.size)[:, None] >> np.arange(d.size)) & 1)
    means = np.abs(signs @ d) / d.size
    return float((means >= abs(d.mean()) - 1e-12).mean())


def _run_planners(runs: Sequence[tuple[str, DualConfig | None, str | None]], steps: int, seeds: Sequence[int],
                  per_seed: list[dict[str, object]] | None = None) -> dict[str, float]:
    """Each run's `_shares` averaged over ``seeds`` (``<name>_<share>``), and for each run but the random walk
    (which must be among them, named ``random_walk``) its mean paired difference to the walk of the same seed
    on each of `PAIRED` (``…_minus_walk``) with the exact sign-flip p (``…_p``). ``per_seed`` collects one row
    per run and seed."""
    figures = {name: [_shares(visits(config, steps, seed, oracle)) for seed in seeds]
               for name, config, oracle in runs}
    out: dict[str, float] = {}
    for name, rows in figures.items():
        out.update({f"{name}_{key}": round(float(np.mean([row[key] for row in rows])), 3) for key in rows[0]})
        if per_seed is not None:
            per_seed.extend({"planner": name, "seed": seed, **{k: round(v, 4) for k, v in row.items()}}
                            for seed, row in zip(seeds, rows, strict=True))
    for name, rows in figures.items():
        if name != "random_walk":
            out.update(_versus_walk(name, rows, figures["random_walk"], PAIRED, digits=3))
    return out


def _versus_walk(name: str, rows: Sequence[dict[str, float]], walk: Sequence[dict[str, float]],
                 keys: Sequence[str], digits: int) -> dict[str, float]:
    """A planner's per-seed ``rows`` against the random walk's of the same seeds, on each of ``keys``: the
    mean paired difference (``<name>_<key>_minus_walk``, rounded to ``digits``) and its exact sign-flip p
    (``<name>_<key>_p``)."""
    out: dict[str, float] = {}
    for key in keys:
        differences = [row[key] - base[key] for row, base in zip(rows, walk, strict=True)]
        out[f"{name}_{key}_minus_walk"] = round(float(np.mean(differences)), digits)
        out[f"{name}_{key}_p"] = round(exact_sign_flip_p(differences), 3)
    return out


def machinery_check(dual: DualConfig, steps: int = 6000, seeds: int = 10, first_seed: int = 100,
                    per_seed: list[dict[str, object]] | None = None) -> dict[str, float]:
    """The planner with the true aim (`OracleAimWorld`), gated by arbitration and planning everywhere, beside
    the random walk: ``oracle_gated_…``, ``oracle_everywhere_…`` and ``random_walk_…`` shares, with the share
    of steps the planner chose (``…_planned``) and the paired comparisons with the walk (`_run_planners`)."""
    config = dataclasses.replace(dual, planner="progress")
    runs = (("oracle_gated", config, "gated"), ("oracle_everywhere", config, "everywhere"),
            ("random_walk", None, None))
    return _run_planners(runs, steps, range(first_seed, first_seed + seeds), per_seed)


def planner_aim_check(dual: DualConfig, steps: int = 12000, seeds: int = 3, first_seed: int = 100,
                      per_seed: list[dict[str, object]] | None = None) -> dict[str, float]:
    """The JSON figures (module docstring): ``progress_…``, ``novelty_…``, ``disagreement_…`` and
    ``random_walk_…`` shares and the paired comparisons with the walk (`_run_planners`), over seeds
    ``first_seed`` … (tuning seeds ≥ 100; the first table in docs/dual-system.md ran seeds 0-9)."""
    runs = tuple((name, None if reading is None else dataclasses.replace(dual, planner=reading), None)
                 for name, reading in (("progress", "progress"), ("novelty", "novelty"),
                                       ("disagreement", "disagreement"), ("random_walk", None)))
    return _run_planners(runs, steps, range(first_seed, first_seed + seeds), per_seed)


FIXED_START_PAIRED = ("coverage_rest", "noise_share")
"""The fixed-start check's measures, each compared with the random walk of the same seed."""


def fixed_start_check(dual: DualConfig, steps: int = 20000, seeds: Sequence[int] = range(100, 105),
                      planners: Sequence[str] = AIMS,
                      per_seed: list[dict[str, object]] | None = None) -> dict[str, float]:
    """`fixed_start_measures` of each aiming planner (``planners``, `dual.planner` readings) and the random
    walk, averaged over ``seeds`` (``<planner>_<measure>``), with each planner's mean paired difference to
    the walk of the same seed (``…_minus_walk``) and its exact sign-flip p (``…_p``); ``per_seed`` collects
    one row per planner and seed."""
    configs = {name: dataclasses.replace(dual, planner=name) for name in planners}
    runs = {name: [fixed_start_measures(configs.get(name), steps, seed) for seed in seeds]
            for name in (*planners, "random_walk")}
    out: dict[str, float] = {}
    for name, rows in runs.items():
        out.update({f"{name}_{key}": round(float(np.mean([row[key] for row in rows])), 4) for key in rows[0]})
        if per_seed is not None:
            per_seed.extend({"planner": name, "seed": seed, **row}
                            for seed, row in zip(seeds, rows, strict=True))
        if name != "random_walk":
            out.update(_versus_walk(name, rows, runs["random_walk"], FIXED_START_PAIRED, digits=4))
    return out


def aim_signal_summary(dual: DualConfig, seeds: Sequence[int], steps: int = 9000,
                       every: int = 1000) -> list[dict[str, object]]:
    """`aim_signals` over ``seeds``: per (step, aim), each third's mean value over seeds and ``top``, how many
    seeds valued each third highest."""
    runs = [aim_signals(dual, steps=steps, seed=seed, every=every) for seed in seeds]
    summary: list[dict[str, object]] = []
    for index, first in enumerate(runs[0]):
        rows = [run[index] for run in runs]
        means = {name: round(float(np.nanmean([row[name] for row in rows])), 4) for name in REGIONS}
        top = dict.fromkeys(REGIONS, 0)
        for row in rows:
            values = {name: float(row[name]) for name in REGIONS if np.isfinite(float(row[name]))}
            top[max(values, key=values.__getitem__)] += 1
        summary.append({"step": first["step"], "aim": first["aim"], **means, "top": top})
    return summary


def _seed_range(text: str) -> list[int]:
    first, _, last = text.partition("-")
    return list(range(int(first), int(last or first) + 1))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m core.dual.checks.planner_aim {learnability,signals,check,machinery} --seeds A-B
    [--steps N]``: JSON lines."""
    from core.config import load_config

    parser = argparse.ArgumentParser(prog="python -m core.dual.checks.planner_aim",
                                     description=(__doc__ or "").split("\n")[0])
    parser.add_argument("what", choices=("learnability", "signals", "check", "machinery", "fixed"),
                        help="the models' error ratio per third, the aims' values per third, the planners' "
                             "shares, the oracle aim's, or the planners' noisy-TV measures from its fixed "
                             "start")
    parser.add_argument("--planners", default=",".join(AIMS),
                        help="fixed: the dual.planner readings to run beside the walk (comma-separated)")
    parser.add_argument("--seeds", type=_seed_range, default=_seed_range("100-104"), help="e.g. 100-104")
    parser.add_argument("--steps", type=int, default=None,
                        help="6000 (learnability), 9000 (signals), 8000 (check), 6000 (machinery) or 20000 "
                             "(fixed)")
    parser.add_argument("--per-seed", action="store_true",
                        help="check, machinery: also print one JSON line per planner and seed")
    args = parser.parse_args(argv)
    dual = load_config("default").dual
    torch.set_num_threads(1)
    if args.what == "learnability":
        for seed in args.seeds:
            for row in learnability(dual, steps=args.steps or 6000, seed=seed):
                print(json.dumps({"seed": seed, **row}))
    elif args.what == "fixed":
        per_seed: list[dict[str, object]] = []
        figures = fixed_start_check(dual, steps=args.steps or 20000, seeds=args.seeds,
                                    planners=args.planners.split(","), per_seed=per_seed)
        for row in per_seed if args.per_seed else []:
            print(json.dumps(row))
        print(json.dumps(figures))
    elif args.what == "signals":
        for row in aim_signal_summary(dual, args.seeds, steps=args.steps or 9000):
            print(json.dumps(row))
    else:
        per_seed: list[dict[str, object]] = []
        check = machinery_check if args.what == "machinery" else planner_aim_check
        shares = check(dual, steps=args.steps or (6000 if args.what == "machinery" else 8000),
                       seeds=len(args.seeds), first_seed=args.seeds[0], per_seed=per_seed)
        for row in per_seed if args.per_seed else []:
            print(json.dumps(row))
        print(json.dumps(shares))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
