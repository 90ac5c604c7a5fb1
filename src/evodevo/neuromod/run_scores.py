"""One row of scores per run: what a run-level experiment compares (SPEC §6).

``biarm report`` writes them to ``table_run_scores.csv`` so that an experiment whose primary
metric is a per-run summary over tasks (E3: forward transfer averaged over tasks 2-4; E4: the
IQM over the four tasks of the normalised final return) is decided from a committed file by
``evodevo compare experiment`` (:mod:`evodevo.evidence.experiment`), like the others.

Per run (variant, seed):

* ``final_normalised_iqm`` / ``final_normalised_mean`` — IQM (rliable's, the 25 % trimmed mean)
  and mean over the tasks of the final greedy return normalised between a uniform-random policy
  and the solved threshold (:mod:`evodevo.evidence.normalise`); empty when a task has no anchors;
* ``forward_transfer_after_first`` — mean of Continual World's ``FT_i`` over tasks 2..T
  (:mod:`evodevo.neuromod.continual_metrics`); empty without a reference for each of them;
* ``auc_normalised_mean`` — mean over tasks of the normalised area under the training curve;
* ``backward_transfer`` — GEM's BWT.

>>> import numpy as np
>>> round(float(iqm([0.0, 0.5, 0.7, 1.0])), 3)  # the middle two of four
0.6
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from evodevo.evidence.aggregate import AGGREGATES
from evodevo.neuromod.continual_metrics import RunMetrics, scale_of
from evodevo.neuromod.table_format import csv_text, variant_order

__all__ = ["RUN_SCORES_FILE", "COLUMNS", "iqm", "run_scores", "run_scores_csv"]

RUN_SCORES_FILE = "table_run_scores.csv"
COLUMNS = [
    "variant",
    "seed",
    "final_normalised_iqm",
    "final_normalised_mean",
    "forward_transfer_after_first",
    "auc_normalised_mean",
    "backward_transfer",
]


def iqm(values: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean of one run's values (rliable's ``aggregate_iqm``)."""
    return float(AGGREGATES["IQM"](np.asarray(values, dtype=float)[None, :]))


def _mean(values: Sequence[float | None]) -> float | None:
    if not values or any(v is None for v in values):
        return None
    return float(np.mean([v for v in values if v is not None]))


def run_scores(
    runs: Mapping[str, Mapping[int, Mapping[str, Any]]],
    metrics: Mapping[str, Mapping[int, RunMetrics]] | None = None,
) -> list[dict[str, Any]]:
    """One dict per run (columns :data:`COLUMNS`; ``None`` where undefined), variants in table
    order, seeds sorted. ``runs``: ``{variant: {seed: summary}}``; ``metrics``: the runs'
    continual-learning metrics (without them the transfer columns are ``None``)."""
    rows = []
    for v in variant_order(runs):
        for seed in sorted(runs[v]):
            tasks = runs[v][seed]["tasks"]
            scales = [scale_of(str(t["env_id"]), t.get("max_steps")) for t in tasks]
            norm = (
                [float(sc.normalise(float(t["final_return"]))) for sc, t in zip(scales, tasks, strict=True)]  # type: ignore[union-attr]
                if scales and all(s is not None for s in scales)
                else None
            )  # fmt: skip
            m = (metrics or {}).get(v, {}).get(seed)
            rows.append(
                {
                    "variant": v,
                    "seed": seed,
                    "final_normalised_iqm": iqm(norm) if norm else None,
                    "final_normalised_mean": float(np.mean(norm)) if norm else None,
                    "forward_transfer_after_first": (
                        _mean([t.forward_transfer for t in m.tasks[1:]]) if m else None
                    ),
                    "auc_normalised_mean": _mean([t.auc_normalised for t in m.tasks])
                    if m
                    else None,
                    "backward_transfer": m.backward_transfer if m else None,
                }
            )
    return rows


def run_scores_csv(rows: Sequence[Mapping[str, Any]]) -> str:
    """The rows as CSV (empty cells where undefined)."""
    return csv_text(COLUMNS, [["" if r[c] is None else r[c] for c in COLUMNS] for r in rows])
