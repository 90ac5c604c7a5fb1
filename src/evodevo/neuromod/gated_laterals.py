"""The gated lateral adapters of BIARM (Eq. 3.8-3.9, SPEC §1.2): ``alpha * V h_k`` with the
content gate ``sigmoid(W_alpha h_k)`` and the context gate ``sigmoid(sum_m w_m s_m)``, every
adapter of a layer in one batched product.

>>> round(context_value([0.3, 0.2, 0.3, 0.2], [0.5] * 4), 4)
0.6225
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F

from evodevo.neuromod.modules import logistic

__all__ = ["Heads", "Prev", "context_value", "gated_laterals"]

Heads = tuple[tuple[torch.Tensor, torch.Tensor], ...]
#: Frozen columns' activations as :meth:`ProgressiveNet.features` returns them.
Prev = tuple[torch.Tensor, ...]


def context_value(weights: Sequence[float], states: Sequence[float]) -> float:
    """Context gate ``sigmoid(sum_m w_m s_m)`` of Eq. 3.8 as a Python float (no autograd)."""
    return logistic(sum(w * x for w, x in zip(weights, states, strict=True)))


def gated_laterals(
    feats: torch.Tensor,
    w: torch.Tensor,
    b: torch.Tensor,
    gate: torch.Tensor | float,
    heads: Heads,
) -> tuple[torch.Tensor, ...]:
    """Eq. 3.8-3.9 for ``n`` stacked adapter blocks feeding ``len(heads)`` layers.

    ``feats`` (n, B, hidden) holds block j's input ``h_k``; ``w`` (n, hidden, 2r) = [V | W_alpha]
    and ``b`` (n, 1, 2r) their biases. With ``o = h_k [V | W_alpha] + b`` (one batched product
    for all blocks), ``glu(o) = V h_k * sigmoid(W_alpha h_k)`` and ``zc = glu(o) * gate`` is
    ``alpha * V h`` of Eq. 3.8 (``gate`` the context gate: a scalar tensor, one per sample
    (B, 1), or a Python float when no gradient is needed). Head g = ``(U, bias)`` takes the g-th
    equal share of the blocks and returns ``bias + [zc_s .. zc_e] U`` (Eq. 3.9, all U_k of a
    layer in one product, the layer's bias folded in; a float gate is the product's ``alpha``,
    ``U (g z) = g (U z)``, one kernel fewer). ``unbind`` rather than slicing keeps the backward
    pass to one gather (no zero-filled copies).
    """
    r = w.shape[2] // 2
    zc = F.glu(torch.baddbmm(b, feats, w), 2)
    alpha = 1.0
    if isinstance(gate, float):
        alpha = gate
    else:
        zc = zc * gate
    per = zc.shape[0] // len(heads)
    if per == 1:
        ms = zc.unbind(0)
    else:
        bsz = zc.shape[1]
        ms = tuple(z.transpose(0, 1).reshape(bsz, per * r) for z in zc.split(per, 0))
    return tuple(
        torch.addmm(bias, m, u, alpha=alpha) for m, (u, bias) in zip(ms, heads, strict=True)
    )
