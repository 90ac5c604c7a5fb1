"""The comparison grid and Tables 3.2-3.5 (SPEC §1.7, §6).

:func:`run_grid` trains every (variant, seed) pair in ``DIR/runs/{variant}__s{seed}/`` over a
:class:`~evodevo.parallel.WorkerPool` of local processes or over Ray
(:func:`~evodevo.parallel.make_pool`); finished runs are skipped and interrupted ones resume
from their newest checkpoint, so the grid itself is resumable, and every run's numbers depend
on its variant and seed only, not on where it ran. :func:`write_report` reads the saved run files only and
writes the tables as Markdown and CSV next to the figures, with the thesis' numbers beside ours.
:func:`write_continual_table` (``evodevo compare biarm``) writes the extended Table 3.2/3.5 --
every variant, the continual baselines of issue 4 included, with final return, retention and
the forgetting measure of Eq. 1.4 (:mod:`evodevo.neuromod.forgetting`) -- from any set of run
directories.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import from_dict
from evodevo.errors import EvodevoError
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.evaluation import improvement, retention
from evodevo.neuromod.forgetting import forgetting
from evodevo.neuromod.thesis_numbers import TABLE_3_2, TABLE_3_3_MS, TABLE_3_4, TABLE_3_5
from evodevo.neuromod.variants import VARIANTS
from evodevo.parallel import make_pool
from evodevo.runs import RunDir, atomic_write_text, read_json
from evodevo.stats import summarise

__all__ = [
    "run_grid",
    "run_dir_name",
    "collect",
    "collect_dirs",
    "write_report",
    "write_continual_table",
    "table_continual",
    "continual_records",
    "ABLATIONS",
]

ABLATIONS = ("no-da", "no-5ht", "no-ne", "no-ach")


def run_dir_name(variant: str, seed: int) -> str:
    """``{variant}__s{seed}``."""
    return f"{variant}__s{seed}"


def _run_item(item: tuple[str, int, dict[str, Any], str]) -> str:
    """Worker body: train one (variant, seed) into its folder, resuming if interrupted."""
    from evodevo.neuromod.checkpoint import latest_resume_point
    from evodevo.neuromod.trainer import train

    variant, seed, cfg_dict, out = item
    cfg = from_dict(BiarmConfig, cfg_dict)
    resume = latest_resume_point(Path(out) / "checkpoints") is not None
    train(cfg, variant, seed, out, resume=resume)
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
    from evodevo.config import to_dict
    from evodevo.neuromod.tasks import resolve_tasks
    from evodevo.neuromod.variants import get_variant

    for v in variants:
        get_variant(v)
    resolve_tasks(cfg)  # every input error before any worker starts
    root = Path(out)
    (root / "runs").mkdir(parents=True, exist_ok=True)
    cfg_dict = to_dict(cfg)
    items = []
    for v in variants:
        for s in seeds:
            folder = root / "runs" / run_dir_name(v, s)
            if (folder / "summary.json").is_file():
                continue
            items.append((v, int(s), cfg_dict, str(folder)))
    if not items:
        return []
    with make_pool(backend, min(workers, len(items)), address=address) as pool:
        return list(pool.map(_run_item, items))


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


def _budget(out: Path, runs: dict[str, dict[int, dict[str, Any]]]) -> str:
    """One paragraph naming budget, seeds, evaluation and machine (SPEC §6)."""
    variant = next(iter(runs))
    seed = next(iter(runs[variant]))
    folder = out / "runs" / run_dir_name(variant, seed)
    saved = RunDir(folder, create=False).read_config()
    cfg = saved["config"]
    machine = saved.get("machine", {})
    s = runs[variant][seed]
    eps = ", ".join(f"{t['env_id']} {t['episodes']}" for t in s["tasks"])
    seeds = {v: sorted(r) for v, r in runs.items()}
    return (
        f"Budget: episodes per task {eps} (episodes_scale {cfg.get('episodes_scale')}); "
        f"module learning `{s.get('module_learning')}`, adapter_dim {s.get('adapter_dim')}; "
        f"{len(s['eval_seeds'])} greedy evaluation episodes with seeds "
        f"{s['eval_seeds'][0]}..{s['eval_seeds'][-1]}; seeds per variant {seeds}. "
        f"Machine: {machine.get('processor')}, {machine.get('cpus')} CPUs, "
        f"{machine.get('platform')}. Intervals: 95 % bootstrap over seeds (10,000 resamples).\n"
    )


# ---------------------------------------------------------------------------- tables
def table_3_2(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """PNN vs BIARM final returns with improvement, thesis beside."""
    header = [
        "Environment",
        "PNN (ours)",
        "BIARM (ours)",
        "Improvement (ours)",
        "PNN (thesis)",
        "BIARM (thesis)",
        "Improvement (thesis)",
    ]
    rows = []
    for env in _env_ids(runs):
        p = summarise(_values(runs.get("pnn", {}), env, "final_return"))
        b = summarise(_values(runs.get("biarm", {}), env, "final_return"))
        th = TABLE_3_2.get(env)
        rows.append(
            [
                env,
                p.fmt(2) + f" (n={p.n})" if p.n else "—",
                b.fmt(2) + f" (n={b.n})" if b.n else "—",
                f"{improvement(b.mean, p.mean):+.2f} %" if p.n and b.n else "—",
                _pm(*th["pnn"]) if th else "—",
                _pm(*th["biarm"]) if th else "—",
                f"{improvement(th['biarm'][0], th['pnn'][0]):+.2f} %" if th else "—",
            ]
        )
    return header, rows


def table_3_3(runs: dict[str, dict[int, dict[str, Any]]]) -> tuple[list[str], list[list[str]]]:
    """Median time per training step (µs), mean over seeds, and the ratio to PNN."""
    variants = [v for v in ("pnn", "biarm", *ABLATIONS) if v in runs]
    header = ["Environment", *[f"{v} µs/step" for v in variants]]
    if "pnn" in runs:
        header += [f"{v}/pnn" for v in variants if v != "pnn"]
    header += ["thesis PNN / BIARM ms", "thesis overhead"]
    rows = []
    for env in _env_ids(runs):
        means = {v: float(np.nanmean(_values(runs[v], env, "us_per_step"))) for v in variants}
        row = [env, *[f"{means[v]:.0f}" for v in variants]]
        if "pnn" in runs:
            row += [f"{means[v] / means['pnn']:.3f}" for v in variants if v != "pnn"]
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
    """Initial vs final returns and retention (of the means), thesis beside."""
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
    variants = [v for v in ("biarm", "pnn", *ABLATIONS) if v in runs]
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


TABLES = {
    "table_3_2": ("Table 3.2 — final return, PNN vs BIARM", table_3_2),
    "table_3_3": ("Table 3.3 — time per training step", table_3_3),
    "table_3_4": ("Table 3.4 — ablations (final return)", table_3_4),
    "table_3_5": ("Table 3.5 — initial vs final return and retention", table_3_5),
    "table_continual": (
        "Extended Tables 3.2/3.5 — every variant: final return, retention, forgetting (Eq. 1.4)",
        table_continual,
    ),
}


def write_report(out: str | Path, figures: bool = True) -> Path:
    """Write ``table_3_*.md/.csv``, ``report.md`` and (optionally) the figures into ``out``."""
    root = Path(out)
    runs = collect(root)
    budget = _budget(root, runs)
    parts = ["# BIARM comparison\n", budget]
    for name, (title, fn) in TABLES.items():
        if name == "table_3_2" and not ({"pnn", "biarm"} & set(runs)):
            continue
        if name == "table_3_4" and not (set(ABLATIONS) & set(runs)):
            continue
        header, rows = fn(runs)
        md = f"## {title}\n\n{budget}\n" + _md_table(header, rows)
        atomic_write_text(root / f"{name}.md", md)
        text = continual_csv(runs) if name == "table_continual" else _csv(header, rows)
        atomic_write_text(root / f"{name}.csv", text)
        parts.append(f"## {title}\n\n" + _md_table(header, rows))
    if figures:
        from evodevo.neuromod.figures import draw_all

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
    from evodevo.stats import permutation_test

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
        f"Variant {variant}; seeds {seeds}; episodes per task {eps}; "
        f"tasks where a label has the strictly highest mean final return: {higher}.\n\n"
    )
    return note + _md_table(header, rows)


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
    for v in _variant_order(runs):
        seed = min(runs[v])
        saved = RunDir(where[(v, seed)], create=False).read_config()
        machine = machine or saved.get("machine", {})
        s = runs[v][seed]
        eps = ", ".join(f"{t['env_id']} {t['episodes']}" for t in s["tasks"])
        lines.append(
            f"- {v}: seeds {sorted(runs[v])}; episodes per task {eps} (episodes_scale "
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
    md = f"# {title}\n\n{_continual_budget(runs, where)}\n" + _md_table(header, rows)
    atomic_write_text(root / "table_continual.md", md)
    atomic_write_text(root / "table_continual.csv", continual_csv(runs))
    return root / "table_continual.md"
