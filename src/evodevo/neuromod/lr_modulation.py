"""Learning-rate modulation (Eq. 3.7, SPEC §1.4).

``eta_eff = eta_base * (0.3 s_DA + 0.2 s_5HT + 0.3 s_NE + 0.2 s_ACh)``, written into every
Adam param group before each gradient step. Baseline PNN keeps ``eta_base``.

>>> effective_lr(1e-3, [0.5, 0.5, 0.5, 0.5], [0.3, 0.2, 0.3, 0.2])
0.0005
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

__all__ = ["effective_lr", "set_lr"]


def effective_lr(
    base: float, states: Sequence[float] | np.ndarray, weights: Sequence[float]
) -> float:
    """Eq. 3.7 with states and weights in the same order."""
    return float(base * float(np.dot(np.asarray(states, dtype=np.float64), np.asarray(weights))))


def set_lr(optimizer: torch.optim.Optimizer, lr: float) -> None:
    """Set ``lr`` on every param group of ``optimizer`` (before a gradient step)."""
    for group in optimizer.param_groups:
        group["lr"] = lr
