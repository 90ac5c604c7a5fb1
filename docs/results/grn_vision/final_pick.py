"""Was the final pick the problem? Re-select a finished run's last elites on fresh episodes.

Issue 22, 2026-12-05 (docs/results/history.md, "More genomes, fewer episodes, on the real env").
A run's ``best_genome.npz`` is the best of its last generation on that generation's few
training episodes. This script takes the elites that the last generation passed on (the first
``evolution.elites`` genomes of the checkpoint's bred population, best first), scores each on
``--episodes`` fresh *training-object* episodes (seed stream 5, never used by evolution; the
same episodes for every elite), keeps the one with the most successes (the earliest rank on a
tie) and tests it on the usual 200 held-out-object episodes (test seed 10000). Elite 0 is the run's
``best_genome.npz``, so picking it reproduces ``evodevo grn evaluate``'s clean test.

Run: ``python docs/results/grn_vision/final_pick.py RUN_DIR [--episodes 30] [--workers 1]``;
writes ``RUN_DIR/final_pick.json`` and ``RUN_DIR/final_pick_test_episodes.csv``.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.grn.controller import make_controller
from evodevo.grn.evaluation import load_run, test_episodes
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.evolution import CHECKPOINT_FILE, Evolution, training_episodes

PICK_KEY = 5
"""Seed stream of the re-selection episodes (evolution uses 2-4)."""


def checkpoint_evolution(cfg: Any, run: Path) -> Evolution:
    """The optimiser state of ``run``'s checkpoint (population best first, final pick), read by
    :meth:`Evolution.load_checkpoint`; no evaluator (nothing is evaluated through it)."""
    evo = Evolution(cfg, make_controller(cfg, 3), evaluator=None)  # type: ignore[arg-type]
    evo.load_checkpoint(run / "checkpoints" / CHECKPOINT_FILE)
    return evo


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--episodes", type=int, default=30)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    lr = load_run(args.run)
    cfg = lr.config
    evo = checkpoint_evolution(cfg, args.run)
    if not evo.bred_at_end:
        raise SystemExit("the checkpoint predates breeding after the last generation")
    elites = evo.population[: cfg.evolution.elites]
    eps = training_episodes(cfg.seed, PICK_KEY, 0, args.episodes, 0.0)
    with Evaluator(cfg, lr.encoder, workers=args.workers) as ev:
        res = ev.evaluate(elites, eps)
        wins = res.success.sum(axis=1)
        pick = int(np.argmax(wins))
        test = test_episodes(cfg.evaluation.test_seed, 200, True)
        tres = ev.evaluate([elites[pick]], test)
    succ = tres.success[0].astype(int)
    out = {
        "elites": len(elites),
        "pick_episodes": args.episodes,
        "pick_successes": wins.astype(int).tolist(),
        "picked": pick,
        "test_successes": int(succ.sum()),
        "test_episodes": len(test),
    }
    (args.run / "final_pick.json").write_text(json.dumps(out, indent=2) + "\n")
    with open(args.run / "final_pick_test_episodes.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["policy", "episode", "seed", "success"])
        for i, (e, s) in enumerate(zip(test, succ, strict=True)):
            w.writerow(["genome", i, e.seed, int(s)])
    print(json.dumps(out))


if __name__ == "__main__":
    main()
