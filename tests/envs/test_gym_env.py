"""Any gymnasium task (core/envs/gym_env.py): what each space becomes, what is refused, and how."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from core.config import EnvConfig
from core.envs.gym_env import EnvError, episode_success, make_env
from tests.utils import toy_envs  # noqa: F401  (registers dualsys_test/... ids)
from tests.utils.toy_envs import REFUSED, ToyImageEnv


def test_a_vector_task_keeps_its_dtype_and_bounds_and_needs_no_rescaling():
    adapted = make_env(EnvConfig(id="MountainCarContinuous-v0"))
    spec = adapted.spec
    assert (spec.obs_kind, spec.obs_shape, spec.obs_dtype) == ("vector", (2,), "float32")
    assert spec.obs_low == pytest.approx((-1.2, -0.07)) and spec.obs_high == pytest.approx((0.6, 0.07))
    assert (spec.action_low, spec.action_high) == ((-1.0,), (1.0,)) and adapted.notes == []
    adapted.env.close()


def test_bounds_other_than_unit_are_rescaled_and_said():
    adapted = make_env(EnvConfig(id="Pendulum-v1"))
    assert adapted.spec.action_low == (-2.0,) and adapted.spec.action_high == (2.0,)
    assert any("rescaled" in note for note in adapted.notes)
    assert adapted.env.action_space.low.tolist() == [-1.0] and adapted.env.action_space.high.tolist() == [1.0]
    adapted.env.close()


def test_channel_first_images_are_transposed_and_said():
    adapted = make_env(EnvConfig(id="dualsys_test/ToyImage-v0", kwargs={"channel_first": True}))
    spec = adapted.spec
    assert (spec.obs_kind, spec.obs_shape, spec.obs_dtype) == ("image", (48, 48, 3), "uint8")
    assert any("channel-first" in note for note in adapted.notes)
    obs, _ = adapted.env.reset(seed=0)
    assert obs.shape == (48, 48, 3) and obs.dtype == np.uint8
    adapted.env.close()


def test_dict_observations_are_flattened():
    pytest.importorskip("shimmy", reason="dm_control tasks need the dmc extra")
    adapted = make_env(EnvConfig(id="dm_control/cartpole-swingup_sparse-v0"))
    assert adapted.spec.obs_kind == "vector" and adapted.spec.obs_shape == (5,)
    assert adapted.spec.obs_dtype == "float64" and adapted.spec.obs_low is None
    assert any("Dict" in note for note in adapted.notes)
    adapted.env.close()


@pytest.mark.parametrize(("env_id", "message"), REFUSED)
def test_what_cannot_be_trained_is_one_line_naming_the_space(env_id, message):
    with pytest.raises(EnvError, match=re.escape(message)) as caught:
        make_env(EnvConfig(id=env_id))
    assert "\n" not in str(caught.value)


def test_nico_grasp_rejects_gym_kwargs_and_a_reward_offset():
    with pytest.raises(EnvError, match=r"env\.kwargs and env\.reward_offset are for tasks other than"):
        make_env(EnvConfig(kwargs={"max_episode_steps": 3}))
    with pytest.raises(EnvError, match=r"env\.reward_offset are for tasks other than NicoGrasp"):
        make_env(EnvConfig(reward_offset=-0.1))


def test_a_reward_offset_adds_a_constant_to_every_step_and_keeps_the_episode():
    plain = make_env(EnvConfig(id="MountainCarContinuous-v0")).env
    offset = make_env(EnvConfig(id="MountainCarContinuous-v0", reward_offset=-0.015)).env
    plain.reset(seed=3)
    offset.reset(seed=3)
    for action in (-1.0, 0.3, 1.0):
        *step_plain, _ = plain.step(np.array([action], dtype=np.float32))
        *step_offset, _ = offset.step(np.array([action], dtype=np.float32))
        np.testing.assert_array_equal(step_plain[0], step_offset[0])
        assert step_offset[1] == pytest.approx(step_plain[1] - 0.015, abs=1e-12)
        assert step_offset[2:] == step_plain[2:]
    plain.close()
    offset.close()


def test_success_rules():
    assert episode_success({"success": True}, True, False, "info")
    assert episode_success({"is_success": 1.0}, False, True, "info")
    assert not episode_success({}, True, False, "info")
    assert episode_success({}, True, False, "terminated")
    assert not episode_success({}, True, True, "terminated")
    assert not episode_success({}, False, True, "terminated")


def test_the_toy_image_env_passes_gymnasiums_checker():
    check_env(ToyImageEnv(), skip_render_check=True)
    check_env(gym.make("dualsys_test/ToyImage-v0", channel_first=True).unwrapped, skip_render_check=True)
