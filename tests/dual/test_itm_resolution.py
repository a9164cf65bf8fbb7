"""The scale-free ITM resolution (dual.e_max_relative) and the `dualsys diagnose regions` diagnostic."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from core.config import load_config
from core.dual.itm_resolution import RelativeResolution
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from tests.utils.paper_dual import paper_dual_overrides


def test_relative_e_max_is_rho_times_the_median_pairwise_distance():
    rng = np.random.default_rng(0)
    latents = rng.normal(scale=0.01, size=(64, 8))
    resolution = RelativeResolution(0.5, latent_dim=8, window=64, every=64, sample=64)
    outputs = [resolution.observe(phi) for phi in latents]
    assert outputs[:-1] == [None] * 63
    diffs = latents[:, None] - latents[None]
    distances = np.sqrt((diffs**2).sum(-1))[np.triu_indices(64, k=1)]
    assert outputs[-1] == pytest.approx(0.5 * np.median(distances))


def _world(*overrides: str) -> LocalWorldModels:
    """The paper's raw-latent ITM (e_max = 6), where the e_max_relative option applies."""
    dual = load_config("default", [*paper_dual_overrides(), *overrides]).dual
    return LocalWorldModels(dual, latent_dim=8, action_dim=1, generator=torch.Generator().manual_seed(0),
                            readings=resolve(dual))


def test_absolute_e_max_keeps_a_small_latent_cloud_in_two_nodes_and_relative_makes_regions():
    latents = torch.from_numpy(np.random.default_rng(1).normal(scale=0.01, size=(1024, 8))).float()
    absolute, relative = _world(), _world("dual.e_max_relative=0.8")
    for phi in latents:
        absolute.observe_state(phi)
        relative.observe_state(phi)
    assert absolute.num_nodes == 2  # e_max = 6 is far beyond every distance in this cloud
    assert relative.num_nodes > 4
    assert relative.itm.e_max == pytest.approx(relative.resolution.current)


def test_relative_resolution_survives_a_checkpoint():
    latents = torch.from_numpy(np.random.default_rng(2).normal(size=(600, 8))).float()
    world = _world("dual.e_max_relative=1.0")
    for phi in latents:
        world.observe_state(phi)
    restored = _world("dual.e_max_relative=1.0")
    restored.load_state_dict(world.state_dict())
    assert restored.itm.e_max == world.itm.e_max
    assert restored.resolution.current == world.resolution.current
    for phi in latents[:300]:  # the restored tracker continues exactly (same window, same sampling)
        world.observe_state(phi)
        restored.observe_state(phi)
    assert restored.itm.e_max == world.itm.e_max and restored.num_nodes == world.num_nodes


def test_bad_relative_e_max_is_a_config_error():
    from core.config import ConfigError, check_config

    with pytest.raises(ConfigError, match=r"dual\.e_max_relative"):
        check_config(load_config("default", ["dual.e_max_relative=-1"]))


def test_diagnose_regions_reports_distances_and_node_counts(tmp_path):
    run = tmp_path / "run"
    train = subprocess.run(
        [sys.executable, "-m", "dualsys_cli.main", "train", "--algo", "ddpg", "--reward", "sparse",
         "--steps", "40", "--set", "env.level=hard", "--set", "net.conv_channels=4,4",
         "--set", "agent.learning_starts=10",
         "--set", "run.eval_every=0", "--set", "run.eval_episodes=1", "--out", str(run)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert train.returncode == 0, train.stderr
    result = subprocess.run(
        [sys.executable, "-m", "dualsys_cli.main", "diagnose", "regions", str(run), "--episodes", "3",
         "--e-max", "6,0.001", "--json"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["level"] == "hard" and payload["states"] >= 4
    assert payload["nodes"]["6"] <= payload["nodes"]["0.001"]
    assert payload["pairwise_distance"]["q05"] <= payload["pairwise_distance"]["q95"]
    bad = subprocess.run(
        [sys.executable, "-m", "dualsys_cli.main", "diagnose", "regions", str(run), "--e-max", "x"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert bad.returncode == 2 and "error: --e-max" in bad.stderr


def test_latent_scale_is_scale_free_and_shrinks_slowly() -> None:
    from core.dual.itm_resolution import LatentScale

    latents = np.random.default_rng(2).normal(size=(400, 8))
    one, hundred = LatentScale(8), LatentScale(8)
    for phi in latents:
        one.observe(phi)
        hundred.observe(100.0 * phi)
    assert hundred.scale == pytest.approx(100.0 * one.scale, rel=1e-9)
    np.testing.assert_allclose(hundred.normalise(100.0 * latents[:5]), one.normalise(latents[:5]), rtol=1e-9)
    assert one.scale == pytest.approx(np.sqrt(8.0), rel=0.2)  # RMS distance from the mean
    grown = one.scale
    for phi in latents[:200]:  # the latents gather in a corner: the recent spread drops 100×
        one.observe(0.01 * phi)
    assert one.scale > 0.95 * grown  # s follows a spread up at once and down over ~20 000 states


def test_normalised_regions_count_the_same_at_any_latent_scale() -> None:
    from core.dual.checks.regions import episode_stream, node_count

    dual = load_config("default").dual
    latents = episode_stream(1200, seed=3)
    counts = [node_count(dual, latents * scale) for scale in (0.01, 1.0, 100.0)]
    assert max(counts) <= min(counts) + 1 and min(counts) >= 5
    # An encoder whose latents grow 100× over 3000 states (ours: about 2300 steps, docs/results.md).
    longer = episode_stream(3000, seed=3)
    growing = longer * np.geomspace(0.01, 1.0, len(longer))[:, None]
    assert node_count(dual, growing) <= 2 * node_count(dual, longer)
    literal = [node_count(load_config("paper").dual, latents * scale) for scale in (0.01, 100.0)]
    assert literal[0] == 2 and literal[1] > 100
