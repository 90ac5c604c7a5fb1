"""Aggregates over runs and tasks of a BIARM grid, on rliable (SPEC §6).

Each run's final greedy return per task is normalised between a uniform random policy and the
task's solved threshold (:mod:`evodevo.evidence.normalise`); per variant, the ``runs x tasks``
matrix gives the interquartile mean (IQM) and the mean with stratified-bootstrap 95 %
intervals, the probability that a variant's run beats a PNN run on a task, and performance
profiles (:mod:`evodevo.evidence.aggregate`). The run is the unit; the evaluation episodes of
one run are averaged first.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.evidence.aggregate import (
    DEFAULT_REPS,
    aggregate_scores,
    performance_profiles,
    probability_of_improvement,
)
from evodevo.evidence.profiles import plot_performance_profiles
from evodevo.neuromod.continual_metrics import scale_of
from evodevo.neuromod.table_format import md_table, variant_order
from evodevo.seed_split import range_label

__all__ = ["AGGREGATE_TITLE", "PROFILE_FIGURE", "normalised_finals", "aggregate_markdown"]

AGGREGATE_TITLE = "Aggregates over tasks (rliable, SPEC §6)"
PROFILE_FIGURE = "fig_performance_profile.png"
#: The variant every other one is compared with.
BASELINE = "pnn"


def normalised_finals(
    runs: Mapping[str, Mapping[int, Mapping[str, Any]]],
) -> tuple[dict[str, np.ndarray], list[str]]:
    """Per variant, the ``runs x tasks`` matrix of normalised final returns (seeds sorted), and
    the tasks. Empty when a task has no normalisation anchors (no solved threshold, or a step
    limit other than the environment's own)."""
    first = next(iter(next(iter(runs.values())).values()))
    tasks = first["tasks"]
    scales = [scale_of(str(t["env_id"]), t.get("max_steps")) for t in tasks]
    if any(s is None for s in scales):
        return {}, [str(t["env_id"]) for t in tasks]
    out: dict[str, np.ndarray] = {}
    for v in variant_order(runs):
        rows = []
        for seed in sorted(runs[v]):
            finals = [float(t["final_return"]) for t in runs[v][seed]["tasks"]]
            if len(finals) != len(scales):
                continue
            rows.append([float(sc.normalise(f)) for sc, f in zip(scales, finals, strict=True)])  # type: ignore[union-attr]
        if rows:
            out[v] = np.array(rows, dtype=float)
    return out, [str(t["env_id"]) for t in tasks]


def aggregate_markdown(
    runs: Mapping[str, Mapping[int, Mapping[str, Any]]],
    figure: Path | None = None,
    reps: int = DEFAULT_REPS,
    seed: int = 0,
) -> str:
    """The aggregates as Markdown (a caption, the IQM/mean table, P(variant > pnn)), and the
    performance profiles drawn into ``figure`` when given; one line saying why when the tasks
    cannot be normalised."""
    scores, tasks = normalised_finals(runs)
    if not scores:
        return (
            "(no aggregate over tasks: a task has no normalisation anchors, i.e. no solved "
            f"threshold in its Gymnasium spec or another step limit; tasks {', '.join(tasks)})\n"
        )
    first = next(iter(next(iter(runs.values())).values()))
    ev = first.get("eval_seeds") or [0]
    caption = (
        "Final greedy return per task normalised to [0, 1] between a uniform random policy and "
        "the solved threshold (above 1: beyond the threshold), over the tasks "
        f"{', '.join(tasks)}; IQM and mean over all run-task scores with stratified-bootstrap "
        f"95 % intervals ({reps} resamples, seed {seed}); evaluation seeds {ev[0]}..{ev[-1]} "
        f"(the {range_label(ev[0], len(ev))} range)."
    )
    agg = aggregate_scores(scores, reps=reps, seed=seed)
    parts = [caption, "", agg.to_markdown(), ""]
    pairs = [(v, BASELINE) for v in scores if v != BASELINE and BASELINE in scores]
    if pairs:
        poi = probability_of_improvement(scores, pairs, reps=reps, seed=seed)
        rows = [[x, str(len(scores[x])), str(len(scores[y])), poi[(x, y)].fmt(2)] for x, y in pairs]
        parts += [
            f"Probability that a run of the variant beats a run of `{BASELINE}` on a task "
            "(averaged over tasks; 0.5: neither; runs resampled independently per task):",
            "",
            md_table(["variant", "runs", f"{BASELINE} runs", f"P(variant > {BASELINE})"], rows),
        ]
    if figure is not None:
        taus = np.linspace(0.0, 1.2, 61)
        plot_performance_profiles(
            performance_profiles(scores, taus, reps=reps, seed=seed),
            figure,
            title="Performance profiles (final return, normalised)",
        )
        parts += [f"![performance profiles]({figure.name})", ""]
    return "\n".join(parts) + "\n"
