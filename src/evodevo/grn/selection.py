"""Selection of Algorithm 3 (SPEC §2.4): elitism and tournament selection.

>>> import numpy as np
>>> elite_indices(np.array([1.0, 3.0, 2.0]), 2).tolist()
[1, 2]
"""

from __future__ import annotations

import numpy as np

__all__ = ["rank", "elite_indices", "tournament"]


def rank(fitness: np.ndarray) -> np.ndarray:
    """Indices sorted by decreasing fitness; ties keep population order (stable)."""
    return np.argsort(-np.asarray(fitness, dtype=float), kind="stable")


def elite_indices(fitness: np.ndarray, n_elites: int) -> np.ndarray:
    """The ``n_elites`` best indices, best first."""
    return rank(fitness)[:n_elites]


def tournament(fitness: np.ndarray, size: int, rng: np.random.Generator) -> int:
    """Index of the fittest of ``size`` genomes drawn without replacement (ties: lowest index).

    When ``size`` exceeds the population, every genome takes part.
    """
    f = np.asarray(fitness, dtype=float)
    k = min(size, f.size)
    entrants = np.sort(rng.choice(f.size, size=k, replace=False))
    return int(entrants[int(np.argmax(f[entrants]))])
