"""The continual-learning metrics table of SPEC §6 over a grid of BIARM runs.

Per variant and task: area under the training curve, forward transfer against the single-task
reference, forgetting, episodes to the solved threshold, and per run backward transfer, each
as the mean over runs with a run-level bootstrap interval (:mod:`evodevo.evidence`), and
every variant paired with ``pnn`` on forward transfer and AUC with a verdict against δ. The
per-run numbers come from :mod:`evodevo.neuromod.continual_metrics`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from evodevo.evidence.aggregate import DEFAULT_REPS, Estimate, interval_estimates
from evodevo.evidence.normalise import RETURN_MARGIN_FRACTION
from evodevo.evidence.verdict import Comparison, compare, holm_table
from evodevo.neuromod.continual_metrics import WINDOW, RunMetrics
from evodevo.neuromod.table_format import csv_text, format_seeds, md_table, variant_order
from evodevo.seed_split import range_label

__all__ = [
    "CL_BASELINE",
    "CL_RUN_METRICS",
    "CL_TASK_METRICS",
    "ContinualTable",
    "continual_runs_csv",
    "continual_table",
]


#: Per-task metrics of :class:`ContinualTable`: key -> (column title, digits).
CL_TASK_METRICS: dict[str, tuple[str, int]] = {
    "auc": ("AUC: mean training return", 1),
    "auc_normalised": ("AUC normalised", 3),
    "forward_transfer": ("FT vs single", 3),
    "forgetting": ("Forgetting R(i,i) − R(T,i)", 2),
    "episodes_to_threshold": ("Episodes to threshold", 0),
}
#: Per-run metrics over the whole sequence: key -> (column title, digits).
CL_RUN_METRICS: dict[str, tuple[str, int]] = {
    "backward_transfer": ("BWT, normalised", 3),
    "forward_transfer": ("FT, mean over tasks", 3),
}
#: The variant every other is paired with in the continual-learning comparisons.
CL_BASELINE = "pnn"
#: The env_id of the per-run (whole sequence) records in the CSV.
SEQUENCE = "sequence"


def _run_values(run: RunMetrics, key: str, index: int | None) -> float | None:
    """One run's value of a metric: of task ``index``, or over the sequence (``None``)."""
    if index is None:
        value = run.backward_transfer if key == "backward_transfer" else run.mean_forward_transfer
    else:
        value = getattr(run.tasks[index], key)
    return None if value is None else float(value)


def _intervals(
    cells: Mapping[tuple[str, int | str, str], list[float]], reps: int, seed: int
) -> dict[tuple[str, int | str, str], Estimate]:
    """Mean of each cell's run values with its 95 % bootstrap interval over runs.

    Cells with the same number of runs go through one seeded call of
    :func:`evodevo.evidence.aggregate.interval_estimates` as the columns of a ``runs x cells``
    matrix, whose stratified bootstrap resamples each column's runs on their own.
    """
    out: dict[tuple[str, int | str, str], Estimate] = {}
    by_n: dict[int, list[tuple[str, int | str, str]]] = {}
    for key, values in cells.items():
        if values:
            by_n.setdefault(len(values), []).append(key)
    for _, keys in sorted(by_n.items()):
        matrix = np.array([cells[k] for k in keys], dtype=float).T  # runs x cells
        points, bounds = interval_estimates(
            {"cells": matrix}, lambda x: np.mean(x, axis=0), reps=reps, seed=seed
        )
        for j, k in enumerate(keys):
            p, lo, hi = points["cells"][j], bounds["cells"][0, j], bounds["cells"][1, j]
            out[k] = Estimate(float(p), float(lo), float(hi))
    return out


