"""Does recombination join an x map and a y map? Crossover on the noisy reach surrogate.

Issue 22, 2026-12-06 (docs/results/history.md, "Crossover"). The real-env runs learn the map
from the target's x offset or the one from its y offset, rarely both; Algorithm 3 breeds by
mutation alone. Here a child is, with probability ``p_cross``, first a recombination of two
tournament-picked parents, then mutated as usual:

* ``gene``: uniform crossover gene by gene — gene k's sensor weights W_s[:, k], its regulatory
  row W_r[k, :], its motor weights W_m[k, :] and its theta, delta, alpha come from one parent;
* ``motor``: the child takes each action's motor column W_m[:, j] from either parent, the rest
  from the first.

Everything else is ``noisy_surrogate.py`` (its success model, its shaping, its score).
Run: ``python docs/results/grn_vision/crossover_surrogate.py [ROW ...] [--seeds N]
[--first-seed S]``; lines appended to ``crossover_surrogate.jsonl``.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
from noisy_surrogate import noisy_score, p_success, rows_cli
from search_surrogate import evolve_best, reach

from evodevo.grn.selection import tournament

ROWS: dict[str, dict[str, Any]] = {
    "preset (no crossover)": {"p_cross": 0.0},
    "gene crossover, p 0.5": {"p_cross": 0.5, "kind": "gene"},
    "gene crossover, p 1": {"p_cross": 1.0, "kind": "gene"},
    "motor-column crossover, p 0.5": {"p_cross": 0.5, "kind": "motor"},
}


def cross(a: Any, b: Any, kind: str, rng: np.random.Generator) -> Any:
    child = a.copy()
    if kind == "motor":
        take = rng.random(a.W_m.shape[1]) < 0.5
        child.W_m[:, take] = b.W_m[:, take]
        return child
    take = rng.random(a.n_genes) < 0.5
    child.W_s[:, take] = b.W_s[:, take]
    child.W_r[take, :] = b.W_r[take, :]
    child.W_m[take, :] = b.W_m[take, :]
    for name in ("theta", "delta", "alpha"):
        getattr(child, name)[take] = getattr(b, name)[take]
    return child


def breeder(p_cross: float, kind: str) -> Any:
    """Offspring: a tournament-picked parent, with probability ``p_cross`` first recombined
    with a second one, then mutated."""

    def breed(ctrl: Any, pop: list[Any], fit: np.ndarray, evo: Any, rng: Any) -> list[Any]:
        children = []
        for _ in range(evo.population - evo.elites):
            parent = pop[tournament(fit, evo.tournament, rng)]
            if rng.random() < p_cross:
                parent = cross(parent, pop[tournament(fit, evo.tournament, rng)], kind, rng)
            children.append(ctrl.mutate(parent, rng))
        return children

    return breed


def evolve(row: dict[str, Any], seed: int) -> tuple[float, float]:
    row = copy.deepcopy(row)
    breed = breeder(row.pop("p_cross"), row.pop("kind", "gene"))
    ctrl, best, test = evolve_best(row, seed, noisy_score, breed)
    d = reach(ctrl, [best], test)[0]
    return round(float(np.median(d)) * 100, 2), round(float(p_success(d).mean()), 3)


def main() -> None:
    rows_cli(__doc__, ROWS, evolve, Path(__file__).with_name("crossover_surrogate.jsonl"), 20, 40)


if __name__ == "__main__":
    main()
