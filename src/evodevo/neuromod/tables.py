"""Tables 3.2-3.5, the extended continual table and the continual-learning metrics table from
saved BIARM runs (SPEC §1.7, §6).

Pure functions of ``{variant: {seed: summary}}`` (what :func:`evodevo.neuromod.compare.collect`
returns): each table is a header and rows of strings, with the thesis' numbers beside ours,
seeds and paired differences stated; :data:`TABLES` names every table a report holds and
:func:`report_tables` picks those the runs can fill. :func:`continual_table` summarises the
per-run metrics of SPEC §6 (:mod:`evodevo.neuromod.continual_metrics`: AUC, forward transfer,
forgetting, backward transfer, episodes to threshold) over runs, with run-level intervals and
paired verdicts from :mod:`evodevo.evidence`. Writing files is
:mod:`evodevo.neuromod.compare`'s job.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.evidence.aggregate import DEFAULT_REPS, Estimate, interval_estimates
from evodevo.evidence.normalise import RETURN_MARGIN_FRACTION
from evodevo.evidence.verdict import Comparison, compare, holm_table
from evodevo.neuromod.continual_metrics import WINDOW, RunMetrics
from evodevo.neuromod.evaluation import improvement, retention
from evodevo.neuromod.forgetting import forgetting
from evodevo.neuromod.thesis_numbers import TABLE_3_2, TABLE_3_3_MS, TABLE_3_4, TABLE_3_5
from evodevo.neuromod.variants import VARIANTS
from evodevo.runs import read_json
from evodevo.seed_split import range_label
from evodevo.stats import summarise

__all__ = [
    "ABLATIONS",
    "BENCHMARK_OVERHEAD",
    "CL_BASELINE",
    "CL_RUN_METRICS",
    "CL_TASK_METRICS",
    "ContinualTable",
    "continual_runs_csv",
    "continual_table",
    "STATS_NOTE",
    "TABLES",
    "budget_paragraph",
    "continual_csv",
    "continual_records",
    "finals_by_seed",
    "fmt_difference",
    "format_seeds",
    "paired_difference",
    "report_tables",
    "run_dir_name",
    "run_facts",
    "seeds_sentence",
    "table_continual",
    "table_markdown",
]

ABLATIONS = ("no-da", "no-5ht", "no-ne", "no-ach")


def run_dir_name(variant: str, seed: int) -> str:
    """``{variant}__s{seed}``: a run's folder under a grid's ``runs/``."""
    return f"{variant}__s{seed}"


# ---------------------------------------------------------------------------- helpers
def _env_ids(runs: dict[str, dict[int, dict[str, Any]]]) -> list[str]:
    first = next(iter(next(iter(runs.values())).values()))
    return [t["env_id"] for t in first["tasks"]]


def _values(runs: dict[int, dict[str, Any]], env: str, key: str) -> list[float]:
    out = []
    for s in sorted(runs):
        for t in runs[s]["tasks"]:
            if t["env_id"] == env:
                out.append(float(t[key]))
    return out


def _pm(mean: float, std: float, digits: int = 2) -> str:
    return f"{mean:.{digits}f} ± {std:.{digits}f}"


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _csv(header: list[str], rows: list[list[Any]]) -> str:
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


#: What every BIARM table's intervals and tests are (SPEC §6), stated once per report.
STATS_NOTE = (
    "Mean ± std over seeds; intervals are 95 % bootstrap intervals of the mean over seeds "
    "(10,000 resamples); paired tests are exact sign-flip tests over seeds."
)

#: BIARM / PNN time per training step measured by ``benchmarks/biarm_overhead.py --json`` (one
#: process, each agent in its own interleaved pass, process CPU time), per task the range over
#: the four runs in docs/results/biarm.md, "Speed", 2026-12-02 (third session); the whole
#: sequence measured 1.114-1.141 there. Cited beside Table 3.3, whose ratios are measured while
#: training, several runs sharing the machine's cores.
BENCHMARK_OVERHEAD: dict[str, tuple[float, float]] = {
    "CartPole-v1": (1.03, 1.06),
    "Acrobot-v1": (1.10, 1.21),
    "MountainCar-v0": (1.15, 1.18),
    "LunarLander-v3": (1.11, 1.17),
}
BENCHMARK_SOURCE = "`benchmarks/biarm_overhead.py`, docs/results/biarm.md (Speed)"


def format_seeds(seeds: Sequence[int]) -> str:
    """Seeds as compact ranges: ``[0, 1, 2, 3, 4, 7]`` -> ``"0-4, 7"``."""
    parts: list[str] = []
    ordered = sorted(set(int(s) for s in seeds))
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        parts.append(str(ordered[i]) if j == i else f"{ordered[i]}-{ordered[j]}")
        i = j + 1
    return ", ".join(parts)


def seeds_sentence(runs: Mapping[str, Mapping[int, Any]]) -> str:
    """The finished seeds of every variant, variants with the same seeds grouped."""
    groups: dict[str, list[str]] = {}
    for v in _variant_order(runs):
        groups.setdefault(format_seeds(list(runs[v])), []).append(v)
    if len(groups) == 1:
        ((seeds, variants),) = groups.items()
        return f"seeds {seeds} for every variant ({len(runs[variants[0]])} each)"
    return "seeds " + "; ".join(f"{s} ({', '.join(vs)})" for s, vs in groups.items())


def run_facts(
    runs: Mapping[str, Mapping[int, Mapping[str, Any]]], folder: Path | None = None
) -> dict[str, str]:
    """What a grid's runs share besides their seeds, as text: ``episodes`` per task,
    ``model`` (module learning, adapter width), ``evaluation`` and ``machine``.

    Read from the first run's ``summary.json`` and, when ``folder`` (the grid folder) holds its
    ``config.json``, the episodes scale and the machine; a fact not recorded is left out.
    """
    variant = next(iter(runs))
    seed = min(runs[variant])
    s = runs[variant][seed]
    saved: dict[str, Any] = {}
    if folder is not None:
        cfg_path = folder / "runs" / run_dir_name(variant, seed) / "config.json"
        if cfg_path.is_file():
            saved = read_json(cfg_path)
    facts = {
        "episodes": "episodes per task "
        + ", ".join(f"{t['env_id']} {t['episodes']}" for t in s["tasks"])
    }
    scale = saved.get("config", {}).get("episodes_scale")
    if scale is not None:
        facts["episodes"] += f" (episodes_scale {scale})"
    if s.get("module_learning") is not None:
        facts["model"] = (
            f"module learning `{s.get('module_learning')}`, adapter_dim {s.get('adapter_dim')}"
        )
    ev = s.get("eval_seeds")
    if ev:
        facts["evaluation"] = (
            f"{len(ev)} greedy evaluation episodes per task (seeds {ev[0]}..{ev[-1]}: the "
            f"{range_label(ev[0], len(ev))} range, SPEC §6)"
        )
    m = saved.get("machine")
    if m:
        facts["machine"] = f"{m.get('processor')}, {m.get('cpus')} CPUs, {m.get('platform')}"
    return facts


def budget_paragraph(
    runs: Mapping[str, Mapping[int, Mapping[str, Any]]], folder: Path | None = None
) -> str:
    """Budget, seeds, evaluation and machine of a grid in one paragraph (SPEC §6)."""
    f = run_facts(runs, folder)
    parts = [f[k] for k in ("episodes", "model", "evaluation") if k in f]
    text = "Budget: " + "; ".join([*parts, seeds_sentence(runs)]) + "."
    if "machine" in f:
        text += f" Machine: {f['machine']}."
    return text + " " + STATS_NOTE


# ---------------------------------------------------------------------------- tables
def paired_difference(
    a: Mapping[int, float], b: Mapping[int, float]
) -> tuple[float, float, int, int] | None:
    """``a − b`` paired by seed over the seeds both have: (mean difference, exact two-sided
    sign-flip p, seeds where ``a`` is higher, shared seeds); None without a shared seed.

    Seeds are the unit (SPEC §6); with n shared seeds p cannot go below ``2 / 2**n``.
    """
    from evodevo.stats import permutation_test

    seeds = sorted(set(a) & set(b))
    if not seeds:
        return None
    x = np.array([a[s] for s in seeds], dtype=float)
    y = np.array([b[s] for s in seeds], dtype=float)
    p = 1.0 if np.array_equal(x, y) else permutation_test(x, y, paired=True)
    return float((x - y).mean()), float(p), int((x > y).sum()), len(seeds)


def finals_by_seed(runs: Mapping[int, Mapping[str, Any]], env: str) -> dict[int, float]:
    """Seed -> final greedy return on ``env`` of one variant's runs."""
    out = {}
    for seed, s in runs.items():
        for t in s["tasks"]:
            if t["env_id"] == env:
                out[int(seed)] = float(t["final_return"])
    return out