@dataclass(frozen=True)
class ContinualTable:
    """The continual-learning metrics of a grid (SPEC §6), summarised over runs.

    Attributes:
        records: One record per (variant, task index or ``""`` for the whole sequence,
            metric): environment id (:data:`SEQUENCE` for the whole sequence), runs, runs with
            a value, their mean and interval, and a note (e.g. the threshold).
        comparisons: ``(metric, task index, Comparison)`` of every variant against
            :data:`CL_BASELINE` on FT and normalised AUC, Holm-corrected together.
        has_reference: The grid holds single-task reference runs, so FT exists.
        eval_seeds: Every distinct tuple of evaluation seeds among the runs.
        seeds: Every run seed of the grid.
        window: Episodes of the rolling mean behind the episodes to threshold.
        reps: Bootstrap resamples of every interval.
        shared_seeds: The most seeds any variant shares with :data:`CL_BASELINE`.
    """

    records: list[dict[str, Any]]
    comparisons: list[tuple[str, int, Comparison]]
    has_reference: bool
    eval_seeds: list[tuple[int, ...]]
    seeds: list[int]
    window: int
    reps: int
    shared_seeds: int = 0

    def _record(self, variant: str, task: int | str, metric: str) -> dict[str, Any] | None:
        for r in self.records:
            if (r["variant"], r["task"], r["metric"]) == (variant, task, metric):
                return r
        return None

    def _cell(self, variant: str, task: int | str, metric: str, digits: int) -> str:
        r = self._record(variant, task, metric)
        if r is not None and metric == "episodes_to_threshold" and r["runs_with_value"] == 0:
            return f"— (0/{r['runs']} runs; {r['note']})"
        if r is None or r["runs_with_value"] == 0:
            note = r["note"] if r is not None else ""
            return f"— ({note})" if note else "—"
        est = Estimate(r["mean"], r["ci_low"], r["ci_high"])
        cell = est.fmt(digits) if r["runs_with_value"] > 1 else f"{est.point:.{digits}f}"
        if metric == "episodes_to_threshold":
            cell += f" ({r['runs_with_value']}/{r['runs']} runs; {r['note']})"
        elif r["runs_with_value"] < r["runs"]:
            cell += f" ({r['runs_with_value']}/{r['runs']} runs)"
        return cell

    def markdown(self) -> str:
        """Captions and tables: per variant and task, per variant over the sequence, and the
        paired comparisons against :data:`CL_BASELINE`."""
        variants = list(dict.fromkeys(r["variant"] for r in self.records))
        task_keys = [k for k in CL_TASK_METRICS if k != "forward_transfer" or self.has_reference]
        header = ["Model", "Environment", "Runs", *[CL_TASK_METRICS[k][0] for k in task_keys]]
        rows = []
        for rec in self.records:
            if rec["metric"] != "auc":
                continue
            v, task = rec["variant"], rec["task"]
            cells = [self._cell(v, task, k, CL_TASK_METRICS[k][1]) for k in task_keys]
            rows.append([v, rec["label"], str(rec["runs"]), *cells])
        seq_keys = [k for k in CL_RUN_METRICS if k != "forward_transfer" or self.has_reference]
        seq_header = ["Model", "Runs", *[CL_RUN_METRICS[k][0] for k in seq_keys]]
        seq_rows = []
        for v in variants:
            r = self._record(v, "", "backward_transfer")
            if r is None:
                continue
            cells = [self._cell(v, "", k, CL_RUN_METRICS[k][1]) for k in seq_keys]
            seq_rows.append([v, str(r["runs"]), *cells])
        ranges = "; ".join(
            f"{len(ev)} greedy evaluation episode{'s' if len(ev) > 1 else ''}, seeds "
            f"{ev[0]}..{ev[-1]} (the "
            f"{range_label(ev[0], len(ev))} range, SPEC §6)"
            for ev in self.eval_seeds
            if ev
        )
        parts = [
            "Per task: AUC is the area under the training curve per episode, i.e. the mean "
            "training-episode return over the task's episodes (ε-greedy, as trained); normalised "
            "AUC is the mean of those returns mapped to [0, 1] (random policy 0, solved threshold "
            "1, clipped; `evodevo.evidence.normalise`); forgetting is the greedy return right "
            "after the task minus after the whole sequence (0: kept; none for the last task); "
            f"episodes to threshold counts training episodes until the mean of the last "
            f"{self.window} returns first reaches the threshold (the task's solved return), mean "
            "over the runs that reached it. Each cell: mean over runs [95 % bootstrap interval "
            f"of the mean over seeds, rliable, {self.reps:,} resamples; none from one run]. "
            f"Returns R: {ranges}.",
            "",
        ]
        if self.has_reference:
            parts += [
                "Forward transfer (Continual World): FT = (AUC − AUC_ref) / (1 − AUC_ref) on "
                "normalised AUCs against the single-task reference `single` (every lateral "
                "scaled by 0) of the same seed; 0 is no transfer, negative is interference. A "
                "seed without its reference uses the mean over the reference's seeds (noted in "
                "`table_cl_runs.csv`).",
                "",
            ]
        else:
            parts += [
                "Forward transfer needs the single-task reference, which this grid lacks: "
                f"`evodevo biarm compare --variants single --seeds {format_seeds(self.seeds)} "
                "--out DIR` (DIR this grid's folder, with the grid's config, episodes scale and "
                "protocol) adds it.",
                "",
            ]
        parts += [md_table(header, rows).rstrip(), ""]
        parts += [
            "Over the sequence, per run: backward transfer (GEM) BWT = mean over tasks before "
            "the last of R(T,i) − R(i,i) on normalised greedy returns (clipped to [0, 1], so a "
            "drop that stays above the solved threshold does not count; negative is forgetting)"
            + (", and FT averaged over the tasks" if self.has_reference else "")
            + "; mean over runs [95 % bootstrap interval].",
            "",
            md_table(seq_header, seq_rows).rstrip(),
            "",
        ]
        parts += self._comparisons_markdown(variants)
        return "\n".join(parts).rstrip() + "\n"

    def _comparisons_markdown(self, variants: list[str]) -> list[str]:
        if CL_BASELINE not in variants or len(variants) < 2:
            return []
        metrics = "FT and normalised AUC" if self.has_reference else "normalised AUC"
        if not self.comparisons:
            return [
                f"Paired comparisons against {CL_BASELINE} on {metrics} need at least 2 seeds "
                f"that another variant shares with {CL_BASELINE}; this grid has "
                f"{self.shared_seeds}.",
                "",
            ]
        head, rule = Comparison.HEADER.split("\n")
        lines = [
            f"Each variant against {CL_BASELINE} on {metrics}, paired by seed "
            "(`evodevo.evidence.verdict`): exact sign-flip test, p Holm-corrected over the "
            f"{len(self.comparisons)} comparisons of this table, δ = "
            f"{RETURN_MARGIN_FRACTION:g} on the normalised scale.",
            "",
            "| metric " + head,
            "|---" + rule,
        ]
        lines += [f"| {m} " + c.fmt(3) for m, _, c in self.comparisons]
        return [*lines, ""]

    def csv(self) -> str:
        """:attr:`records` as CSV (numbers unformatted, empty where undefined)."""
        header = ["variant", "task", "env_id", "metric", "runs", "runs_with_value", "mean"]
        header += ["ci_low", "ci_high", "note"]
        return csv_text(header, [[r[k] for k in header] for r in self.records])

    def comparisons_csv(self) -> str:
        """:attr:`comparisons` as CSV, one row each."""
        header = ["metric", "task", "env_id", "a", "b", "n", "mean_diff", "ci_low", "ci_high"]
        header += ["std_diff", "p", "p_holm", "delta", "mde", "verdict", "runs_needed", "test"]
        rows = [
            [m, i, c.task, c.a, c.b, c.n, c.mean_diff, c.low, c.high, c.std_diff, c.p, c.p_adj]
            + [c.delta, c.mde, c.verdict, "" if c.runs_needed is None else c.runs_needed, c.test]
            for m, i, c in self.comparisons
        ]
        return csv_text(header, rows)


