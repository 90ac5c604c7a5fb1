"""Is the evolved GRN better without its expression noise at test time? (issue 22, a lead)

The nine ablations of seed 0 put "no noise" at +4.0 (``vision2_noes_s0``) and +5.0
(``vision7_record_s0``) points on 100 held-out-object episodes, neither significant. Choosing
a test-time setting on the test objects would tune on the test set, so this script measures it
on the **training** objects first: each seed's kept genome (``vision7_record_s{seed}``), with
and without N(0, σ²) expression noise (the ``no_noise`` ablation of
:mod:`evodevo.grn.ablations`), on the same episodes (common random numbers), paired by exact McNemar.

Usage: python docs/results/grn_vision/noise_free.py SEED [EPISODES]  (one seed per process;
appends one JSON line per seed to noise_free.jsonl beside this file).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from evodevo.grn.ablations import ablate
from evodevo.grn.evaluation import load_run, test_episodes
from evodevo.grn.evaluator import Evaluator
from evodevo.parallel import set_single_thread
from evodevo.stats import mcnemar_exact, rate

HERE = Path(__file__).resolve().parent
#: training-object episodes derive(30000, i): a stream of their own (evolution and test derive theirs)
EPISODE_SEED = 30000


def main(seed: int, n: int) -> None:
    set_single_thread()
    loaded = load_run(HERE / f"vision7_record_s{seed}")
    cfg = loaded.config
    quiet_genome, quiet = ablate(loaded.genome, "no_noise", cfg, np.random.default_rng(0))
    eps = test_episodes(EPISODE_SEED, n, test_objects=False)
    t0 = time.perf_counter()
    with Evaluator(cfg, loaded.encoder, workers=1) as ev:
        noisy = ev.evaluate([loaded.genome], eps).success[0]
        clean = ev.evaluate([quiet_genome], eps, config=quiet).success[0]
    both = [int(a) for a in noisy], [int(b) for b in clean]
    row = {
        "seed": seed,
        "objects": "train",
        "episode_seed": EPISODE_SEED,
        "episodes": n,
        "noise_std": cfg.dynamics.noise_std,
        "with_noise": rate(sum(both[0]), n).rate,
        "without_noise": rate(sum(both[1]), n).rate,
        "mcnemar_p": mcnemar_exact(*both),
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(row))
    with open(HERE / "noise_free.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 200)
