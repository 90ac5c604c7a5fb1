"""Progressive columns with plain (PNN) or neuromodulated gated (BIARM) laterals (SPEC §1.2).

Column i: ``h1 = relu(W1 phi(x))``, ``h2 = relu(W2 h1 + lat2)``, ``q = Wq h2 + latq``, where
``lat2`` reads the earlier columns' ``h1`` and ``latq`` their ``h2`` (Rusu et al. 2016, layer
l-1 into layer l; SPEC §1.2). Lateral terms of earlier columns k < i:

* PNN: ``sum_k U_k h_k`` -- ONE matrix product of the concatenated ``[h_1 ... h_{i-1}]``.
* BIARM (Eq. 3.8, 3.9): ``sum_k U_k (alpha_k * V_k h_k)`` with
  ``alpha_k = sigmoid(W_alpha,k h_k) * sigmoid(sum_m w_m s_m)``. ``V_k`` and ``W_alpha,k``
  (d -> r each, r = ``adapter_dim``) are stored as one stacked tensor, so all earlier columns'
  adapters are one batched product (``baddbmm`` over k), ``V h * sigmoid(W_alpha h)`` one
  ``glu``, and all ``U_k`` one matrix product of the concatenated gated adapters. The context
  gate is a scalar (or one per sample), so it scales the summed lateral; where no gradient
  is needed (target network, frozen columns, acting) it is a Python float, the ``alpha`` of
  that product.

Frozen columns (SPEC §1.2) have ``requires_grad=False`` and are never given to an optimiser;
their first layers and their layer-2 adapters are fused into cached tensors (all frozen
columns' adapters one batched product), and only their hidden activations are computed during
training (their heads are not needed by later columns).

>>> import torch
>>> net = ProgressiveNet(obs_dim=4, hidden=8, gated=True, adapter_dim=2, seed=0)
>>> _ = net.add_column(2); _ = net.add_column(3)
>>> net.q(torch.zeros(5, 4), 1, torch.full((4,), 0.5)).shape
torch.Size([5, 3])
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from scipy.special import expit
from torch import nn

from evodevo.neuromod.gated_laterals import Prev, context_value, gated_laterals
from evodevo.neuromod.kernels import NO_TENSOR
from evodevo.neuromod.kernels import load as load_kernel
from evodevo.neuromod.kernels import resolve as resolve_kernel
from evodevo.seeding import torch_gen

__all__ = ["Column", "ProgressiveNet", "context_value", "gated_laterals", "xavier"]


def xavier(shape: tuple[int, ...], fan: tuple[int, int], gen: torch.Generator) -> nn.Parameter:
    """Xavier-uniform tensor of ``shape`` with explicit (fan_in, fan_out)."""
    bound = (6.0 / (fan[0] + fan[1])) ** 0.5
    t = torch.empty(shape).uniform_(-bound, bound, generator=gen)
    return nn.Parameter(t)


def _fused() -> Any:
    """The compiled C++ extension (only called once :func:`resolve_kernel` returned "cpp")."""
    mod = load_kernel()
    assert mod is not None
    return mod


class Column(nn.Module):
    """One task column with its lateral adapters from ``n_prev`` earlier columns.

    Args:
        n_prev: number of earlier columns k (0 for the first task).
        obs_dim: ``d_max``.
        hidden: width of both hidden layers.
        n_actions: Q-head outputs.
        gated: BIARM laterals (else PNN laterals).
        adapter_dim: r of V and W_alpha.
        context_weights: initial w_m of Eq. 3.8, in the modules' internal layout.
        learn_context: train w_m with the column.
        gen: generator for the Xavier initialisation.
        kernel: ``"cpp"`` (fused C++ laterals) or ``"torch"`` (:mod:`evodevo.neuromod.kernels`).
        lateral_init: ``xavier`` or ``zero`` initial ``U`` (``network.lateral_init``).
        lateral_scale: the fixed factor ``s`` on the earlier columns' activations this column's
            laterals read (``network.lateral_scale``): the column computes ``U (s h_k)``
            (PNN) or ``U (alpha * V (s h_k))`` (BIARM). :meth:`ProgressiveNet.lateral_inputs`
            applies it, so :meth:`forward` and the C++ kernels take the scaled inputs.
    """

    def __init__(
        self,
        n_prev: int,
        obs_dim: int,
        hidden: int,
        n_actions: int,
        gated: bool,
        adapter_dim: int,
        context_weights: Sequence[float],
        learn_context: bool,
        gen: torch.Generator,
        kernel: str = "torch",
        lateral_init: str = "xavier",
        lateral_scale: float = 1.0,
    ) -> None:
        super().__init__()
        self.lateral_scale = float(lateral_scale)
        self.n_prev = k = n_prev
        self.hidden = h = hidden
        self.n_actions = a = n_actions
        self.gated = gated
        self.r = r = adapter_dim
        self.kernel = kernel
        self.w1 = xavier((obs_dim, h), (obs_dim, h), gen)
        self.b1 = nn.Parameter(torch.zeros(h))
        self.w2 = xavier((h, h), (h, h), gen)
        self.b2 = nn.Parameter(torch.zeros(h))
        self.wq = xavier((h, a), (h, a), gen)
        self.bq = nn.Parameter(torch.zeros(a))
        if k > 0:
            if gated:
                # [V | W_alpha] of every earlier column, stacked: blocks 0..k-1 read the earlier
                # h1 (lateral into layer 2), blocks k..2k-1 the earlier h2 (into the head).
                v = xavier((2 * k, h, r), (h, r), gen)
                wa = xavier((2 * k, h, r), (h, r), gen)
                self.ad_w = nn.Parameter(torch.cat([v.data, wa.data], 2))
                self.ad_b = nn.Parameter(torch.zeros(2 * k, 1, 2 * r))
                self.u2 = xavier((k * r, h), (k * r, h), gen)
                self.uq = xavier((k * r, a), (k * r, a), gen)
                self.ctx_w = nn.Parameter(
                    torch.tensor(list(context_weights), dtype=torch.float32),
                    requires_grad=learn_context,
                )
            else:
                self.u2 = xavier((k * h, h), (k * h, h), gen)
                self.uq = xavier((k * h, a), (k * h, a), gen)
            if lateral_init == "zero":
                # drawn and then zeroed, so every other parameter is the same as under xavier:
                # the new column starts as an isolated one (its Q-values near 0, not the earlier
                # columns' features through random maps) and U learns from h_k != 0
                with torch.no_grad():
                    self.u2.zero_()
                    self.uq.zero_()

    # ---------------------------------------------------------------- laterals
    def context(self, states: torch.Tensor) -> torch.Tensor:
        """Context gate ``sigmoid(sum_m w_m s_m)``; states (4,) -> scalar, (B, 4) -> (B, 1)."""
        if states.dim() == 1:
            return torch.sigmoid(torch.dot(states, self.ctx_w))
        return torch.sigmoid(states @ self.ctx_w).unsqueeze(1)

    def context_value(self, states: Sequence[float]) -> float:
        """:meth:`context` of scalar states as a Python float (no autograd)."""
        return context_value(self.ctx_w.tolist(), states)

    def rows(self, prev: Prev, start: int, stop: int) -> Prev:
        """Rows ``start:stop`` (samples) of a :meth:`ProgressiveNet.features` result."""
        if self.gated:
            return (prev[0][:, start:stop],)
        return prev[0][start:stop], prev[1][start:stop]

    # ---------------------------------------------------------------- forward
    def forward(
        self,
        x: torch.Tensor,
        prev: Prev | None = None,
        states: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Q-values (B, n_actions) of this column.

        ``prev`` holds the earlier columns' activations as :meth:`ProgressiveNet.features`
        returns them (rows of this batch); ``states`` (BIARM) are the four module states the
        context gate reads: (4,) for one gate, or (B, 4) for one per sample (learned mode).
        With ``kernel == "cpp"`` the gate and both laterals are one fused C++ operation
        (:mod:`evodevo.neuromod.kernels`), else the PyTorch operations of
        :func:`gated_laterals` (a float gate where no gradient is needed).
        """
        h1 = torch.relu(torch.addmm(self.b1, x, self.w1))
        if not self.n_prev:
            return torch.addmm(self.bq, torch.relu(torch.addmm(self.b2, h1, self.w2)), self.wq)
        assert prev is not None
        if self.gated:
            assert states is not None
            if self.kernel == "cpp":
                t2, tq = _fused().gated_lateral(
                    prev[0], self.ad_w, self.ad_b, states, self.ctx_w,
                    self.u2, self.b2, self.uq, self.bq,
                )  # fmt: skip
            else:
                gate: torch.Tensor | float
                if states.dim() == 1 and not torch.is_grad_enabled():
                    gate = self.context_value(states.tolist())
                else:
                    gate = self.context(states)
                # both laterals' adapters (from h1 and from h2 of the earlier columns) in one op
                t2, tq = gated_laterals(
                    prev[0], self.ad_w, self.ad_b, gate, ((self.u2, self.b2), (self.uq, self.bq))
                )
        else:  # PNN: U h of all earlier columns, one product per layer, bias folded in
            t2 = torch.addmm(self.b2, prev[0], self.u2)
            tq = torch.addmm(self.bq, prev[1], self.uq)
        h2 = torch.relu(torch.addmm(t2, h1, self.w2))
        return torch.addmm(tq, h2, self.wq)