def continual_runs_csv(metrics: Mapping[str, Mapping[int, RunMetrics]]) -> str:
    """Every run's metrics, one row per (run, task): the data behind :class:`ContinualTable`."""
    header = ["variant", "seed", "task", "env_id", "episodes", "auc", "auc_normalised"]
    header += ["forward_transfer", "reference", "initial_return", "final_return", "forgetting"]
    header += ["threshold", "episodes_to_threshold", "backward_transfer", "run_dir"]
    rows = []
    for v in variant_order(metrics):
        for seed in sorted(metrics[v]):
            run = metrics[v][seed]
            for t in run.tasks:
                values = [v, seed, t.index, t.env_id, t.episodes, t.auc, t.auc_normalised]
                values += [t.forward_transfer, t.reference, t.initial_return, t.final_return]
                values += [t.forgetting, t.threshold, t.episodes_to_threshold]
                values += [run.backward_transfer, run.run_dir]
                rows.append(["" if x is None else x for x in values])
    return csv_text(header, rows)


def _missing_note(runs: Sequence[RunMetrics], key: str, index: int | None) -> str:
    """Why a normalised metric has no value in any run."""
    tasks = [t for r in runs for t in (r.tasks if index is None else r.tasks[index : index + 1])]
    if any(t.auc_normalised is None for t in tasks):
        return "no normalisation anchors for this step limit"
    if key == "forward_transfer" and all(t.reference is not None for t in tasks):
        return "undefined: reference AUC is 1"
    return "no reference run" if key == "forward_transfer" else ""


