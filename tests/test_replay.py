"""The replay buffer (SPEC §1.6): what a sampled mini-batch holds."""

from __future__ import annotations

import numpy as np
import torch

from evodevo.neuromod.replay import ReplayBuffer


def _filled(n: int, capacity: int, d: int = 3) -> ReplayBuffer:
    buf = ReplayBuffer(capacity, d)
    for i in range(n):
        obs = np.arange(d, dtype=np.float32) + i
        buf.add(obs, i % 4, 0.5 * i, -obs, i % 5 == 0, 0.99**i)
    return buf


def test_a_sampled_batch_is_the_stored_transitions_at_the_drawn_indices():
    buf = _filled(30, 50)
    obs, nobs, act, rew, term, n_task = buf.sample(np.random.default_rng(3), 16)
    idx = np.random.default_rng(3).integers(0, 30, size=16)  # the same draw
    assert obs.dtype == nobs.dtype == rew.dtype == term.dtype == n_task.dtype == torch.float32
    assert act.dtype == torch.int64 and obs.shape == (16, 3) and act.shape == (16,)
    assert torch.equal(obs[:, 0], torch.from_numpy(idx.astype(np.float32)))
    assert torch.equal(nobs, -obs)
    assert torch.equal(act, torch.from_numpy(idx % 4))
    assert torch.equal(rew, torch.from_numpy((0.5 * idx).astype(np.float32)))
    assert torch.equal(term, torch.from_numpy((idx % 5 == 0).astype(np.float32)))
    assert torch.allclose(n_task, torch.from_numpy((0.99**idx).astype(np.float32)))


def test_the_ring_overwrites_the_oldest_transition_and_samples_only_stored_rows():
    buf = _filled(12, 10)
    assert len(buf) == 10 and buf.pos == 2
    obs = buf.sample(np.random.default_rng(0), 500)[0][:, 0]
    assert set(obs.tolist()) == set(range(2, 12))  # transitions 0 and 1 were overwritten


def test_a_batch_is_a_copy_not_a_view_of_the_buffer():
    buf = _filled(5, 5)
    obs = buf.sample(np.random.default_rng(1), 4)[0]
    before = obs.clone()
    buf.data[:] = 0.0
    assert torch.equal(obs, before)