class ProgressiveNet(nn.Module):
    """The column stack: frozen columns 0..i-1 and the trainable column i.

    Args:
        obs_dim: ``d_max``.
        hidden: column width.
        gated: BIARM (True) or PNN (False) laterals.
        adapter_dim: r.
        seed: run seed; column i is initialised from ``derive(seed, 3, i)``.
        context_weights: initial Eq. 3.8 weights in the modules' internal layout.
        learn_context: train the Eq. 3.8 weights.
        lateral_kernel: ``network.lateral_kernel`` (``auto``, ``cpp``, ``torch``), resolved by
            :func:`evodevo.neuromod.kernels.resolve`; :attr:`kernel` is the result. ``cpp``
            computes the frozen columns' activations in one C++ call for PNN and BIARM alike
            (bit for bit the PyTorch numbers), and BIARM's gated laterals in the fused kernel
            (PNN's laterals are one matrix product per layer already).
        lateral_init: ``network.lateral_init`` of every new column.
        lateral_scale: ``network.lateral_scale`` of every new column (a column keeps the one
            it was built with: :meth:`add_column` may override it, checkpoints store it).
    """

    def __init__(
        self,
        obs_dim: int,
        hidden: int,
        gated: bool,
        adapter_dim: int,
        seed: int,
        context_weights: Sequence[float] = (0.3, 0.3, 0.2, 0.2),
        learn_context: bool = True,
        lateral_kernel: str = "auto",
        lateral_init: str = "xavier",
        lateral_scale: float = 1.0,
    ) -> None:
        super().__init__()
        self.lateral_init = lateral_init
        self.lateral_scale = lateral_scale
        self.lateral_kernel = lateral_kernel
        self.kernel = resolve_kernel(lateral_kernel)
        self.obs_dim = obs_dim
        self.hidden = hidden
        self.gated = gated
        self.adapter_dim = adapter_dim
        self.seed = seed
        self.context_weights = list(context_weights)
        self.learn_context = learn_context
        self.columns = nn.ModuleList()
        self._w1_frozen = torch.empty(obs_dim, 0)
        self._b1_frozen = torch.empty(0)
        # BIARM: frozen columns' context weights (Python lists; None for column 0) and the
        # layer-2 adapters of all frozen columns j >= 1 stacked block (j, k) for k < j, in the
        # order (1,0), (2,0), (2,1), (3,0) ..., so the first upto*(upto-1)/2 blocks are those of
        # columns < upto; ``_blk_src`` names the frozen h1_k each block reads.
        self._ctxw_frozen: list[list[float] | None] = []
        self._ctxw_frozen_t = torch.empty(0, 4)  # the same, (columns, 4), zeros for column 0
        self._adw_frozen = torch.empty(0)
        self._adb_frozen = torch.empty(0)
        self._blk_src = torch.empty(0, dtype=torch.long)
        # per frozen column (W2, b2, U2) for the C++ features (U2 empty for column 0)
        self._frozen_w2: list[torch.Tensor] = []
        self._frozen_b2: list[torch.Tensor] = []
        self._frozen_u2: list[torch.Tensor] = []
        self._np: dict[int, dict[str, np.ndarray]] = {}  # NumPy views for :meth:`q_np`

    @property
    def n_columns(self) -> int:
        return len(self.columns)

    @property
    def current(self) -> Column:
        return self.columns[-1]  # type: ignore[return-value]

    def add_column(self, n_actions: int, lateral_scale: float | None = None) -> Column:
        """Freeze every existing column and append a new trainable one (its laterals read the
        earlier activations times ``lateral_scale``, default the net's)."""
        for col in self.columns:
            for p in col.parameters():
                p.requires_grad_(False)
        self.refresh_frozen()
        col = Column(
            n_prev=self.n_columns,
            obs_dim=self.obs_dim,
            hidden=self.hidden,
            n_actions=n_actions,
            gated=self.gated,
            adapter_dim=self.adapter_dim,
            context_weights=self.context_weights,
            learn_context=self.learn_context,
            gen=torch_gen(self.seed, 3, self.n_columns),
            kernel=self.kernel,
            lateral_init=self.lateral_init,
            lateral_scale=self.lateral_scale if lateral_scale is None else lateral_scale,
        )
        self.columns.append(col)
        return col

    def refresh_frozen(self) -> None:
        """Cache the fused first layers, adapters and context weights of the frozen columns."""
        self._np = {}
        cols = [c for c in self.columns if isinstance(c, Column)]
        if not cols:
            return
        self._w1_frozen = torch.cat([c.w1.detach() for c in cols], 1)
        self._b1_frozen = torch.cat([c.b1.detach() for c in cols])
        self._frozen_w2 = [c.w2.detach() for c in cols]
        self._frozen_b2 = [c.b2.detach() for c in cols]
        # a frozen column's lateral scale is folded into its lateral weights (U (s h) = (s U) h
        # for PNN; (s h) V = h (s V) for BIARM's adapters, biases unscaled), so the frozen
        # activations below (PyTorch, NumPy and C++ alike) read the raw earlier activations
        self._frozen_u2 = [
            (
                c.u2.detach() * c.lateral_scale
                if c.lateral_scale != 1.0 and not self.gated
                else c.u2.detach()
            )
            if c.n_prev
            else torch.empty(0)
            for c in cols
        ]
        if self.gated:
            self._ctxw_frozen = [c.ctx_w.detach().tolist() if c.n_prev else None for c in cols]
            self._ctxw_frozen_t = torch.tensor([w or [0.0] * 4 for w in self._ctxw_frozen])
            lat = [c for c in cols if c.n_prev]
            if lat:
                self._adw_frozen = torch.cat(
                    [
                        c.ad_w.detach()[: c.n_prev] * c.lateral_scale
                        if c.lateral_scale != 1.0
                        else c.ad_w.detach()[: c.n_prev]
                        for c in lat
                    ]
                )
                self._adb_frozen = torch.cat([c.ad_b.detach()[: c.n_prev] for c in lat])
                self._blk_src = torch.tensor([k for c in lat for k in range(c.n_prev)])

    def frozen_context(self, states: Sequence[float], upto: int) -> list[float]:
        """Context gates of columns 0..upto-1 (Python floats; nan for column 0, no laterals)."""
        return [
            math.nan if w is None else context_value(w, states) for w in self._ctxw_frozen[:upto]
        ]

    def features(self, x: torch.Tensor, upto: int, states: torch.Tensor | None) -> Prev:
        """Hidden activations of the frozen columns ``< upto`` for the inputs ``x`` (B rows).

        PNN: ``(h1, h2)``, each (B, upto*hidden), the columns' activations side by side (each
        lateral is then one product with the concatenated activations). BIARM: ``(stacked,)``,
        one (2*upto, B, hidden) tensor of blocks ``h1_1 .. h1_upto, h2_1 .. h2_upto``, the
        layout of the adapters' batched product (:func:`gated_laterals`). Take rows with
        :meth:`Column.rows`. Only frozen columns may be asked for (``upto <= n_columns - 1``);
        no autograd graph. With ``kernel == "cpp"`` the same operations run in one C++ call
        (``csrc/frozen_features.h``).
        """
        if self.kernel == "cpp":
            ext = _fused()
            if self.gated:
                if upto > 1:
                    assert states is not None
                out = ext.frozen_features_gated(
                    x, self._w1_frozen, self._b1_frozen, self._adw_frozen, self._adb_frozen,
                    self._blk_src, self._frozen_w2, self._frozen_b2, self._frozen_u2,
                    self._ctxw_frozen_t, NO_TENSOR if states is None else states, upto,
                )  # fmt: skip
                return (out,)
            h1, h2 = ext.frozen_features_pnn(
                x, self._w1_frozen, self._b1_frozen,
                self._frozen_w2, self._frozen_b2, self._frozen_u2, upto,
            )  # fmt: skip
            return h1, h2
        h = self.hidden
        bsz = x.shape[0]
        with torch.no_grad():
            pre = torch.addmm(self._b1_frozen[: upto * h], x, self._w1_frozen[:, : upto * h])
            if self.gated:
                out = torch.empty(2 * upto, bsz, h)
                torch.clamp_min(pre.view(bsz, upto, h).transpose(0, 1), 0.0, out=out[:upto])
                zc = out  # replaced by the gated adapters when upto > 1
                gates: list[float] = []
                t2: torch.Tensor
                if upto > 1:
                    assert states is not None
                    gates = self.frozen_context(states.tolist(), upto)
                    # all frozen columns' layer-2 adapters in one batched product
                    nb = upto * (upto - 1) // 2
                    src = out[:1] if nb == 1 else out.index_select(0, self._blk_src[:nb])
                    zc = F.glu(torch.baddbmm(self._adb_frozen[:nb], src, self._adw_frozen[:nb]), 2)
                for j in range(upto):
                    col: Column = self.columns[j]  # type: ignore[assignment]
                    if j == 0:  # column 0 has no laterals, hence no gate
                        t2 = col.b2
                    else:
                        s0 = j * (j - 1) // 2
                        m = zc[s0] if j == 1 else zc[s0 : s0 + j].transpose(0, 1).reshape(bsz, -1)
                        t2 = torch.addmm(col.b2, m, col.u2, alpha=gates[j])
                    torch.clamp_min(torch.addmm(t2, out[j], col.w2), 0.0, out=out[upto + j])
                return (out,)
            h1 = torch.relu(pre)
            parts = [h1]
            for j in range(upto):
                col = self.columns[j]  # type: ignore[assignment]
                t2 = torch.addmm(col.b2, h1[:, : j * h], self._frozen_u2[j]) if j else col.b2
                parts.append(torch.relu(torch.addmm(t2, h1[:, j * h : (j + 1) * h], col.w2)))
            return h1, parts[1] if upto == 1 else torch.cat(parts[1:], 1)

    def q(self, x: torch.Tensor, col: int, states: torch.Tensor | None) -> torch.Tensor:
        """Q-values of column ``col`` (B, n_actions) for padded observations ``x``.

        ``states`` are the four scalar states (internal layout) for the context gates, (4,);
        column ``col``'s own gate may also read per-sample states (B, 4) (learned mode).
        """
        column: Column = self.columns[col]  # type: ignore[assignment]
        if col == 0:
            return column(x)
        frozen_states = states if states is None or states.dim() == 1 else None
        prev = self.lateral_inputs(x, col, frozen_states)
        return column(x, prev, states)

    def lateral_inputs(self, x: torch.Tensor, col: int, states: torch.Tensor | None) -> Prev:
        """What column ``col``'s laterals read: :meth:`features` of the columns ``< col``
        times the column's ``lateral_scale`` (the same tensors when it is 1)."""
        prev = self.features(x, col, states)
        s = self._scale(col)
        return prev if s == 1.0 else tuple(p * s for p in prev)

    def _scale(self, col: int) -> float:
        column: Column = self.columns[col]  # type: ignore[assignment]
        return column.lateral_scale

    def _np_views(self, col: int) -> dict[str, np.ndarray]:
        """NumPy views (shared memory) of column ``col``'s parameters and the frozen caches."""
        views = self._np.get(col)
        if views is None:
            c: Column = self.columns[col]  # type: ignore[assignment]
            views = {n: p.detach().numpy() for n, p in c.named_parameters()}
            views["w1f"] = self._w1_frozen.numpy()
            views["b1f"] = self._b1_frozen.numpy()
            if self.gated:
                views["ctxwf"] = self._ctxw_frozen_t.numpy()
            if self.gated and col > 1:
                views["adwf"] = self._adw_frozen.numpy()
                views["adbf"] = self._adb_frozen.numpy()
                views["src"] = self._blk_src.numpy()
            self._np[col] = views
        return views

    def q_np(
        self, x: np.ndarray, col: int, states: Sequence[float] | np.ndarray | None
    ) -> np.ndarray:
        """:meth:`q` of ONE padded observation ``x`` (float32, ``obs_dim``) in NumPy.

        The same equations as :meth:`features` and :meth:`Column.forward` with float gates
        (last-bit rounding aside), for acting: at batch 1 every torch operation costs several
        times its NumPy equivalent. ``states`` are the four scalar states (internal layout;
        BIARM only); the context gates of all columns are two vector products (float32).
        Returns the Q-values (n_actions,) of column ``col``.
        """
        v = self._np_views(col)
        h1 = x @ v["w1"]
        h1 += v["b1"]
        np.maximum(h1, 0.0, out=h1)
        if col == 0:
            h2 = h1 @ v["w2"]
            h2 += v["b2"]
            np.maximum(h2, 0.0, out=h2)
            return h2 @ v["wq"] + v["bq"]
        h = self.hidden
        feats = np.empty((2 * col, h), dtype=np.float32)  # frozen h1_0.., then h2_0..
        hf = x @ v["w1f"][:, : col * h]
        hf += v["b1f"][: col * h]
        np.maximum(hf, 0.0, out=feats[:col].reshape(-1))
        gates = np.empty(0, dtype=np.float32)
        zf = feats
        s = np.empty(0, dtype=np.float32)
        if self.gated:
            assert states is not None
            s = np.asarray(states, dtype=np.float32)
            gates = expit(v["ctxwf"][:col] @ s)  # entry 0 (column 0, no laterals) unused
            if col > 1:  # all frozen columns' layer-2 adapters in one batched product
                nb = col * (col - 1) // 2
                of = np.matmul(feats[v["src"][:nb], None], v["adwf"][:nb])[:, 0]
                of += v["adbf"][:nb, 0]
                r = of.shape[1] // 2
                zf = of[:, :r] * expit(of[:, r:])
        for j in range(col):
            fv = self._np_views(j)
            t = feats[j] @ fv["w2"]
            t += fv["b2"]
            if j and self.gated:
                s0 = j * (j - 1) // 2
                t += gates[j] * (zf[s0 : s0 + j].reshape(-1) @ fv["u2"])
            elif j:
                t += feats[:j].reshape(-1) @ self._frozen_u2[j].numpy()
            np.maximum(t, 0.0, out=feats[col + j])
        scale = self._scale(col)
        if scale != 1.0:  # what this column's laterals read (lateral_inputs)
            feats *= scale
        if self.gated:
            assert states is not None
            o = np.matmul(feats[:, None], v["ad_w"])[:, 0]
            o += v["ad_b"][:, 0]
            r = o.shape[1] // 2
            zc = o[:, :r] * expit(o[:, r:])
            g = expit(v["ctx_w"] @ s)
            t2 = g * (zc[:col].reshape(-1) @ v["u2"])
            tq = g * (zc[col:].reshape(-1) @ v["uq"])
        else:
            t2 = feats[:col].reshape(-1) @ v["u2"]
            tq = feats[col:].reshape(-1) @ v["uq"]
        t2 += v["b2"]
        t2 += h1 @ v["w2"]
        np.maximum(t2, 0.0, out=t2)
        tq += v["bq"]
        tq += t2 @ v["wq"]
        return tq

    def make_target(self) -> Column:
        """A frozen copy of the current column (the DQN target network)."""
        target = copy.deepcopy(self.current)
        for p in target.parameters():
            p.requires_grad_(False)
        return target

    def config_dict(self) -> dict[str, object]:
        """Constructor arguments plus each column's action count (for :meth:`from_config`)."""
        return {
            "obs_dim": self.obs_dim,
            "hidden": self.hidden,
            "gated": self.gated,
            "adapter_dim": self.adapter_dim,
            "seed": self.seed,
            "context_weights": self.context_weights,
            "learn_context": self.learn_context,
            "lateral_kernel": self.lateral_kernel,
            "actions": [c.n_actions for c in self.columns],  # type: ignore[union-attr]
            "lateral_scales": self.lateral_scales(),
        }

    def lateral_scales(self) -> list[float]:
        """Each column's ``lateral_scale``, in column order."""
        return [self._scale(i) for i in range(self.n_columns)]

    @classmethod
    def from_config(cls, cfg: dict[str, object]) -> ProgressiveNet:
        """Rebuild an empty stack with the same columns (load a state dict into it)."""
        kw = dict(cfg)
        actions = list(kw.pop("actions"))  # type: ignore[call-overload]
        scales = list(kw.pop("lateral_scales", [1.0] * len(actions)))  # type: ignore[call-overload]
        net = cls(**kw)  # type: ignore[arg-type]
        for a, s in zip(actions, scales, strict=True):
            net.add_column(int(a), float(s))
        return net

    def freeze_all(self) -> None:
        """Freeze every column (after the last task) and refresh the fused caches."""
        for p in self.columns.parameters():
            p.requires_grad_(False)
        self.refresh_frozen()


def huber(pred: torch.Tensor, target: torch.Tensor, delta: float) -> torch.Tensor:
    """Mean Huber loss (SPEC §1.6)."""
    return F.huber_loss(pred, target, delta=delta)


__all__ += ["huber"]
