"""E3, phase A (docs/results/claims.md): the lateral scale at which PNN transfers best.

Reads the selection runs (seeds 100-102, never reported) under
``docs/results/claims/transfer_scale/``: ``pnn_<scale>/runs/pnn__s<seed>`` for each scale and the
single-task reference ``single/runs/single__s<seed>``. For each scale, forward transfer
(Continual World's FT against the reference of the same seed) averaged over tasks 2-4 and over
the seeds; the highest wins, a tie goes to the larger scale. Prints a table on stderr and the
chosen scale on stdout (what ``run_experiments.sh`` reads).

    python docs/results/claims/choose_lateral_scale.py [FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from evodevo.neuromod.continual_metrics import grid_metrics

SCALES = ("1e-4", "1e-2", "1")
SEEDS = (100, 101, 102)


def mean_transfer(root: Path, scale: str) -> float:
    """FT over tasks 2-4 of PNN at ``scale``, averaged over the selection seeds."""
    grid = {
        "pnn": {s: root / f"pnn_{scale}" / "runs" / f"pnn__s{s}" for s in SEEDS},
        "single": {s: root / "single" / "runs" / f"single__s{s}" for s in SEEDS},
    }
    missing = [
        str(d)
        for runs in grid.values()
        for d in runs.values()
        if not (d / "summary.json").is_file()
    ]
    if missing:
        raise SystemExit(f"phase A is not finished: no summary.json in {missing[0]}")
    metrics = grid_metrics(grid)["pnn"]
    per_seed = []
    for s in SEEDS:
        fts = [t.forward_transfer for t in metrics[s].tasks[1:]]
        if any(f is None for f in fts):
            raise SystemExit(f"no forward transfer for pnn at {scale}, seed {s} (normalisation?)")
        per_seed.append(float(np.mean([f for f in fts if f is not None])))
    return float(np.mean(per_seed))


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/results/claims/transfer_scale")
    ft = {scale: mean_transfer(root, scale) for scale in SCALES}
    for scale, value in ft.items():
        print(f"lateral_scale {scale}: mean FT over tasks 2-4 {value:+.4f}", file=sys.stderr)
    best = max(ft.values())
    chosen = max((float(s), s) for s, v in ft.items() if v == best)[1]  # tie: the larger scale
    print(chosen)


if __name__ == "__main__":
    main()
