"""Fitness of Eq. 4.6 (SPEC §2.4): ``F = mean_reward + 10 S + 2 C + min(S, 0.8)``.

S is the success rate over the evaluation episodes and ``C = 1 / (1 + std(rewards))`` the
consistency (population standard deviation of the per-episode rewards).

>>> round(fitness([1.0, 0.0, 1.0, 1.0], [True, False, True, True]), 4)
10.3957
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "distance_penalty",
    "DISTANCE_UNIT",
    "DISTANCE_CAP",
    "fitness",
    "fitness_matrix",
    "SUCCESS_WEIGHT",
    "CONSISTENCY_WEIGHT",
    "SUCCESS_CAP",
]

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


DISTANCE_UNIT = 0.05
"""Unit (m) of the shaped training term: a genome loses ``distance_weight`` per 5 cm."""
DISTANCE_CAP = 0.2
"""Distances (m) above this count as this (a miss is a miss)."""


def distance_penalty(distance: np.ndarray) -> np.ndarray:
    """Mean over episodes (last axis) of min(d, 20 cm) / 5 cm, per genome (SPEC §2.4 shaping).

    ``d`` is the gripper-to-nearest-object distance at an episode's end, read from the simulator
    during training only; episodes without a measurement (NaN) count as the cap.

    >>> distance_penalty(np.array([[0.0, 0.1], [0.5, np.nan]])).tolist()
    [1.0, 4.0]
    """
    d = np.where(np.isfinite(distance), distance, DISTANCE_CAP)
    return np.asarray(np.minimum(d, DISTANCE_CAP).mean(axis=-1) / DISTANCE_UNIT, dtype=float)
