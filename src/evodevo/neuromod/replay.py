"""Replay buffer: preallocated NumPy storage, one fresh buffer per task (SPEC §1.6).

One float32 matrix holds ``[obs, next_obs, action, reward, terminated, n_task]`` per row, so
sampling a mini-batch is one fancy index and a ``torch.from_numpy`` view per column.

>>> import numpy as np
>>> buf = ReplayBuffer(10, obs_dim=2)
>>> buf.add(np.ones(2, np.float32), 1, 0.5, np.zeros(2, np.float32), False, 1.0)
>>> len(buf)
1
"""

from __future__ import annotations

import numpy as np
import torch

__all__ = ["ReplayBuffer", "Batch"]

Batch = tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]


class ReplayBuffer:
    """Ring buffer of ``capacity`` transitions of ``obs_dim``-sized (padded) observations."""

    def __init__(self, capacity: int, obs_dim: int) -> None:
        self.capacity = int(capacity)
        self.obs_dim = d = int(obs_dim)
        self.data = np.zeros((self.capacity, 2 * d + 4), dtype=np.float32)
        self._cols = (slice(0, d), slice(d, 2 * d), 2 * d, 2 * d + 1, 2 * d + 2, 2 * d + 3)
        self.pos = 0
        self.size = 0

    def __len__(self) -> int:
        return self.size

    def add(
        self,
        obs: np.ndarray,
        action: int,
        reward: float,
        next_obs: np.ndarray,
        terminated: bool,
        n_task: float,
    ) -> None:
        """Store one transition (``terminated`` only: truncation still bootstraps)."""
        d = self.obs_dim
        row = self.data[self.pos]
        row[:d] = obs
        row[d : 2 * d] = next_obs
        row[2 * d] = action
        row[2 * d + 1] = reward
        row[2 * d + 2] = terminated
        row[2 * d + 3] = n_task
        self.pos = (self.pos + 1) % self.capacity
        if self.size < self.capacity:
            self.size += 1

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        """``(obs, next_obs, action, reward, terminated, n_task)`` of a uniform mini-batch.

        The columns are sliced as NumPy views and wrapped by ``torch.from_numpy`` (views of
        one gathered matrix, the same strides as slicing a tensor): about 10 µs per step less
        than six tensor slices, on every training step of every variant.
        """
        idx = rng.integers(0, self.size, size=batch_size)
        rows = self.data[idx]
        d = self.obs_dim
        wrap = torch.from_numpy
        return (
            wrap(rows[:, :d]),
            wrap(rows[:, d : 2 * d]),
            wrap(rows[:, 2 * d].astype(np.int64)),
            wrap(rows[:, 2 * d + 1]),
            wrap(rows[:, 2 * d + 2]),
            wrap(rows[:, 2 * d + 3]),
        )
