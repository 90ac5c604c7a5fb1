"""The four neuromodulator modules (Eq. 3.1-3.6, SPEC §1.3 and §1.5).

Each module m has a target network ``sigmoid(W2_m relu(W1_m [phi(s), e_m] + b1_m) + b2_m)``
(hidden 64) whose extra input ``e_m`` is the reward (DA), the DA state (5HT), the task
novelty (NE) or the NE state (ACh). The four networks are stored stacked, so that

* the observation part of the first layer of all four is ONE matrix product, and
* the dependency order of SPEC §1.3 costs one extra tiny stage: stage 1 computes DA and NE
  (their extra inputs are known), updates their states (Eq. 3.1), and stage 2 computes 5HT
  and ACh from the states *just updated*.

Internally the modules are laid out as ``(DA, NE, 5HT, ACh)`` so that each stage is a
contiguous slice; every public array (``states``, CSV columns, Eq. 3.7 weights) uses the
order of :data:`~evodevo.neuromod.config.MODULE_NAMES` ``(DA, 5HT, NE, ACh)``.

The per-step update (:meth:`Neuromodulators.step`) runs in NumPy on views that share memory
with the torch parameters and state tensor, without autograd (a single observation through
four 64-unit networks costs microseconds in NumPy and ten times more as torch ops). In
``learned`` mode :meth:`Neuromodulators.batch_targets` computes the same networks on a
mini-batch with autograd, so that the TD loss trains them through the context gate (Eq. 3.8).

An ablated module (SPEC §1.5) keeps its state at ``ablated_value`` (0.5): its network is not
used and modules that read it get 0.5.

>>> import numpy as np
>>> from evodevo.neuromod.config import ModuleConfig
>>> mods = Neuromodulators(ModuleConfig(), obs_dim=4, seed=0)
>>> mods.step(np.zeros(4, dtype=np.float32), reward=1.0)
>>> bool(((mods.states >= 0) & (mods.states <= 1)).all())
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from evodevo.neuromod.config import MODULE_NAMES, ModuleConfig
from evodevo.seeding import torch_gen

__all__ = ["Neuromodulators", "LAYOUT", "ema_update", "novelty_decay"]

#: Internal order of the stacked networks: stage 1 (DA, NE), stage 2 (5HT, ACh).
LAYOUT: tuple[str, ...] = ("DA", "NE", "5HT", "ACh")
#: ``public[i] = internal[_TO_INTERNAL[i]]`` for the MODULE_NAMES order.
_TO_INTERNAL = np.array([LAYOUT.index(m) for m in MODULE_NAMES])


def ema_update(state: float, target: float, tau: float) -> float:
    """Eq. 3.1: ``s + tau (target - s)`` (reference form of the vectorised update)."""
    return state + tau * (target - state)


def novelty_decay(n_task: float, decay: float) -> float:
    """Eq. 3.5: ``n_task * decay`` after one environment step."""
    return n_task * decay


def _sig(x: float) -> float:
    """Scalar logistic function (Python floats are far cheaper than 1-element arrays)."""
    return 1.0 / (1.0 + math.exp(-max(-60.0, min(60.0, x))))


class Neuromodulators(nn.Module):
    """Stacked target networks plus the scalar states and task novelty.

    Args:
        cfg: module settings (taus, hidden size, learning mode).
        obs_dim: ``d_max``, the size of ``phi(s)``.
        seed: run seed; the networks are Xavier-initialised from ``derive(seed, 4)``.
        ablated: names of ablated modules (held at ``cfg.ablated_value``).
    """

    def __init__(
        self, cfg: ModuleConfig, obs_dim: int, seed: int, ablated: Sequence[str] = ()
    ) -> None:
        super().__init__()
        unknown = [m for m in ablated if m not in MODULE_NAMES]
        if unknown:
            raise ValueError(f"unknown module {unknown[0]!r}; modules are {MODULE_NAMES}")
        self.cfg = cfg
        self.obs_dim = obs_dim
        self.hidden = h = cfg.hidden
        gen = torch_gen(seed, 4)
        w1 = torch.empty(4, obs_dim + 1, h)
        w2 = torch.empty(4, h, 1)
        for m in range(4):
            nn.init.xavier_uniform_(w1[m], generator=gen)
            nn.init.xavier_uniform_(w2[m], generator=gen)
        # (d+1, 4h): column block m belongs to module LAYOUT[m]; last row weighs the extra input.
        self.w1 = nn.Parameter(w1.permute(1, 0, 2).reshape(obs_dim + 1, 4 * h).contiguous())
        self.b1 = nn.Parameter(torch.zeros(4 * h))
        self.w2 = nn.Parameter(w2[..., 0].contiguous())  # (4, h)
        self.b2 = nn.Parameter(torch.zeros(4))
        if cfg.learning == "fixed":
            for p in self.parameters():
                p.requires_grad_(False)
        self.ablated = tuple(ablated)
        active = np.array([m not in self.ablated for m in LAYOUT])
        self._active = active
        self._tau = np.array([dict(zip(MODULE_NAMES, cfg.taus, strict=True))[m] for m in LAYOUT])
        self._tau_eff = (self._tau * active).astype(np.float32)
        self._tau_py = [float(x) for x in self._tau_eff]
        self._ext = np.zeros((2, 1), dtype=np.float32)
        # State tensor (internal layout) and a NumPy view sharing its memory.
        self.state_t = torch.full((4,), float(cfg.initial_state))
        self.state_t[torch.from_numpy(~active)] = float(cfg.ablated_value)
        self._s = self.state_t.numpy()
        self.n_task = 1.0
        self._views()
        self._ablated_mask_t = torch.from_numpy(~active)

    def _views(self) -> None:
        """NumPy views of the parameters (shared memory: optimiser steps are seen at once)."""
        d, h = self.obs_dim, self.hidden
        self._w1o = self.w1.detach().numpy()[:d]
        self._wex = self.w1.detach().numpy()[d].reshape(4, h)
        self._b1 = self.b1.detach().numpy()
        self._w2 = self.w2.detach().numpy()
        self._b2 = self.b2.detach().numpy()

    # ----------------------------------------------------------------- per-step update
    def start_task(self) -> None:
        """Algorithm 1 line 5: ``n_task = 1.0`` at the start of each task (states are kept)."""
        self.n_task = 1.0

    def step(self, obs: np.ndarray, reward: float) -> None:
        """One environment step: Eq. 3.2-3.6 targets, Eq. 3.1 update, then Eq. 3.5 decay.

        ``obs`` is ``phi(s_current)`` (float32, length ``d_max``), ``reward`` the reward
        received for the action taken in it. 5HT reads the DA state updated in this call,
        ACh the NE state updated in this call.
        """
        s = self._s
        tau = self._tau_py
        ext = self._ext
        pre = np.dot(obs, self._w1o)
        pre += self._b1
        p = pre.reshape(4, self.hidden)
        # stage 1: DA (extra input r), NE (extra input n_task)
        ext[0, 0] = reward
        ext[1, 0] = self.n_task
        z = p[:2] + ext * self._wex[:2]
        np.maximum(z, 0.0, out=z)
        l_da, l_ne = ((z * self._w2[:2]).sum(1) + self._b2[:2]).tolist()
        s_da = float(s[0])
        s_ne = float(s[1])
        s_da += tau[0] * (_sig(l_da) - s_da)
        s_ne += tau[1] * (_sig(l_ne) - s_ne)
        s[0] = s_da
        s[1] = s_ne
        # stage 2: 5HT (extra input s_DA just updated), ACh (extra input s_NE just updated)
        ext[0, 0] = s[0]
        ext[1, 0] = s[1]
        z = p[2:] + ext * self._wex[2:]
        np.maximum(z, 0.0, out=z)
        l_5ht, l_ach = ((z * self._w2[2:]).sum(1) + self._b2[2:]).tolist()
        s_5ht = float(s[2])
        s_ach = float(s[3])
        s[2] = s_5ht + tau[2] * (_sig(l_5ht) - s_5ht)
        s[3] = s_ach + tau[3] * (_sig(l_ach) - s_ach)
        self.n_task *= self.cfg.novelty_decay

    # ----------------------------------------------------------------- learned mode
    def batch_targets(
        self, obs: torch.Tensor, reward: torch.Tensor, n_task: torch.Tensor
    ) -> torch.Tensor:
        """Target outputs on a mini-batch with autograd, internal layout, shape (B, 4).

        5HT reads DA's output and ACh reads NE's output on the same sample (the batch
        analogue of the per-step dependency order); ablated modules output 0.5.
        """
        d, h = self.obs_dim, self.hidden
        b = obs.shape[0]
        pre = torch.addmm(self.b1, obs, self.w1[:d]).view(b, 4, h)
        wex = self.w1[d].view(4, h)
        extra1 = torch.stack((reward, n_task), dim=1).unsqueeze(2)  # (B, 2, 1)
        z1 = torch.relu(pre[:, :2] + extra1 * wex[:2])
        t1 = torch.sigmoid((z1 * self.w2[:2]).sum(2) + self.b2[:2])
        mask = self._ablated_mask_t
        abl = float(self.cfg.ablated_value)
        if bool(mask[:2].any()):
            t1 = torch.where(mask[:2], torch.full_like(t1, abl), t1)
        z2 = torch.relu(pre[:, 2:] + t1.unsqueeze(2) * wex[2:])
        t2 = torch.sigmoid((z2 * self.w2[2:]).sum(2) + self.b2[2:])
        if bool(mask[2:].any()):
            t2 = torch.where(mask[2:], torch.full_like(t2, abl), t2)
        return torch.cat((t1, t2), dim=1)

    # ----------------------------------------------------------------- public views
    @property
    def states(self) -> np.ndarray:
        """Copy of the four states in MODULE_NAMES order (DA, 5HT, NE, ACh)."""
        return self._s[_TO_INTERNAL].copy()

    def set_states(self, public_states: Sequence[float]) -> None:
        """Set the states from a MODULE_NAMES-ordered sequence (used by resume and tests)."""
        self._s[_TO_INTERNAL] = np.asarray(public_states, dtype=np.float32)

    def to_internal(self, public: Sequence[float]) -> np.ndarray:
        """Reorder a MODULE_NAMES-ordered 4-vector into the internal layout."""
        out = np.empty(4, dtype=np.float32)
        out[_TO_INTERNAL] = np.asarray(public, dtype=np.float32)
        return out

    def extra_state(self) -> dict[str, object]:
        """What a checkpoint needs besides the parameters."""
        return {"states": self.states.tolist(), "n_task": self.n_task}

    def load_extra_state(self, data: dict[str, object]) -> None:
        self.set_states(data["states"])  # type: ignore[arg-type]
        self.n_task = float(data["n_task"])  # type: ignore[arg-type]
        self._views()
