"""Tables 3.2-3.5 and the extended continual table from saved BIARM runs (SPEC §1.7, §6).

Pure functions of ``{variant: {seed: summary}}`` (what :func:`evodevo.neuromod.compare.collect`
returns): each table is a header and rows of strings, with the thesis' numbers beside ours,
seeds and paired differences stated; :data:`TABLES` names every table a report holds and
:func:`report_tables` picks those the runs can fill. The SPEC §6 continual-learning metrics
table is :mod:`evodevo.neuromod.continual_table`; the text helpers are
:mod:`evodevo.neuromod.table_format`. Writing files is :mod:`evodevo.neuromod.compare`'s job.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.neuromod.evaluation import improvement, retention
from evodevo.neuromod.forgetting import forgetting
from evodevo.neuromod.table_format import (
    csv_text,
    format_seeds,
    pm,
    table_markdown,
    variant_order,
)
from evodevo.neuromod.thesis_numbers import TABLE_3_2, TABLE_3_3_MS, TABLE_3_4, TABLE_3_5
from evodevo.runs import read_json
from evodevo.seed_split import range_label
from evodevo.stats import permutation_test, summarise

__all__ = [
    "ABLATIONS",
    "BENCHMARK_OVERHEAD",
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


def seeds_sentence(runs: Mapping[str, Mapping[int, Any]]) -> str:
    """The finished seeds of every variant, variants with the same seeds grouped."""
    groups: dict[str, list[str]] = {}
    for v in variant_order(runs):
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
                pm(*th["pnn"]) if th else "—",
                pm(*th["biarm"]) if th else "—",
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
            ours.append(pm(s.mean, s.std) + f" (n={s.n})")
        th = TABLE_3_4.get(env, {})
        rows.append([env, *ours, *[pm(*th[v]) if v in th else "—" for v in variants]])
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
                    pm(ini.mean, ini.std),
                    pm(fin.mean, fin.std),
                    "undefined" if math.isnan(ret) else f"{100 * ret:.2f} %",
                    pm(*th[0]) if th else "—",
                    pm(*th[1]) if th else "—",
                    f"{100 * th[2]:.2f} %" if th else "—",
                ]
            )
    return header, rows


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
    for v in variant_order(runs):
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
                else pm(r["forgetting_mean"], r["forgetting_std"]),
                "—"
                if math.isnan(r["thesis_final_mean"])
                else pm(r["thesis_final_mean"], r["thesis_final_std"]),
                "—"
                if math.isnan(r["thesis_retention"])
                else f"{100 * r['thesis_retention']:.2f} %",
            ]
        )
    return header, rows


def _cell(record: Mapping[str, Any], key: str, ci: bool = False) -> str:
    """``mean ± std`` (and ``[lo, hi]``) of ``record[key + '_mean']`` etc., two decimals."""
    cell = pm(record[f"{key}_mean"], record[f"{key}_std"])
    if ci:
        cell += f" [{record[f'{key}_ci_low']:.2f}, {record[f'{key}_ci_high']:.2f}]"
    return cell


def continual_csv(runs: dict[str, dict[int, dict[str, Any]]]) -> str:
    """:func:`continual_records` as CSV (numbers unformatted; nan where undefined)."""
    records = continual_records(runs)
    header = list(records[0]) if records else []
    return csv_text(header, [[r[k] for k in header] for r in records])


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
