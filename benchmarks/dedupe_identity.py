"""Kuka: one evaluator call with ``evaluation.dedupe`` gives what it gives without.

A population of the evolved genome of ``docs/results/thesis/grn/plain_s1``, a mutant of it and
three copies (2 distinct genomes in 5) is scored on the common training episodes of
generation 0, once with dedupe and once without, by the same :class:`Evaluator` (lockstep 4,
settled-scene cache on, the gripper distance measured); the script reports whether reward,
success, steps and distance are equal bit for bit, the episodes saved and the CPU seconds.

Usage::

    python benchmarks/dedupe_identity.py [--seeds N]

The last line of output is JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["run", "main"]


def run(seeds: int = 3) -> dict[str, Any]:
    """Score the population with and without dedupe; see the module docstring."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from benchmarks.evolution_speed import DEFAULT_RUN, _load
    from evodevo.grn.evaluator import Evaluator
    from evodevo.grn.evolution import EPISODE_KEY, training_episodes

    config, encoder, controller, best = _load(DEFAULT_RUN)
    rng = np.random.default_rng(7)
    mutant = controller.mutate(best, rng)
    same_arrays = zip(mutant.arrays().values(), best.arrays().values(), strict=True)
    while all(np.array_equal(a, b) for a, b in same_arrays):  # a mutant that differs
        mutant = controller.mutate(best, rng)
        same_arrays = zip(mutant.arrays().values(), best.arrays().values(), strict=True)
    population = [best, mutant, best.copy(), mutant.copy(), best.copy()]
    episodes = training_episodes(
        config.seed, EPISODE_KEY, 0, seeds, config.evaluation.noisy_fraction
    )
    off = dataclasses.replace(
        config, evaluation=dataclasses.replace(config.evaluation, dedupe=False)
    )
    results: dict[str, Any] = {}
    cpu: dict[str, float] = {}
    with Evaluator(config, encoder) as ev:
        for name, cfg in (("dedupe", config), ("no_dedupe", off)):
            c0 = time.process_time()
            results[name] = ev.evaluate(population, episodes, config=cfg, measure_distance=True)
            cpu[name] = round(time.process_time() - c0, 2)
    a, b = results["dedupe"], results["no_dedupe"]
    fields = ("reward", "success", "steps", "distance")
    return {
        "population": f"{len(population)} genomes, 2 distinct",
        "episodes": len(episodes),
        "identical": all(
            np.array_equal(getattr(a, k), getattr(b, k), equal_nan=True) for k in fields
        ),
        "episodes_saved": a.episodes_saved,
        "dedupe_cpu_s": cpu["dedupe"],
        "no_dedupe_cpu_s": cpu["no_dedupe"],
        "success": a.success.astype(int).tolist(),
    }


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="common episode seeds")
    args = ap.parse_args(argv)
    print(json.dumps(run(args.seeds)))


if __name__ == "__main__":
    main()
