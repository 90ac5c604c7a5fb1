"""Learning-rate modulation (Eq. 3.7, SPEC §1.4).

``eta_eff = eta_base * (0.3 s_DA + 0.2 s_5HT + 0.3 s_NE + 0.2 s_ACh)``, written into the Adam
param group before each gradient step (:meth:`evodevo.neuromod.agent.BiarmAgent.lr`). Baseline
PNN keeps ``eta_base``. With ``modules.lr_relative`` the weights come divided by their value at
the resting state, so ``eta_eff = eta_base`` at rest.

>>> effective_lr(1e-3, [0.5, 0.5, 0.5, 0.5], [0.3, 0.2, 0.3, 0.2])
0.0005
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["effective_lr"]


def effective_lr(base: float, states: Sequence[float], weights: Sequence[float]) -> float:
    """Eq. 3.7 with states and weights in the same order (a plain left-to-right sum: it runs
    every environment step)."""
    total = 0.0
    for w, s in zip(weights, states, strict=True):
        total += w * s
    return base * total
