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

The per-step update (:meth:`Neuromodulators.step`) runs in NumPy without autograd (a single
observation through four 64-unit networks costs microseconds in NumPy and ten times more as
torch ops): each stage is ``relu(x A) B`` with ``x = [phi(s), 1, e_1, e_2]`` and per-stage
copies ``A``, ``B`` of the weights (biases and extra-input weights as rows of ``A``), rebuilt
whenever the parameters change, so one step is four vector-matrix products and two ``relu``.
With the compiled extension (:mod:`evodevo.neuromod.kernels`, :meth:`Neuromodulators.use_kernel`)
the same step on the same matrices is one C++ call (``csrc/module_step.cpp``).
In ``learned`` mode :meth:`Neuromodulators.batch_targets` computes the same networks on a
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
from collections.abc import Callable, Sequence

import numpy as np
import torch
from torch import nn

from evodevo.neuromod.config import MODULE_NAMES, ModuleConfig
from evodevo.seeding import torch_gen

__all__ = ["Neuromodulators", "LAYOUT", "ema_update", "logistic", "novelty_decay"]

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


def logistic(x: float) -> float:
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
        # One float32 buffer holds the per-step update's input row, the states, taus, output
        # biases and stage matrices (see :meth:`_views`); the C++ step takes it as one argument
        # (csrc/module_step.h). The state tensor (internal layout) and its NumPy view are
        # slices of it.
        d, h = obs_dim, cfg.hidden
        n_in, width = d + 3, 2 * h
        self._pack_dims = (n_in, width)
        pack = np.zeros(n_in + 12 + 2 * n_in * width + 4 * width, dtype=np.float32)
        self._pack_t = torch.from_numpy(pack)
        self._x = pack[:n_in]
        self._x[d] = 1.0
        self._s = pack[n_in : n_in + 4]
        pack[n_in + 4 : n_in + 8] = self._tau_eff
        self._b2np = pack[n_in + 8 : n_in + 12]
        off = n_in + 12
        self._amat = pack[off : off + 2 * n_in * width].reshape(2, n_in, width)
        off += 2 * n_in * width
        self._bmat = pack[off:].reshape(2, width, 2)
        self._s[:] = float(cfg.initial_state)
        self._s[~active] = float(cfg.ablated_value)
        self.state_t = self._pack_t[n_in : n_in + 4]
        self.n_task = 1.0
        self._kernel: object | None = None
        self._views()
        self._ablated_mask_t = torch.from_numpy(~active)

    def use_kernel(self, module: object | None) -> None:
        """Run :meth:`step` through the compiled ``module_step`` of ``module`` (the extension
        :func:`evodevo.neuromod.kernels.load` returns), or through NumPy when None."""
        self._kernel = module

    def _views(self) -> None:
        """Per-stage matrices of the per-step update, rebuilt from the parameters.

        Stage ``g`` (0: DA, NE; 1: 5HT, ACh) is ``logits = relu(x_g A_g) B_g + b2_g`` with
        ``x_g = [phi(s), 1, e_first, e_second]``: ``A_g`` (d+3, 2h) stacks the two modules'
        observation weights, their first-layer biases and their extra-input weights (each in
        its own row, zero under the other module), ``B_g`` (2h, 2) is block-diagonal with the
        two output weight vectors. The same numbers as the parameters, laid out so that a
        stage is two vector-matrix products. Copies (into slices of the one buffer the C++
        step reads), not views of the parameters: :meth:`step` rebuilds them
        when a parameter's version counter moved (``load_state_dict``, in-place edits), and
        :meth:`refresh` after an optimiser step (fused Adam does not count versions).
        """
        d, h = self.obs_dim, self.hidden
        w1 = self.w1.detach().numpy()
        b1 = self.b1.detach().numpy()
        w2 = self.w2.detach().numpy()
        a, b = self._amat, self._bmat  # written in place: slices of the one buffer
        a.fill(0.0)
        b.fill(0.0)
        for g in range(2):
            cols = slice(2 * g * h, 2 * (g + 1) * h)
            a[g, :d] = w1[:d, cols]
            a[g, d] = b1[cols]
            for j in range(2):
                m = 2 * g + j
                a[g, d + 1 + j, j * h : (j + 1) * h] = w1[d, m * h : (m + 1) * h]
                b[g, j * h : (j + 1) * h, j] = w2[m]
        self._a = (a[0], a[1])
        self._bo = (b[0], b[1])
        self._b2np[:] = self.b2.detach().numpy()
        self._b2py = [float(x) for x in self._b2np]
        self._z = np.empty(2 * h, dtype=np.float32)
        self._versions = self._param_versions()

    def _param_versions(self) -> tuple[int, ...]:
        # the hot loop uses step_function's closure; this is the general path
        return (self.w1._version, self.b1._version, self.w2._version, self.b2._version)

    def refresh(self) -> None:
        """Rebuild the per-step matrices (after an optimiser step on the module networks)."""
        self._views()

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
        if self._versions != self._param_versions():
            self._views()
        if self._kernel is not None:
            self._x[: self.obs_dim] = obs
            n_in, width = self._pack_dims
            self._kernel.module_step(  # type: ignore[attr-defined]
                self._pack_t, n_in, width, reward, self.n_task
            )
            self.n_task *= self.cfg.novelty_decay
            return
        s = self._s
        tau = self._tau_py
        b2 = self._b2py
        x, z, a, bo = self._x, self._z, self._a, self._bo
        d = self.obs_dim
        x[:d] = obs
        # stage 1: DA (extra input r), NE (extra input n_task)
        x[d + 1] = reward
        x[d + 2] = self.n_task
        np.dot(x, a[0], out=z)
        np.maximum(z, 0.0, out=z)
        l_da, l_ne = np.dot(z, bo[0]).tolist()
        s_da, s_ne, s_5ht, s_ach = s.tolist()
        s_da += tau[0] * (logistic(l_da + b2[0]) - s_da)
        s_ne += tau[1] * (logistic(l_ne + b2[1]) - s_ne)
        s[0] = s_da
        s[1] = s_ne
        # stage 2: 5HT (extra input s_DA just updated), ACh (extra input s_NE just updated)
        x[d + 1] = s[0]
        x[d + 2] = s[1]
        np.dot(x, a[1], out=z)
        np.maximum(z, 0.0, out=z)
        l_5ht, l_ach = np.dot(z, bo[1]).tolist()
        s[2] = s_5ht + tau[2] * (logistic(l_5ht + b2[2]) - s_5ht)
        s[3] = s_ach + tau[3] * (logistic(l_ach + b2[3]) - s_ach)
        self.n_task *= self.cfg.novelty_decay

    def step_function(
        self, row: np.ndarray, row_t: torch.Tensor
    ) -> Callable[[np.ndarray, float], None]:
        """:meth:`step` as a closure for the per-step loop of the trainer.

        With the C++ kernel, a call with ``row`` (the agent's observation row, whose memory
        ``row_t`` shares) is one C++ call that reads the observation from ``row_t``, with the
        parameter-version check of :meth:`step` on local references; any other call, or a
        changed parameter, goes through :meth:`step`. Without the kernel it is :meth:`step`.
        """
        kernel = self._kernel
        if kernel is None:
            return self.step
        call = kernel.module_step_obs  # type: ignore[attr-defined]
        pack = self._pack_t
        n_in, width = self._pack_dims
        decay = self.cfg.novelty_decay
        w1, b1, w2, b2 = self.w1, self.b1, self.w2, self.b2
        step = self.step

        def fast(obs: np.ndarray, reward: float) -> None:
            if obs is not row or self._versions != (
                w1._version, b1._version, w2._version, b2._version
            ):  # fmt: skip
                step(obs, reward)
                return
            call(pack, row_t, n_in, width, reward, self.n_task)
            self.n_task *= decay

        return fast

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
    def uses_kernel(self) -> bool:
        """True when :meth:`step` runs through the compiled ``module_step``."""
        return self._kernel is not None

    @property
    def state_array(self) -> np.ndarray:
        """The live float32 array of the four states in the internal layout (DA, NE, 5HT, ACh:
        the dependency order of Eq. 3.2-3.6), which the fused kernels read; use :attr:`states`
        for the MODULE_NAMES order."""
        return self._s

    @property
    def taus_internal(self) -> list[float]:
        """The EMA rates of Eq. 3.1 in the internal layout (an ablated module's is 0)."""
        return list(self._tau_py)

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
