"""Replay buffers: observation replay (B / B_pixel) and float32 latent replay (B_latent, Section 3).

PixelReplay stores observations in their own dtype: uint8 images take one byte per channel, float
vectors keep their float32/float64 values exactly. A write whose dtype cannot be cast to the buffer's
without loss (a float into a uint8 buffer, float64 into float32) is a TypeError, never a silent cast.

PixelReplay stores every frame once. An episode of L steps writes L + 1 frames (the first observation,
then each next observation) and L transition rows that point at their two frames by a global frame id:
the next observation is found by index, not stored twice, and the last transition of an episode points
at that episode's own final frame, so sampling never crosses an episode boundary.

Frames live in a ring of ``frame_capacity`` slots (default ``capacity + capacity // 4``, enough for
episodes of ≥ 4 steps to keep ``capacity`` transitions sampleable); a transition stays sampleable while
its frames are alive and it is among the last ``capacity`` rows. Memory for the 100k-transition
capacity: 125 000 frames × 6 144 B (32×64×3 uint8) ≈ 768 MB, plus 29 B of row data per transition
(two int64 frame ids, a float32 action for 1-D actions, two float32 rewards, a bool) ≈ 2.9 MB.

Sampling is one vectorised fancy-index per array (``frames[ids % F]``) with the run's seeded NumPy
generator. Both buffers save only their filled part in a ``weights_only``-loadable dict of tensors.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch


class PixelBatch(NamedTuple):
    """A minibatch of real transitions (s, a, r, s′, terminated); obs stay uint8 ``[B, H, W, C]``."""

    obs: torch.Tensor
    action: torch.Tensor
    reward: torch.Tensor
    next_obs: torch.Tensor
    terminated: torch.Tensor
    reward_ext: torch.Tensor


class LatentBatch(NamedTuple):
    """A minibatch of latent transitions (φ, a, r, φ′, done), all float32."""

    latent: torch.Tensor
    action: torch.Tensor
    reward: torch.Tensor
    next_latent: torch.Tensor
    done: torch.Tensor


class PixelReplay:
    """Observation replay storing each frame once; see the module docstring for the layout."""

    def __init__(
        self,
        capacity: int,
        obs_shape: tuple[int, ...],
        action_dim: int,
        obs_dtype: str | np.dtype = "uint8",
        frame_capacity: int | None = None,
    ) -> None:
        if capacity < 1:
            raise ValueError(f"replay capacity must be >= 1, got {capacity}")
        self.capacity = capacity
        self.frame_capacity = frame_capacity or capacity + capacity // 4 + 2
        self.obs_shape = tuple(obs_shape)
        self.action_dim = action_dim
        self.obs_dtype = np.dtype(obs_dtype)
        self.frames = np.zeros((self.frame_capacity, *self.obs_shape), dtype=self.obs_dtype)
        self.obs_id = np.zeros(capacity, dtype=np.int64)
        self.next_id = np.zeros(capacity, dtype=np.int64)
        self.action = np.zeros((capacity, action_dim), dtype=np.float32)
        self.reward = np.zeros(capacity, dtype=np.float32)
        self.reward_ext = np.zeros(capacity, dtype=np.float32)
        self.terminated = np.zeros(capacity, dtype=bool)
        self.frames_written = 0
        """Global count of frames ever written; frame id g lives in slot g % frame_capacity."""
        self.rows_written = 0
        """Global count of transitions ever written; row id t lives in slot t % capacity."""
        self.first_alive_row = 0
        """Smallest row id whose obs frame has not been overwritten."""
        self._current_frame: int | None = None

    # -- writing -------------------------------------------------------------------------------
    def start_episode(self, obs: np.ndarray) -> None:
        """Store the first observation of an episode."""
        self._current_frame = self._write_frame(obs)

    def add(
        self,
        action: np.ndarray,
        reward: float,
        next_obs: np.ndarray,
        terminated: bool,
        reward_ext: float | None = None,
    ) -> None:
        """Store (s_t, a_t, r_t, s_{t+1}, terminated) where s_t is the last stored frame of this episode.

        ``reward`` is what the critic learns from (r = r_ext + r_int for the dual-system methods);
        ``reward_ext`` the environment's reward (defaults to ``reward``).
        """
        if self._current_frame is None:
            raise RuntimeError("PixelReplay.add before start_episode")
        obs_frame = self._current_frame
        next_frame = self._write_frame(next_obs)
        slot = self.rows_written % self.capacity
        self.obs_id[slot] = obs_frame
        self.next_id[slot] = next_frame
        self.action[slot] = np.asarray(action, dtype=np.float32).reshape(self.action_dim)
        self.reward[slot] = reward
        self.reward_ext[slot] = reward if reward_ext is None else reward_ext
        self.terminated[slot] = terminated
        self.rows_written += 1
        self._current_frame = next_frame

    def _write_frame(self, obs: np.ndarray) -> int:
        dtype = getattr(obs, "dtype", None)
        if dtype is not None and dtype != self.obs_dtype and not np.can_cast(dtype, self.obs_dtype, "safe"):
            raise TypeError(
                f"observation of dtype {dtype} cannot be stored in a {self.obs_dtype} replay without loss"
            )
        frame_id = self.frames_written
        self.frames[frame_id % self.frame_capacity] = obs
        self.frames_written += 1
        self._advance_alive(oldest_alive_frame=self.frames_written - self.frame_capacity)
        return frame_id

    def _advance_alive(self, oldest_alive_frame: int) -> None:
        start = max(self.first_alive_row, self.rows_written - self.capacity)
        while start < self.rows_written and self.obs_id[start % self.capacity] < oldest_alive_frame:
            start += 1
        self.first_alive_row = start

    # -- reading -------------------------------------------------------------------------------
    def __len__(self) -> int:
        return self.rows_written - self._oldest_row()

    def _oldest_row(self) -> int:
        return max(self.first_alive_row, self.rows_written - self.capacity)

    def sample(self, batch_size: int, rng: np.random.Generator) -> PixelBatch:
        """Uniformly sample ``batch_size`` stored transitions (with replacement), vectorised."""
        if len(self) == 0:
            raise RuntimeError("cannot sample from an empty replay buffer")
        rows = rng.integers(self._oldest_row(), self.rows_written, size=batch_size) % self.capacity
        return self.gather(rows)

    def gather(self, slots: np.ndarray) -> PixelBatch:
        """The transitions in ring ``slots`` as a batch."""
        obs = self.frames[self.obs_id[slots] % self.frame_capacity]
        next_obs = self.frames[self.next_id[slots] % self.frame_capacity]
        return PixelBatch(
            obs=torch.from_numpy(obs),
            action=torch.from_numpy(self.action[slots]),
            reward=torch.from_numpy(self.reward[slots]),
            next_obs=torch.from_numpy(next_obs),
            terminated=torch.from_numpy(self.terminated[slots].astype(np.float32)),
            reward_ext=torch.from_numpy(self.reward_ext[slots]),
        )

    # -- persistence ---------------------------------------------------------------------------
    def state_dict(self) -> dict[str, torch.Tensor | int]:
        """Only the filled part: alive frames in id order and alive rows in id order (uint8 frames)."""
        first_row = self._oldest_row()
        rows = np.arange(first_row, self.rows_written) % self.capacity
        first_frame = max(0, self.frames_written - self.frame_capacity)
        if self.rows_written > first_row:
            first_frame = max(first_frame, int(self.obs_id[first_row % self.capacity]))
        elif self._current_frame is not None:
            first_frame = max(first_frame, self._current_frame)
        frame_slots = np.arange(first_frame, self.frames_written) % self.frame_capacity
        return {
            "capacity": self.capacity,
            "frame_capacity": self.frame_capacity,
            "frames_written": self.frames_written,
            "rows_written": self.rows_written,
            "first_frame": first_frame,
            "first_row": first_row,
            "current_frame": -1 if self._current_frame is None else self._current_frame,
            "frames": torch.from_numpy(self.frames[frame_slots]),
            "obs_id": torch.from_numpy(self.obs_id[rows]),
            "next_id": torch.from_numpy(self.next_id[rows]),
            "action": torch.from_numpy(self.action[rows]),
            "reward": torch.from_numpy(self.reward[rows]),
            "reward_ext": torch.from_numpy(self.reward_ext[rows]),
            "terminated": torch.from_numpy(self.terminated[rows]),
        }

    def load_state_dict(self, state: dict) -> None:
        """Restore a buffer saved by :meth:`state_dict` (capacities must match)."""
        if int(state["capacity"]) != self.capacity or int(state["frame_capacity"]) != self.frame_capacity:
            raise ValueError("replay capacity differs from the saved buffer")
        self.frames_written = int(state["frames_written"])
        self.rows_written = int(state["rows_written"])
        first_frame, first_row = int(state["first_frame"]), int(state["first_row"])
        frame_slots = np.arange(first_frame, self.frames_written) % self.frame_capacity
        self.frames[frame_slots] = state["frames"].numpy()
        rows = np.arange(first_row, self.rows_written) % self.capacity
        self.obs_id[rows] = state["obs_id"].numpy()
        self.next_id[rows] = state["next_id"].numpy()
        self.action[rows] = state["action"].numpy()
        self.reward[rows] = state["reward"].numpy()
        self.reward_ext[rows] = state["reward_ext"].numpy()
        self.terminated[rows] = state["terminated"].numpy()
        self.first_alive_row = first_row
        current = int(state["current_frame"])
        self._current_frame = None if current < 0 else current

    @staticmethod
    def nbytes_per_transition(obs_shape: tuple[int, ...], action_dim: int) -> float:
        """Bytes per transition of capacity (frames at the default 1.25 frames/transition + row data)."""
        frame = int(np.prod(obs_shape))
        return 1.25 * frame + 8 + 8 + 4 * action_dim + 4 + 4 + 1


class LatentReplay:
    """Ring buffer of float32 latent transitions (φ, a, r, φ′, done) for B_latent (Algorithm 3, line 17)."""

    def __init__(self, capacity: int, latent_dim: int, action_dim: int) -> None:
        if capacity < 1:
            raise ValueError(f"replay capacity must be >= 1, got {capacity}")
        self.capacity = capacity
        self.latent = np.zeros((capacity, latent_dim), dtype=np.float32)
        self.action = np.zeros((capacity, action_dim), dtype=np.float32)
        self.reward = np.zeros(capacity, dtype=np.float32)
        self.next_latent = np.zeros((capacity, latent_dim), dtype=np.float32)
        self.done = np.zeros(capacity, dtype=np.float32)
        self.rows_written = 0

    def __len__(self) -> int:
        return min(self.rows_written, self.capacity)

    def add_batch(
        self,
        latent: np.ndarray | torch.Tensor,
        action: np.ndarray | torch.Tensor,
        reward: np.ndarray | torch.Tensor,
        next_latent: np.ndarray | torch.Tensor,
        done: np.ndarray | torch.Tensor | None = None,
    ) -> None:
        """Append N transitions (arrays with a leading N axis), vectorised."""
        latent_np = _as_numpy(latent).reshape(-1, self.latent.shape[1])
        count = latent_np.shape[0]
        if count == 0:
            return
        slots = np.arange(self.rows_written, self.rows_written + count) % self.capacity
        self.latent[slots] = latent_np
        self.action[slots] = _as_numpy(action).reshape(count, -1)
        self.reward[slots] = _as_numpy(reward).reshape(count)
        self.next_latent[slots] = _as_numpy(next_latent).reshape(count, -1)
        self.done[slots] = 0.0 if done is None else _as_numpy(done).reshape(count)
        self.rows_written += count

    def sample(self, batch_size: int, rng: np.random.Generator) -> LatentBatch:
        if len(self) == 0:
            raise RuntimeError("cannot sample from an empty replay buffer")
        slots = rng.integers(0, len(self), size=batch_size)
        return LatentBatch(
            latent=torch.from_numpy(self.latent[slots]),
            action=torch.from_numpy(self.action[slots]),
            reward=torch.from_numpy(self.reward[slots]),
            next_latent=torch.from_numpy(self.next_latent[slots]),
            done=torch.from_numpy(self.done[slots]),
        )

    def state_dict(self) -> dict[str, torch.Tensor | int]:
        filled = len(self)
        return {
            "capacity": self.capacity,
            "rows_written": self.rows_written,
            "latent": torch.from_numpy(self.latent[:filled].copy()),
            "action": torch.from_numpy(self.action[:filled].copy()),
            "reward": torch.from_numpy(self.reward[:filled].copy()),
            "next_latent": torch.from_numpy(self.next_latent[:filled].copy()),
            "done": torch.from_numpy(self.done[:filled].copy()),
        }

    def load_state_dict(self, state: dict) -> None:
        if int(state["capacity"]) != self.capacity:
            raise ValueError("latent replay capacity differs from the saved buffer")
        self.rows_written = int(state["rows_written"])
        filled = len(self)
        self.latent[:filled] = state["latent"].numpy()
        self.action[:filled] = state["action"].numpy()
        self.reward[:filled] = state["reward"].numpy()
        self.next_latent[:filled] = state["next_latent"].numpy()
        self.done[:filled] = state["done"].numpy()


def _as_numpy(value: np.ndarray | torch.Tensor) -> np.ndarray:
    if isinstance(value, torch.Tensor):
        return value.detach().cpu().numpy()
    return np.asarray(value)
