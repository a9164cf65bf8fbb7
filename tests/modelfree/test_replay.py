"""Pixel replay (frames stored once, no episode-boundary crossing) and latent replay (modelfree/replay.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from core.modelfree.replay import LatentReplay, PixelReplay

SHAPE = (4, 6, 3)


def frame(episode: int, step: int) -> np.ndarray:
    """A frame that encodes (episode, step) in its pixels."""
    image = np.zeros(SHAPE, dtype=np.uint8)
    image[..., 0] = episode
    image[..., 1] = step
    return image


def fill(replay: PixelReplay, lengths: list[int], terminal_last: bool = True) -> None:
    for episode, length in enumerate(lengths):
        replay.start_episode(frame(episode, 0))
        for step in range(length):
            action = np.array([episode + step / 100.0], dtype=np.float32)
            replay.add(
                action,
                reward=float(10 * episode + step),
                next_obs=frame(episode, step + 1),
                terminated=terminal_last and step == length - 1,
                reward_ext=-float(step),
            )


def check_consistent(batch) -> None:
    obs_episode, obs_step = batch.obs[:, 0, 0, 0].long(), batch.obs[:, 0, 0, 1].long()
    next_episode, next_step = batch.next_obs[:, 0, 0, 0].long(), batch.next_obs[:, 0, 0, 1].long()
    assert torch.equal(obs_episode, next_episode), "a transition crossed an episode boundary"
    assert torch.equal(next_step, obs_step + 1)
    assert torch.allclose(batch.action[:, 0], obs_episode + obs_step / 100.0)
    assert torch.equal(batch.reward, (10 * obs_episode + obs_step).float())
    assert torch.equal(batch.reward_ext, -obs_step.float())
    assert batch.obs.dtype == torch.uint8 and batch.obs.shape[1:] == SHAPE


def test_sampled_transitions_match_and_never_cross_episodes():
    replay = PixelReplay(capacity=1000, obs_shape=SHAPE, action_dim=1)
    lengths = [1, 3, 5, 2, 7]
    fill(replay, lengths)
    assert len(replay) == sum(lengths)
    assert replay.frames_written == sum(lengths) + len(lengths)  # each frame once: L + 1 per episode
    batch = replay.sample(512, np.random.default_rng(0))
    check_consistent(batch)
    # terminated exactly on each episode's last step
    last = torch.tensor([lengths[e] - 1 for e in batch.obs[:, 0, 0, 0].long().tolist()])
    assert torch.equal(batch.terminated.bool(), batch.obs[:, 0, 0, 1].long() == last)


def test_ring_overwrite_keeps_only_alive_consistent_transitions():
    replay = PixelReplay(capacity=20, obs_shape=SHAPE, action_dim=1)
    fill(replay, [3, 4, 2, 6, 5, 3, 7, 2, 4] * 3)
    assert 0 < len(replay) <= 20
    batch = replay.sample(2000, np.random.default_rng(1))
    check_consistent(batch)
    # only the most recent episodes survive
    assert int(batch.obs[:, 0, 0, 0].min()) >= 20


def test_short_episodes_reduce_capacity_but_stay_consistent():
    replay = PixelReplay(capacity=16, obs_shape=SHAPE, action_dim=1)
    fill(replay, [1] * 50)  # 2 frames per transition
    assert 0 < len(replay) <= 16
    check_consistent(replay.sample(500, np.random.default_rng(2)))


def test_state_dict_round_trip_saves_only_the_filled_part(tmp_path):
    replay = PixelReplay(capacity=30, obs_shape=SHAPE, action_dim=1)
    fill(replay, [5, 6, 7, 8, 9, 4])
    state = replay.state_dict()
    assert state["frames"].shape[0] <= replay.frame_capacity and state["frames"].dtype == torch.uint8
    torch.save(state, tmp_path / "r.pt")
    restored = PixelReplay(capacity=30, obs_shape=SHAPE, action_dim=1)
    restored.load_state_dict(torch.load(tmp_path / "r.pt", weights_only=True))
    assert len(restored) == len(replay)
    a, b = replay.sample(64, np.random.default_rng(3)), restored.sample(64, np.random.default_rng(3))
    for left, right in zip(a, b, strict=True):
        assert torch.equal(left, right)
    small = PixelReplay(capacity=1000, obs_shape=SHAPE, action_dim=1)
    fill(small, [3])
    assert small.state_dict()["frames"].shape[0] == 4  # never the empty tail


def test_add_before_start_and_empty_sample_raise():
    replay = PixelReplay(capacity=4, obs_shape=SHAPE, action_dim=1)
    with pytest.raises(RuntimeError):
        replay.add(np.zeros(1), 0.0, frame(0, 1), False)
    with pytest.raises(RuntimeError):
        replay.sample(1, np.random.default_rng(0))


def test_latent_replay_ring_and_round_trip():
    replay = LatentReplay(capacity=5, latent_dim=3, action_dim=1)
    for start in range(0, 8, 2):
        ids = np.arange(start, start + 2, dtype=np.float32)
        replay.add_batch(np.repeat(ids[:, None], 3, 1), ids[:, None], ids, np.repeat(ids[:, None] + 1, 3, 1))
    assert len(replay) == 5
    batch = replay.sample(100, np.random.default_rng(0))
    ids = batch.latent[:, 0]
    assert torch.equal(batch.action[:, 0], ids) and torch.equal(batch.reward, ids)
    assert torch.equal(batch.next_latent[:, 0], ids + 1)
    assert int(ids.min()) >= 3  # the oldest three were overwritten
    restored = LatentReplay(capacity=5, latent_dim=3, action_dim=1)
    restored.load_state_dict(replay.state_dict())
    again = restored.sample(100, np.random.default_rng(0))
    assert torch.equal(again.latent, batch.latent)


def test_float_observations_round_trip_exactly_in_their_own_dtype():
    rng = np.random.default_rng(0)
    states = rng.normal(0.0, 1e3, (6, 5)) * np.array([1.0, 1e-7, 1e7, -1.0, 3.14159])  # float64, odd scales
    replay = PixelReplay(capacity=10, obs_shape=(5,), action_dim=2, obs_dtype="float64")
    replay.start_episode(states[0])
    for step in range(1, 6):
        replay.add(np.zeros(2, np.float32), 0.0, states[step], terminated=False)
    batch = replay.gather(np.arange(5))
    assert batch.obs.dtype == torch.float64
    assert np.array_equal(batch.obs.numpy(), states[:5])
    assert np.array_equal(batch.next_obs.numpy(), states[1:])
    restored = PixelReplay(capacity=10, obs_shape=(5,), action_dim=2, obs_dtype="float64")
    restored.load_state_dict(replay.state_dict())
    assert np.array_equal(restored.gather(np.arange(5)).obs.numpy(), states[:5])


def test_images_take_one_byte_per_channel():
    replay = PixelReplay(capacity=100, obs_shape=(48, 48, 3), action_dim=1)
    assert replay.frames.dtype == np.uint8
    assert replay.frames.nbytes == replay.frame_capacity * 48 * 48 * 3


@pytest.mark.parametrize(
    ("buffer_dtype", "obs"),
    [
        ("uint8", np.full(SHAPE, -1.2, dtype=np.float32)),  # MountainCar's position would have become 255
        ("float32", np.zeros((3,), dtype=np.float64)),
        ("uint8", np.zeros(SHAPE, dtype=np.int64)),
    ],
)
def test_a_lossy_write_is_an_error_not_a_cast(buffer_dtype, obs):
    replay = PixelReplay(capacity=4, obs_shape=obs.shape, action_dim=1, obs_dtype=buffer_dtype)
    with pytest.raises(TypeError, match="without loss"):
        replay.start_episode(obs)


def test_a_lossless_write_is_stored():
    replay = PixelReplay(capacity=4, obs_shape=(3,), action_dim=1, obs_dtype="float64")
    replay.start_episode(np.array([1.5, -2.0, 0.25], dtype=np.float32))  # float32 → float64 is exact
    assert replay.frames[0].tolist() == [1.5, -2.0, 0.25]
