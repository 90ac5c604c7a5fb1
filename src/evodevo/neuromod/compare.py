"""The comparison grid and its report files (SPEC §1.7, §6).

:func:`run_grid` trains every (variant, seed) pair in ``DIR/runs/{variant}__s{seed}/`` over a
:class:`~evodevo.parallel.WorkerPool` of local processes or over Ray
(:func:`~evodevo.parallel.make_pool`); finished runs are skipped and interrupted ones resume
from their newest checkpoint, so the grid itself is resumable, and every run's numbers depend
on its variant and seed only, not on where it ran. :func:`write_report` reads the saved run files only and
writes the tables (:mod:`evodevo.neuromod.tables`) as Markdown and CSV next to the figures,
with the thesis' numbers beside ours, and the continual-learning metrics of SPEC §6
(:func:`continual_markdown`: AUC, forward transfer against the ``single`` runs of the grid,
forgetting, backward transfer, episodes to threshold; ``table_cl_metrics.md/.csv``,
``table_cl_paired.csv``, ``table_cl_runs.csv``).
:func:`write_continual_table` (``evodevo compare biarm``) writes the extended Table 3.2/3.5 --
every variant, the continual baselines included, with final return, retention and
the forgetting measure of Eq. 1.4 (:mod:`evodevo.neuromod.forgetting`) -- from any set of run
directories.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import from_dict, to_dict
from evodevo.errors import EvodevoError
from evodevo.evidence.aggregate import DEFAULT_REPS
from evodevo.neuromod.ablation_verdicts import (
    ABLATION_FILE,
    ABLATION_TITLE,
    ablation_comparisons,
    ablation_verdict_markdown,
)
from evodevo.neuromod.aggregate_table import AGGREGATE_TITLE, PROFILE_FIGURE, aggregate_markdown
from evodevo.neuromod.checkpoint import latest_resume_point
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.continual_metrics import RunMetrics, grid_metrics
from evodevo.neuromod.continual_table import ContinualTable, continual_runs_csv, continual_table
from evodevo.neuromod.figures import draw_all
from evodevo.neuromod.final_verdicts import (
    FINAL_FILE,
    FINAL_TITLE,
    final_return_comparisons,
    final_verdict_csv,
    final_verdict_markdown,
)
from evodevo.neuromod.run_scores import RUN_SCORES_FILE, run_scores, run_scores_csv
from evodevo.neuromod.table_format import (
    csv_text,
    format_seeds,
    md_table,
    table_markdown,
    variant_order,
)
from evodevo.neuromod.tables import (
    ABLATIONS,
    BENCHMARK_OVERHEAD,
    STATS_NOTE,
    TABLES,
    budget_paragraph,
    continual_csv,
    continual_records,
    finals_by_seed,
    fmt_difference,
    paired_difference,
    report_tables,
    run_dir_name,
    run_facts,
    seeds_sentence,
    table_continual,
)
from evodevo.neuromod.tasks import resolve_tasks
from evodevo.neuromod.trainer import train
from evodevo.neuromod.variants import get_variant
from evodevo.parallel import make_pool
from evodevo.runs import RunDir, atomic_write_text, make_dir, read_json, write_json
from evodevo.stats import permutation_test, summarise
from evodevo.trainers import Trainer, get_trainer

__all__ = [
    "GRID_FILE",
    "grid_progress",
    "record_grid",
    "run_grid",
    "run_dir_name",
    "collect",
    "collect_dirs",
    "run_folders",
    "CL_TITLE",
    "continual_markdown",
    "write_report",
    "report_tables",
    "table_markdown",
    "budget_paragraph",
    "run_facts",
    "seeds_sentence",
    "format_seeds",
    "paired_difference",
    "finals_by_seed",
    "fmt_difference",
    "STATS_NOTE",
    "BENCHMARK_OVERHEAD",
    "write_continual_table",
    "table_continual",
    "continual_records",
    "ABLATIONS",
]


def _run_item(item: tuple[str, int, dict[str, Any], str, Trainer | None]) -> str:
    """Worker body: train one (variant, seed) into its folder, resuming if interrupted.

    The item carries the trainer of a variant that :func:`~evodevo.neuromod.trainer.train`
    does not run itself (resolved by the parent; pickled by reference, so the worker imports
    its module)."""

    variant, seed, cfg_dict, out, trainer = item
    cfg = from_dict(BiarmConfig, cfg_dict)
    resume = latest_resume_point(Path(out) / "checkpoints") is not None
    if trainer is None:
        train(cfg, variant, seed, out, resume=resume)
    else:  # called as train calls it (evodevo.trainers)
        trainer(cfg, get_variant(variant), seed, out, resume)
    return out


def run_grid(
    cfg: BiarmConfig,
    variants: Sequence[str],
    seeds: Sequence[int],
    out: str | Path,
    workers: int = 1,
    backend: str = "local",
    address: str | None = None,
) -> list[str]:
    """Train the missing runs of the grid; returns the run folders that were (re)run.

    Args:
        cfg: the config every run shares.
        variants: variant names.
        seeds: run seeds.
        out: the grid folder (runs go to ``out/runs/{variant}__s{seed}``).
        workers: parallel runs (processes, or Ray actors of one CPU each).
        backend: ``"local"`` (process pool) or ``"ray"``; the numbers are the same.
        address: Ray cluster (``"auto"`` or ``HOST:PORT``); None starts a private local Ray.
            On a cluster, ``out`` must be a path every node sees (a shared file system).
    """

    trainers = {v: get_trainer(get_variant(v).architecture) for v in variants}
    resolve_tasks(cfg)  # every input error before any worker starts
    root = Path(out)
    make_dir(root / "runs")
    record_grid(root, [run_dir_name(v, s) for v in variants for s in seeds])
    cfg_dict = to_dict(cfg)
    items = []
    for v in variants:
        for s in seeds:
            folder = root / "runs" / run_dir_name(v, s)
            if (folder / "summary.json").is_file():
                continue
            items.append((v, int(s), cfg_dict, str(folder), trainers[v]))
    if not items:
        return []
    with make_pool(backend, min(workers, len(items)), address=address) as pool:
        return list(pool.map(_run_item, items))


GRID_FILE = "grid.json"
"""``DIR/grid.json``: ``{"runs": [...]}``, every run folder ``biarm compare`` was asked for in
this grid (the union over its calls). ``evodevo reproduce`` counts a compare step done only
when each of them has a ``summary.json``, so tables drawn from a partial grid (``biarm
report``) do not mark it finished."""


def record_grid(root: Path, names: Sequence[str]) -> None:
    """Add ``names`` to the runs requested in ``root/grid.json`` (see :data:`GRID_FILE`)."""
    path = root / GRID_FILE
    known: list[str] = list(read_json(path).get("runs", [])) if path.is_file() else []
    runs = known + [n for n in names if n not in known]
    if runs != known or not path.is_file():
        write_json(path, {"runs": runs})


def grid_progress(root: str | Path) -> tuple[int, int] | None:
    """(finished, requested) runs of the grid in ``root``, or None without ``grid.json``."""
    path = Path(root) / GRID_FILE
    if not path.is_file():
        return None
    runs = read_json(path).get("runs", [])
    done = sum((Path(root) / "runs" / n / "summary.json").is_file() for n in runs)
    return done, len(runs)


def collect(out: str | Path) -> dict[str, dict[int, dict[str, Any]]]:
    """``{variant: {seed: summary}}`` of every finished run under ``DIR/runs``."""
    root = Path(out) / "runs"
    if not root.is_dir():
        raise EvodevoError(f"{str(root)!r} does not exist; run `evodevo biarm compare` first")
    found: dict[str, dict[int, dict[str, Any]]] = {}
    for folder in sorted(root.iterdir()):
        p = folder / "summary.json"
        if p.is_file():
            s = read_json(p)
            found.setdefault(s["variant"], {})[int(s["seed"])] = s
    if not found:
        raise EvodevoError(f"no finished run under {str(root)!r}; nothing to report")
    return found


def run_folders(out: str | Path) -> dict[str, dict[int, Path]]:
    """``{variant: {seed: folder}}`` of every finished run under ``DIR/runs`` (as :func:`collect`)."""
    root = Path(out) / "runs"
    if not root.is_dir():
        raise EvodevoError(f"{str(root)!r} does not exist; run `evodevo biarm compare` first")
    found: dict[str, dict[int, Path]] = {}
    for folder in sorted(root.iterdir()):
        p = folder / "summary.json"
        if p.is_file():
            s = read_json(p)
            found.setdefault(str(s["variant"]), {})[int(s["seed"])] = folder
    return found


#: Heading of the continual-learning metrics in every BIARM report.
CL_TITLE = "Continual-learning metrics (SPEC §6)"


def _continual(
    out: str | Path, reps: int
) -> tuple[dict[str, dict[int, RunMetrics]], ContinualTable]:
    metrics = grid_metrics(run_folders(out))
    return metrics, continual_table(metrics, reps=reps)


def continual_markdown(out: str | Path, reps: int = DEFAULT_REPS) -> str:
    """The continual-learning metrics of a grid folder as Markdown captions and tables
    (:class:`~evodevo.neuromod.continual_table.ContinualTable`), or one line saying why there are none
    (e.g. a run folder without ``metrics.csv``)."""
    try:
        return _continual(out, reps)[1].markdown()
    except EvodevoError as exc:
        return f"(no continual-learning metrics: {exc})\n"


def write_report(out: str | Path, figures: bool = True, reps: int = DEFAULT_REPS) -> Path:
    """Write ``table_3_*.md/.csv``, ``table_continual.md/.csv``, ``table_final_verdicts.md/.csv``
    (each variant against pnn on the final return, with a verdict), with module ablations
    ``table_ablation_verdicts.md/.csv`` (biarm against each, E5's rule), ``table_run_scores.csv``
    (one row of per-run scores, :mod:`~evodevo.neuromod.run_scores`), ``table_aggregates.md`` (IQM,
    probability of improvement, performance profiles), ``table_cl_metrics.md/.csv``
    (with ``table_cl_paired.csv`` and ``table_cl_runs.csv``), ``report.md`` and (optionally)
    the figures into ``out``.

    ``report.md`` states the budget, seeds and machine once at its top and gives each table a
    one-line caption; each ``table_*.md`` file, read on its own, carries the budget too.
    ``reps``: bootstrap resamples of the continual-learning intervals and comparisons.
    """
    root = Path(out)
    runs = collect(root)
    budget = budget_paragraph(runs, root)
    parts = ["# BIARM comparison\n", budget + "\n"]
    for name, title, caption, header, rows in report_tables(runs):
        body = table_markdown(caption, header, rows)
        atomic_write_text(root / f"{name}.md", f"## {title}\n\n{body}\n{budget}\n")
        text = continual_csv(runs) if name == "table_continual" else csv_text(header, rows)
        atomic_write_text(root / f"{name}.csv", text)
        parts.append(f"## {title}\n\n{body}")
    verdicts = final_return_comparisons(runs, reps=reps)
    body = final_verdict_markdown(verdicts)
    atomic_write_text(root / f"{FINAL_FILE}.md", f"## {FINAL_TITLE}\n\n{body}\n{budget}\n")
    atomic_write_text(root / f"{FINAL_FILE}.csv", final_verdict_csv(verdicts))
    parts.append(f"## {FINAL_TITLE}\n\n{body}")
    cells = ablation_comparisons(runs, reps=reps)
    if cells:
        body = ablation_verdict_markdown(cells)
        text = f"## {ABLATION_TITLE}\n\n{body}\n{budget}\n"
        atomic_write_text(root / f"{ABLATION_FILE}.md", text)
        atomic_write_text(root / f"{ABLATION_FILE}.csv", final_verdict_csv(cells))
        parts.append(f"## {ABLATION_TITLE}\n\n{body}")
    agg = aggregate_markdown(runs, root / PROFILE_FIGURE if figures else None, reps=reps)
    atomic_write_text(root / "table_aggregates.md", f"## {AGGREGATE_TITLE}\n\n{agg}\n{budget}\n")
    parts.append(f"## {AGGREGATE_TITLE}\n\n{agg}")
    metrics: dict[str, dict[int, RunMetrics]] | None = None
    try:
        metrics, cl = _continual(root, reps)
    except EvodevoError as exc:
        parts.append(f"## {CL_TITLE}\n\n(no continual-learning metrics: {exc})\n")
    else:
        body = cl.markdown()
        atomic_write_text(root / "table_cl_metrics.md", f"## {CL_TITLE}\n\n{body}\n{budget}\n")
        atomic_write_text(root / "table_cl_metrics.csv", cl.csv())
        atomic_write_text(root / "table_cl_paired.csv", cl.comparisons_csv())
        atomic_write_text(root / "table_cl_runs.csv", continual_runs_csv(metrics))
        parts.append(f"## {CL_TITLE}\n\n{body}")
    atomic_write_text(root / RUN_SCORES_FILE, run_scores_csv(run_scores(runs, metrics)))
    if figures:
        names = draw_all(root, runs)
        parts.append("## Figures\n\n" + "\n".join(f"![{n}]({n})" for n in names) + "\n")
    report = root / "report.md"
    atomic_write_text(report, "\n".join(parts))
    return report


def contrast_table(dirs: Mapping[str, str | Path], variant: str = "biarm") -> str:
    """Markdown table contrasting one variant run under several settings (e.g. fixed vs learned).

    ``dirs`` maps a label to a ``compare`` output folder. Per task: final return mean ± std
    [95 % bootstrap] of each label over the seeds all labels share, and a paired permutation
    test (sign flips over seeds) between the first two labels.
    """

    labels = list(dirs)
    runs = {lab: collect(d).get(variant, {}) for lab, d in dirs.items()}
    seeds = sorted(set.intersection(*(set(r) for r in runs.values())))
    if not seeds:
        raise EvodevoError(f"no seed of variant {variant!r} finished under every folder")
    first = runs[labels[0]][seeds[0]]
    envs = [t["env_id"] for t in first["tasks"]]
    header = ["Environment", *[f"{lab} final" for lab in labels]]
    header += [f"{lab} µs/step" for lab in labels]
    if len(labels) >= 2:
        header.append(f"paired permutation p ({labels[0]} vs {labels[1]})")
    rows = []
    higher = dict.fromkeys(labels, 0)
    for i, env in enumerate(envs):
        vals = {lab: [runs[lab][s]["tasks"][i]["final_return"] for s in seeds] for lab in labels}
        us = {
            lab: float(np.nanmean([runs[lab][s]["tasks"][i]["us_per_step"] for s in seeds]))
            for lab in labels
        }
        row = [env, *[summarise(vals[lab]).fmt(1) for lab in labels]]
        row += [f"{us[lab]:.0f}" for lab in labels]
        if len(labels) >= 2:
            a, b = vals[labels[0]], vals[labels[1]]
            row.append("—" if a == b else f"{permutation_test(a, b, paired=True):.3f}")
        rows.append(row)
        means = {lab: float(np.mean(vals[lab])) for lab in labels}
        best = max(means.values())
        for lab in labels:
            if means[lab] == best and list(means.values()).count(best) == 1:
                higher[lab] += 1
    eps = ", ".join(f"{t['env_id']} {t['episodes']}" for t in first["tasks"])
    note = (
        f"Variant {variant}; seeds {format_seeds(seeds)}; episodes per task {eps}; "
        f"tasks where a label has the strictly highest mean final return: {higher}.\n\n"
    )
    return note + md_table(header, rows)


__all__ += ["contrast_table"]


# ---------------------------------------------------------------------------- compare biarm
def collect_dirs(
    paths: Sequence[str | Path],
) -> tuple[dict[str, dict[int, dict[str, Any]]], dict[tuple[str, int], Path]]:
    """Summaries of finished BIARM runs from run directories and/or ``biarm compare`` folders.

    Returns ``{variant: {seed: summary}}`` and each run's folder. A path that is neither a
    finished ``biarm train`` run (``summary.json``) nor a folder with ``runs/``, a run of
    another kind, or the same (variant, seed) twice is an :class:`EvodevoError`.
    """
    folders: list[Path] = []
    for p in map(Path, paths):
        if (p / "summary.json").is_file():
            folders.append(p)
        elif (p / "runs").is_dir():
            folders += sorted(f for f in (p / "runs").iterdir() if (f / "summary.json").is_file())
        else:
            raise EvodevoError(
                f"{str(p)!r} holds neither summary.json nor runs/; pass finished "
                "`evodevo biarm train` run directories or `evodevo biarm compare` folders"
            )
    runs: dict[str, dict[int, dict[str, Any]]] = {}
    where: dict[tuple[str, int], Path] = {}
    for f in folders:
        kind = read_json(f / "config.json").get("kind") if (f / "config.json").is_file() else None
        if kind != "biarm":
            raise EvodevoError(
                f"{str(f)!r} holds a {kind!r} run, not a BIARM run (`evodevo biarm train`); "
                "use `evodevo compare kuka` for Kuka runs"
            )
        s = read_json(f / "summary.json")
        key = (str(s["variant"]), int(s["seed"]))
        if key in where:
            raise EvodevoError(
                f"variant {key[0]!r} seed {key[1]} is in both {str(where[key])!r} and "
                f"{str(f)!r}; pass each run once"
            )
        where[key] = f
        runs.setdefault(key[0], {})[key[1]] = s
    if not runs:
        raise EvodevoError("no finished BIARM run in the given directories; nothing to compare")
    return runs, where


def _continual_budget(
    runs: dict[str, dict[int, dict[str, Any]]], where: Mapping[tuple[str, int], Path]
) -> str:
    """Budget, seeds, evaluation and machine of every variant (SPEC §6)."""
    lines = []
    machine: dict[str, Any] = {}
    for v in variant_order(runs):
        seed = min(runs[v])
        saved = RunDir(where[(v, seed)], create=False).read_config()
        machine = machine or saved.get("machine", {})
        s = runs[v][seed]
        eps = ", ".join(f"{t['env_id']} {t['episodes']}" for t in s["tasks"])
        lines.append(
            f"- {v}: seeds {format_seeds(list(runs[v]))}; episodes per task {eps} (episodes_scale "
            f"{saved['config'].get('episodes_scale')}); {len(s['eval_seeds'])} greedy "
            f"evaluation episodes, seeds {s['eval_seeds'][0]}..{s['eval_seeds'][-1]}"
        )
    return (
        "Budget and seeds per variant:\n\n"
        + "\n".join(lines)
        + "\n\nMean ± std over seeds, 95 % bootstrap interval of the mean (10,000 resamples). "
        "Retention is that of the seed means (Table 3.5, SPEC §1.7). Forgetting is Eq. 1.4, "
        "max over k of Acc(i,k) - Acc(i,T) in return units (0: none; the last task has none), "
        "per seed, then mean ± std. sb3-dqn trains a separate model per task, so its "
        "retention is 1 and its forgetting 0 by construction. Thesis numbers: Tables 3.2, 3.4 "
        "and 3.5 (BIARM, PNN and the ablations only). "
        f"Machine: {machine.get('processor')}, {machine.get('cpus')} CPUs, "
        f"{machine.get('platform')}.\n"
    )


def write_continual_table(paths: Sequence[str | Path], out: str | Path) -> Path:
    """``evodevo compare biarm``: ``table_continual.md`` and ``.csv`` in ``out``; returns the
    Markdown file."""
    runs, where = collect_dirs(paths)
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    title = TABLES["table_continual"][0]
    header, rows = table_continual(runs)
    md = f"# {title}\n\n{_continual_budget(runs, where)}\n" + md_table(header, rows)
    atomic_write_text(root / "table_continual.md", md)
    atomic_write_text(root / "table_continual.csv", continual_csv(runs))
    return root / "table_continual.md"
