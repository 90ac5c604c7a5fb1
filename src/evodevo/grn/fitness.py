"""Fitness of Eq. 4.6 (SPEC §2.4): ``F = mean_reward + 10 S + 2 C + min(S, 0.8)``.

S is the success rate over the evaluation episodes and ``C = 1 / (1 + std(rewards))`` the
consistency (population standard deviation of the per-episode rewards).

>>> round(fitness([1.0, 0.0, 1.0, 1.0], [True, False, True, True]), 4)
10.3957
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["fitness", "fitness_matrix", "SUCCESS_WEIGHT", "CONSISTENCY_WEIGHT", "SUCCESS_CAP"]

SUCCESS_WEIGHT = 10.0
"""Weight of the success rate in Eq. 4.6."""
CONSISTENCY_WEIGHT = 2.0
"""Weight of the consistency C in Eq. 4.6."""
SUCCESS_CAP = 0.8
"""Cap of the extra success term min(S, 0.8) of Eq. 4.6."""


def fitness(rewards: Sequence[float] | np.ndarray, successes: Sequence[bool] | np.ndarray) -> float:
    """Eq. 4.6 for one genome's episodes."""
    r = np.asarray(rewards, dtype=float)
    s = float(np.mean(np.asarray(successes, dtype=float)))
    c = 1.0 / (1.0 + float(np.std(r)))
    return float(r.mean() + SUCCESS_WEIGHT * s + CONSISTENCY_WEIGHT * c + min(s, SUCCESS_CAP))


def fitness_matrix(rewards: np.ndarray, successes: np.ndarray) -> np.ndarray:
    """Eq. 4.6 for every row of (genomes, episodes) arrays."""
    return np.array([fitness(r, s) for r, s in zip(rewards, successes, strict=True)])