def fmt_difference(pair: tuple[float, float, int, int] | None) -> str:
    """``+301.3 (p = 0.062; higher on 5/5 seeds)`` or ``—`` without a shared seed."""
    if pair is None:
        return "—"
    d, p, k, n = pair
    return f"{d:+.2f} (p = {p:.2g}; higher on {k}/{n} seeds)"


def table_3_2(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """PNN vs BIARM final returns, BIARM − PNN paired by seed, thesis beside.

    Ours is a difference in return (mean over seeds of the per-seed difference, exact sign-flip
    p, seeds where BIARM is higher), not a percentage of a PNN mean that may be negative; the
    thesis' improvement (``(BIARM − PNN) / |PNN|`` of its means, SPEC §1.7) is shown as printed.
    """
    header = [
        "Environment",
        "PNN (ours)",
        "BIARM (ours)",
        "BIARM − PNN (ours, paired by seed)",
        "PNN (thesis)",
        "BIARM (thesis)",
        "BIARM − PNN (thesis means)",
        "Improvement (thesis, as printed: % of abs(PNN))",
    ]
    rows = []
    for env in _env_ids(runs):
        p = summarise(_values(runs.get("pnn", {}), env, "final_return"))
        b = summarise(_values(runs.get("biarm", {}), env, "final_return"))
        pair = paired_difference(
            finals_by_seed(runs.get("biarm", {}), env), finals_by_seed(runs.get("pnn", {}), env)
        )
        th = TABLE_3_2.get(env)
        rows.append(
            [
                env,
                p.fmt(2) + f" (n={p.n})" if p.n else "—",
                b.fmt(2) + f" (n={b.n})" if b.n else "—",
                fmt_difference(pair),
                _pm(*th["pnn"]) if th else "—",
                _pm(*th["biarm"]) if th else "—",
                f"{th['biarm'][0] - th['pnn'][0]:+.2f}" if th else "—",
                f"{improvement(th['biarm'][0], th['pnn'][0]):+.2f} %" if th else "—",
            ]
        )
    return header, rows


def table_3_3(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """Median µs per training step measured while training (mean over seeds), the ratio to
    PNN, the benchmark's BIARM / PNN (:data:`BENCHMARK_OVERHEAD`) and the thesis' times."""
    variants = [v for v in ("pnn", "biarm", *ABLATIONS) if v in runs]
    header = ["Environment", *[f"{v} µs" for v in variants]]
    if "pnn" in runs:
        header += [f"{v}/pnn" for v in variants if v != "pnn"]
    header += ["biarm/pnn, benchmark", "thesis PNN / BIARM ms", "thesis overhead"]
    rows = []
    for env in _env_ids(runs):
        means = {v: float(np.nanmean(_values(runs[v], env, "us_per_step"))) for v in variants}
        row = [env, *[f"{means[v]:.0f}" for v in variants]]
        if "pnn" in runs:
            row += [f"{means[v] / means['pnn']:.3f}" for v in variants if v != "pnn"]
        bench = BENCHMARK_OVERHEAD.get(env)
        row.append(f"{bench[0]:.2f}-{bench[1]:.2f}" if bench else "—")
        th = TABLE_3_3_MS.get(env)
        row += (
            [f"{th[0]:.2f} / {th[1]:.2f}", f"+{100 * (th[1] / th[0] - 1):.0f} %"]
            if th
            else ["—", "—"]
        )
        rows.append(row)
    return header, rows


def table_3_4(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """Full BIARM vs the four ablations (final return), thesis beside."""
    variants = [v for v in ("biarm", *ABLATIONS) if v in runs]
    header = [
        "Environment",
        *[f"{v} (ours)" for v in variants],
        *[f"{v} (thesis)" for v in variants],
    ]
    rows = []
    for env in _env_ids(runs):
        ours = []
        for v in variants:
            s = summarise(_values(runs[v], env, "final_return"))
            ours.append(_pm(s.mean, s.std) + f" (n={s.n})")
        th = TABLE_3_4.get(env, {})
        rows.append([env, *ours, *[_pm(*th[v]) if v in th else "—" for v in variants]])
    return header, rows


def table_3_5(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """Initial vs final returns and retention (of the means) of the models the thesis' Table 3.5
    reports (BIARM and PNN), thesis beside; every variant's is in :func:`table_continual`."""
    header = [
        "Environment",
        "Model",
        "Initial (ours)",
        "Final (ours)",
        "Retention (ours)",
        "Initial (thesis)",
        "Final (thesis)",
        "Retention (thesis)",
    ]
    rows = []
    variants = [v for v in ("biarm", "pnn") if v in runs]
    for env in _env_ids(runs):
        for v in variants:
            ini = summarise(_values(runs[v], env, "initial_return"))
            fin = summarise(_values(runs[v], env, "final_return"))
            ret = retention(ini.mean, fin.mean)
            th = TABLE_3_5.get(env, {}).get(v)
            rows.append(
                [
                    env,
                    v,
                    _pm(ini.mean, ini.std),
                    _pm(fin.mean, fin.std),
                    "undefined" if math.isnan(ret) else f"{100 * ret:.2f} %",
                    _pm(*th[0]) if th else "—",
                    _pm(*th[1]) if th else "—",
                    f"{100 * th[2]:.2f} %" if th else "—",
                ]
            )
    return header, rows


def _variant_order(runs: Mapping[str, Any]) -> list[str]:
    """Known variants in their table order, then any other name found, sorted."""
    known = [v for v in VARIANTS if v in runs]
    return known + sorted(v for v in runs if v not in VARIANTS)


def _thesis_final(variant: str, env: str) -> tuple[float, float] | None:
    """The thesis' final return (Table 3.2, or 3.4 for the ablations), if it reports one."""
    if variant in ("pnn", "biarm") and env in TABLE_3_2:
        return TABLE_3_2[env][variant]
    return TABLE_3_4.get(env, {}).get(variant)


def _forgetting_values(runs: dict[int, dict[str, Any]], env: str) -> list[float]:
    """Eq. 1.4 per seed for task ``env`` (nan for the sequence's last task)."""
    out = []
    for s in sorted(runs):
        tasks = runs[s]["tasks"]
        for i, t in enumerate(tasks):
            if t["env_id"] == env:
                out.append(forgetting(t, last=i == len(tasks) - 1))
    return out


def continual_records(runs: dict[str, dict[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """One numeric record per (variant, task): the data of the extended Table 3.2/3.5.

    Final and initial returns are mean, std (ddof 1) and 95 % bootstrap interval over seeds
    (:func:`evodevo.stats.summarise`); retention is that of the means (SPEC §1.7, as Table
    3.5); forgetting is Eq. 1.4 per seed, then summarised over seeds (nan for the last task,
    which nothing follows). The thesis columns are nan where the thesis reports nothing.
    """
    records = []
    for v in _variant_order(runs):
        for env in _env_ids({v: runs[v]}):
            ini = summarise(_values(runs[v], env, "initial_return"))
            fin = summarise(_values(runs[v], env, "final_return"))
            forg_vals = _forgetting_values(runs[v], env)
            forg = (
                summarise(forg_vals) if not any(math.isnan(x) for x in forg_vals) else summarise([])
            )
            th_final = _thesis_final(v, env)
            th_ret = TABLE_3_5.get(env, {}).get(v)
            episodes = sorted({int(t["episodes"]) for t in _tasks_of(runs[v], env)})
            records.append(
                {
                    "variant": v,
                    "env_id": env,
                    "n_seeds": fin.n,
                    "seeds": " ".join(str(s) for s in sorted(runs[v])),
                    "episodes": " ".join(str(e) for e in episodes),
                    "initial_mean": ini.mean,
                    "initial_std": ini.std,
                    "final_mean": fin.mean,
                    "final_std": fin.std,
                    "final_ci_low": fin.ci_low,
                    "final_ci_high": fin.ci_high,
                    "retention": retention(ini.mean, fin.mean),
                    "forgetting_mean": forg.mean,
                    "forgetting_std": forg.std,
                    "forgetting_ci_low": forg.ci_low,
                    "forgetting_ci_high": forg.ci_high,
                    "thesis_final_mean": th_final[0] if th_final else math.nan,
                    "thesis_final_std": th_final[1] if th_final else math.nan,
                    "thesis_retention": th_ret[2] if th_ret else math.nan,
                }
            )
    return records


def _tasks_of(runs: dict[int, dict[str, Any]], env: str) -> list[dict[str, Any]]:
    return [t for s in sorted(runs) for t in runs[s]["tasks"] if t["env_id"] == env]


def table_continual(
    runs: dict[str, dict[int, dict[str, Any]]],
) -> tuple[list[str], list[list[str]]]:
    """Extended Tables 3.2/3.5: every variant found, per task (Markdown cells)."""
    header = [
        "Model",
        "Environment",
        "Seeds",
        "Final return (ours) mean ± std [95 % CI]",
        "Initial (ours)",
        "Retention (ours)",
        "Forgetting Eq. 1.4 (ours)",
        "Final (thesis)",
        "Retention (thesis)",
    ]
    rows = []
    for r in continual_records(runs):
        ret = r["retention"]
        rows.append(
            [
                r["variant"],
                r["env_id"],
                str(r["n_seeds"]),
                _cell(r, "final", ci=True),
                _cell(r, "initial"),
                "undefined" if math.isnan(ret) else f"{100 * ret:.2f} %",
                "— (last task)"
                if math.isnan(r["forgetting_mean"])
                else _pm(r["forgetting_mean"], r["forgetting_std"]),
                "—"
                if math.isnan(r["thesis_final_mean"])
                else _pm(r["thesis_final_mean"], r["thesis_final_std"]),
                "—"
                if math.isnan(r["thesis_retention"])
                else f"{100 * r['thesis_retention']:.2f} %",
            ]
        )
    return header, rows


def _cell(record: Mapping[str, Any], key: str, ci: bool = False) -> str:
    """``mean ± std`` (and ``[lo, hi]``) of ``record[key + '_mean']`` etc., two decimals."""
    cell = _pm(record[f"{key}_mean"], record[f"{key}_std"])
    if ci:
        cell += f" [{record[f'{key}_ci_low']:.2f}, {record[f'{key}_ci_high']:.2f}]"
    return cell


def continual_csv(runs: dict[str, dict[int, dict[str, Any]]]) -> str:
    """:func:`continual_records` as CSV (numbers unformatted; nan where undefined)."""
    records = continual_records(runs)
    header = list(records[0]) if records else []
    return _csv(header, [[r[k] for k in header] for r in records])


#: name -> (title, one-line caption, table function) of every table a grid's report holds.
TABLES = {
    "table_3_2": (
        "Table 3.2 — final return, PNN vs BIARM",
        "Final greedy return per task, mean ± std [95 % CI] over seeds. BIARM − PNN is a "
        "difference in return, the mean over seeds of the per-seed difference, with its exact "
        "sign-flip p and the seeds on which BIARM is higher; the thesis' improvement is a "
        "percentage of its PNN mean (SPEC §1.7), shown as printed.",
        table_3_2,
    ),
    "table_3_3": (
        "Table 3.3 — µs per training step, measured while training",
        "Median wall-clock µs per training step inside each training run, mean over seeds, "
        "with several runs of the grid sharing the machine's cores at once: these ratios carry "
        "that contention. The method's overhead is the benchmark's BIARM / PNN (one process, "
        f"interleaved, process CPU time; per-task range over its runs, {BENCHMARK_SOURCE}).",
        table_3_3,
    ),
    "table_3_4": (
        "Table 3.4 — ablations (final return)",
        "Final greedy return per task of the full BIARM and each module ablation, mean ± std "
        "over seeds, the thesis' Table 3.4 beside.",
        table_3_4,
    ),
    "table_3_5": (
        "Table 3.5 — initial vs final return and retention, the thesis' models",
        "Greedy return after each task's own training (initial) and after the whole sequence "
        "(final), mean ± std over seeds, and retention of the means (SPEC §1.7), for the two "
        "models the thesis reports; every variant's is in the extended table.",
        table_3_5,
    ),
    "table_continual": (
        "Extended Tables 3.2/3.5 — every variant: final return, retention, forgetting (Eq. 1.4)",
        "Every variant found: final and initial greedy return, retention of the seed means, and "
        "forgetting (Eq. 1.4: max over k of Acc(i,k) − Acc(i,T), per seed, then mean ± std); "
        "sb3-dqn trains a separate model per task, so it cannot forget.",
        table_continual,
    ),
}


def report_tables(
    runs: dict[str, dict[int, dict[str, Any]]],
) -> list[tuple[str, str, str, list[str], list[list[str]]]]:
    """``(name, title, caption, header, rows)`` of every table the grid's runs can fill."""
    out = []
    for name, (title, caption, fn) in TABLES.items():
        if name in ("table_3_2", "table_3_5") and not ({"pnn", "biarm"} & set(runs)):
            continue
        if name == "table_3_4" and not (set(ABLATIONS) & set(runs)):
            continue
        header, rows = fn(runs)
        out.append((name, title, caption, header, rows))
    return out


def table_markdown(caption: str, header: list[str], rows: list[list[str]]) -> str:
    """A table under its one-line caption."""
    return f"{caption}\n\n" + _md_table(header, rows)


# ---------------------------------------------------------------------------- SPEC §6 metrics
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
        parts += [_md_table(header, rows).rstrip(), ""]
        parts += [
            "Over the sequence, per run: backward transfer (GEM) BWT = mean over tasks before "
            "the last of R(T,i) − R(i,i) on normalised greedy returns (clipped to [0, 1], so a "
            "drop that stays above the solved threshold does not count; negative is forgetting)"
            + (", and FT averaged over the tasks" if self.has_reference else "")
            + "; mean over runs [95 % bootstrap interval].",
            "",
            _md_table(seq_header, seq_rows).rstrip(),
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
        return _csv(header, [[r[k] for k in header] for r in self.records])

    def comparisons_csv(self) -> str:
        """:attr:`comparisons` as CSV, one row each."""
        header = ["metric", "task", "env_id", "a", "b", "n", "mean_diff", "ci_low", "ci_high"]
        header += ["std_diff", "p", "p_holm", "delta", "mde", "verdict", "runs_needed", "test"]
        rows = [
            [m, i, c.task, c.a, c.b, c.n, c.mean_diff, c.low, c.high, c.std_diff, c.p, c.p_adj]
            + [c.delta, c.mde, c.verdict, "" if c.runs_needed is None else c.runs_needed, c.test]
            for m, i, c in self.comparisons
        ]
        return _csv(header, rows)


def continual_runs_csv(metrics: Mapping[str, Mapping[int, RunMetrics]]) -> str:
    """Every run's metrics, one row per (run, task): the data behind :class:`ContinualTable`."""
    header = ["variant", "seed", "task", "env_id", "episodes", "auc", "auc_normalised"]
    header += ["forward_transfer", "reference", "initial_return", "final_return", "forgetting"]
    header += ["threshold", "episodes_to_threshold", "backward_transfer", "run_dir"]
    rows = []
    for v in _variant_order(metrics):
        for seed in sorted(metrics[v]):
            run = metrics[v][seed]
            for t in run.tasks:
                values = [v, seed, t.index, t.env_id, t.episodes, t.auc, t.auc_normalised]
                values += [t.forward_transfer, t.reference, t.initial_return, t.final_return]
                values += [t.forgetting, t.threshold, t.episodes_to_threshold]
                values += [run.backward_transfer, run.run_dir]
                rows.append(["" if x is None else x for x in values])
    return _csv(header, rows)


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
    variants = _variant_order(metrics)
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
