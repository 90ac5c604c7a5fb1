"""Per-entry (sparse) mutation on the noisy surrogate (issue 22, 2026-12-06).

Each entry of every block moves with probability FRAC by N(0, SIG²), instead of the preset's
noise on a whole matrix at once (docs/results/history.md, "Crossover"). A prototype: it swaps the
mutation that the controller calls, and reuses ``crossover_surrogate.py``'s loop with crossover
off, so its numbers compare with that script's "mutation only" row.

Run from this folder: ``python sparse_mutation_surrogate.py FRAC SIG`` (seeds 40-59; prints
FRAC, SIG, the mean of the per-seed median reach in cm, the seeds above 7 cm and the expected
success).
"""

from __future__ import annotations

import sys
from typing import Any

import crossover_surrogate as cs
import numpy as np

import evodevo.grn.controller as controller
from evodevo.grn.mutation import clip_to_bounds

BLOCKS = ("W_s", "W_r", "W_m", "P", "theta", "delta", "alpha")


def sparse_mutation(frac: float, sig: float) -> Any:
    def mutate(parent: Any, config: Any, rng: np.random.Generator) -> Any:
        m = config.mutation
        child = parent.copy()
        if rng.random() < m.p_struct:
            n = child.W_r.shape[0]
            k, i = int(rng.integers(n)), int(rng.integers(n))
            child.W_r[k, i] = 0.0 if child.W_r[k, i] != 0 else rng.normal(0, m.struct_std)
        for name in BLOCKS:
            w = getattr(child, name)
            mask = rng.random(w.shape) < frac
            if name == "W_r":
                mask &= w != 0
            w[mask] += rng.normal(0, sig, int(mask.sum()))
        return clip_to_bounds(child, config)

    return mutate


def main() -> None:
    frac, sig = float(sys.argv[1]), float(sys.argv[2])
    controller.mutate_genome = sparse_mutation(frac, sig)  # type: ignore[assignment]
    res = [cs.evolve({"p_cross": 0.0}, s) for s in range(40, 60)]
    med, ps = [r[0] for r in res], [r[1] for r in res]
    print(
        frac,
        sig,
        round(float(np.mean(med)), 2),
        sum(m > 7 for m in med),
        round(float(np.mean(ps)), 3),
    )


if __name__ == "__main__":
    main()