def continual_table(
    metrics: Mapping[str, Mapping[int, RunMetrics]],
    reps: int = DEFAULT_REPS,
    seed: int = 0,
    window: int = WINDOW,
) -> ContinualTable:
    """Summarise :func:`evodevo.neuromod.continual_metrics.grid_metrics` over runs (SPEC §6).

    Args:
        metrics: ``{variant: {seed: RunMetrics}}``.
        reps: Bootstrap resamples of every interval and comparison.
        seed: Seed of the bootstraps.
        window: The rolling window the metrics were computed with (stated in the caption).
    """
    variants = variant_order(metrics)
    has_reference = any(
        t.forward_transfer is not None
        for runs in metrics.values()
        for r in runs.values()
        for t in r.tasks
    )
    cells: dict[tuple[str, int | str, str], list[float]] = {}
    about: dict[tuple[str, int | str, str], tuple[str, str, int, str]] = {}
    for v in variants:
        runs = [metrics[v][s] for s in sorted(metrics[v])]
        envs = [t.env_id for t in runs[0].tasks]
        slots: list[tuple[int | None, str]] = [
            (i, k) for i in range(len(envs)) for k in CL_TASK_METRICS
        ]
        slots += [(None, k) for k in CL_RUN_METRICS]
        for index, key in slots:
            if not has_reference and key == "forward_transfer":
                continue
            values = [x for r in runs if (x := _run_values(r, key, index)) is not None]
            note = ""
            if key == "episodes_to_threshold" and index is not None:
                thr = sorted({t for r in runs if (t := r.tasks[index].threshold) is not None})
                note = "threshold " + ", ".join(f"{x:g}" for x in thr) if thr else "no threshold"
            elif key == "forgetting" and index == len(envs) - 1:
                note = "last task"
            elif not values and key in ("auc_normalised", "forward_transfer", "backward_transfer"):
                note = _missing_note(runs, key, index)
            task: int | str = "" if index is None else index
            env = SEQUENCE if index is None else envs[index]
            label = env if index is None or envs.count(env) == 1 else f"{env} (task {index + 1})"
            cells[(v, task, key)] = values
            about[(v, task, key)] = (env, label, len(runs), note)
    estimates = _intervals(cells, reps, seed)
    records = []
    for (v, task, key), values in cells.items():
        est = estimates.get((v, task, key))
        env, label, n_runs, note = about[(v, task, key)]
        records.append(
            {
                "variant": v,
                "task": task,
                "env_id": env,
                "label": label,
                "metric": key,
                "runs": n_runs,
                "runs_with_value": len(values),
                "mean": "" if est is None else est.point,
                "ci_low": "" if est is None else est.low,
                "ci_high": "" if est is None else est.high,
                "note": note,
            }
        )
    comparisons = _cl_comparisons(metrics, variants, has_reference, reps, seed)
    eval_seeds = list(
        dict.fromkeys(r.eval_seeds for runs in metrics.values() for r in runs.values())
    )
    seeds = sorted({int(s) for runs in metrics.values() for s in runs})
    base = set(metrics.get(CL_BASELINE, {}))
    shared = max((len(set(r) & base) for v, r in metrics.items() if v != CL_BASELINE), default=0)
    return ContinualTable(
        records, comparisons, has_reference, eval_seeds, seeds, window, reps, shared
    )


def _cl_comparisons(
    metrics: Mapping[str, Mapping[int, RunMetrics]],
    variants: list[str],
    has_reference: bool,
    reps: int,
    seed: int,
) -> list[tuple[str, int, Comparison]]:
    """Every variant against :data:`CL_BASELINE` per task on FT and normalised AUC, paired by
    seed over the seeds both hold a value for (at least 2), Holm-corrected together."""
    if CL_BASELINE not in metrics:
        return []
    base = metrics[CL_BASELINE]
    keys = [("FT", "forward_transfer")] if has_reference else []
    keys.append(("AUC normalised", "auc_normalised"))
    found: list[tuple[str, int, Comparison]] = []
    for v in variants:
        if v == CL_BASELINE:
            continue
        envs = [t.env_id for t in next(iter(metrics[v].values())).tasks]
        for i, env in enumerate(envs):
            where = env if envs.count(env) == 1 else f"{env} (task {i + 1})"
            for label, key in keys:
                pairs = []
                for s in sorted(set(metrics[v]) & set(base)):
                    same = i < len(base[s].tasks) and base[s].tasks[i].env_id == env
                    a = _run_values(metrics[v][s], key, i)
                    b = _run_values(base[s], key, i) if same else None
                    if a is not None and b is not None:
                        pairs.append((a, b))
                if len(pairs) < 2:
                    continue
                a_vals, b_vals = zip(*pairs, strict=True)
                c = compare(
                    v,
                    a_vals,
                    CL_BASELINE,
                    b_vals,
                    delta=RETURN_MARGIN_FRACTION,
                    reps=reps,
                    seed=seed,
                    task=where,
                )
                found.append((label, i, c))
    adjusted = holm_table([c for _, _, c in found])
    return [(m, i, c) for (m, i, _), c in zip(found, adjusted, strict=True)]
