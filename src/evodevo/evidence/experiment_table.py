"""The tables and figure of a decided experiment (:mod:`evodevo.evidence.experiment`, SPEC §6):
``table.md`` (arms, the decision with its reading, the comparisons beside), ``comparisons.csv``,
``runs.csv`` and ``runs.png``."""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from evodevo.evidence.experiment import ExperimentResult, decide_experiment, load_experiment
from evodevo.evidence.verdict import to_markdown
from evodevo.seed_split import range_label

__all__ = ["markdown", "write_experiment"]


def _range_words(label: str) -> str:
    """``"the locked test range"`` for a caption (SPEC §6), else the range's name."""
    if label == "test":
        return "the locked test range"
    return label if label == "outside the split" else f"the {label} range"


def _f(v: float | None, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def _column_cell(values: Mapping[int, float]) -> str:
    """``mean [min, max]`` of a descriptive run column, or —."""
    if not values:
        return "—"

    def num(x: float) -> str:  # whole numbers from 100 up, else three significant figures
        return f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}"

    v = list(values.values())
    return f"{num(sum(v) / len(v))} [{num(min(v))}, {num(max(v))}]"


def _test_words(res: ExperimentResult) -> str:
    if res.spec.metric == "success":
        objects, first, n = res.test
        return (
            f"Test: {n} episodes on {objects} objects, first seed {first} "
            f"({_range_words(range_label(first, n))})"
        )
    if res.spec.test_key:
        return f"Test: every run's {res.spec.test_key} is {res.test[0]}"
    return "Test: as each result file records it"


def markdown(res: ExperimentResult) -> str:
    """The experiment's tables: arms, the decision, the comparisons beside, and the reading."""
    spec = res.spec
    success = spec.metric == "success"
    units = "points" if success else "(units of the metric)"
    lines = [
        f"# {spec.name}. {spec.title}",
        "",
        f"{_test_words(res)}; registered run seeds {spec.seeds} ({res.runs_registered} per "
        f"arm); metric {spec.unit}; δ = {spec.margin:g} {units}; intervals are 95 % bootstrap "
        f"intervals over runs ({spec.reps} resamples).",
        "",
    ]
    target = f" pooled ≥ {spec.target:g} % |" if success and spec.target is not None else ""
    extra = "".join(f" {label}: mean [min, max] |" for label in spec.run_columns)
    extra_rule = "---:|" * len(spec.run_columns)
    if success:
        lines += [
            "| arm | runs | seeds | mean success over runs [95 % CI] | pooled successes | "
            "pooled success [Wilson 95 %] |" + target + extra,
            "|---|---:|---|---:|---:|---:|" + ("---|" if target else "") + extra_rule,
        ]
    else:
        lines += [
            "| arm | runs | seeds | mean over runs [95 % CI] |" + extra,
            "|---|---:|---|---:|" + extra_rule,
        ]
    digits = 1 if success else 2
    for r in res.arm_rows:
        row = (
            f"| {r['arm']} | {r['runs']} | {r['seeds'] or '—'} | {_f(r['mean'], digits)} "
            f"[{_f(r['low'], digits)}, {_f(r['high'], digits)}] |"
        )
        if success:
            row += (
                f" {r['pooled_successes']} / {r['pooled_episodes']} | {_f(r['pooled'])} "
                f"[{_f(r['pooled_low'])}, {_f(r['pooled_high'])}] |"
            )
        if target:
            reached = r["pooled"] is not None and r["pooled"] >= (spec.target or 0)
            row += " — |" if r["pooled"] is None else f" {'yes' if reached else 'no'} |"
        arm = res.arms[r["arm"]]
        for label in spec.run_columns:
            row += f" {_column_cell(arm.columns.get(label, {}))} |"
        lines.append(row)
    if spec.run_columns:
        lines += [
            "",
            "The columns after the tests describe the runs ("
            + "; ".join(f"{label}: `{where}`" for label, where in spec.run_columns.items())
            + " in each run's folder) and decide nothing.",
        ]
    lines += [
        "",
        "## The decision",
        "",
        f"Paired by run seed (A − B, {spec.unit}), exact sign-flip test, Holm over the "
        f"{len(spec.decision)} comparison(s) below; with {res.runs_registered} runs per arm "
        f"the smallest p (Holm) the decision can reach is {spec.smallest_decision_p:.3g}.",
        "",
        to_markdown(res.decision, digits=digits)
        if res.decision
        else "(no comparison has 2 paired runs yet)",
        "",
        f"**Reading (claim: {spec.claim}"
        + (f", read on {', '.join(spec.claim_on)}" if spec.claim_on else "")
        + (
            ", read per group: "
            + "; ".join(f"{g} = {', '.join(items)}" for g, items in spec.claim_groups.items())
            if spec.claim_groups
            else ""
        )
        + f"): {res.reading}.**",
        "",
    ]
    if spec.beside:
        lines += [
            "## Beside the decision",
            "",
            "Each comparison alone (no correction; not part of the decision).",
            "",
            to_markdown(res.beside, digits=digits) if res.beside else "(no paired runs yet)",
            "",
        ]
    return "\n".join(lines)


def _csv(rows: Sequence[Mapping[str, Any]]) -> str:
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()


def write_experiment(spec_path: str | Path, out: str | Path | None = None) -> Path:
    """Decide the experiment of ``spec_path`` and write ``OUT/table.md``, ``comparisons.csv``,
    ``runs.csv`` and ``runs.png`` (default OUT: ``<root>/<name>``); returns ``table.md``."""
    from evodevo.evidence.profiles import plot_run_scores
    from evodevo.runs import atomic_write_text

    spec, root = load_experiment(spec_path)
    res = decide_experiment(spec, root)
    folder = Path(out) if out is not None else root / spec.name.lower()
    folder.mkdir(parents=True, exist_ok=True)
    md = folder / "table.md"
    atomic_write_text(md, markdown(res) + "\n")
    comps = [
        {"family": fam, **{k: getattr(c, k) for k in ("a", "b", "n", "mean_diff", "low", "high",
         "std_diff", "p", "p_adj", "delta", "mde", "verdict", "runs_needed")}}
        for fam, cs in (("decision", res.decision), ("beside", res.beside))
        for c in cs
    ]  # fmt: skip
    atomic_write_text(folder / "comparisons.csv", _csv(comps))
    if spec.metric == "success":
        runs: list[dict[str, Any]] = [
            {"arm": a.name, "seed": s, "successes": k, "episodes": n, "success": v}
            for a in res.arms.values()
            for s, v, k, n in zip(
                [""] if a.reference else a.seeds, a.values, a.successes, a.episodes, strict=False
            )
        ]
    else:
        runs = [
            {"arm": a.name, "seed": s, "value": v}
            for a in res.arms.values()
            for s, v in zip(a.seeds, a.values, strict=True)
        ]
    for row in runs:
        cols = res.arms[row["arm"]].columns
        for label in spec.run_columns:
            row[label] = cols.get(label, {}).get(row["seed"], "") if row["seed"] != "" else ""
    atomic_write_text(folder / "runs.csv", _csv(runs))
    plot_run_scores(
        {
            a.name: {s: a.score(s) for s in a.seeds[: 1 if a.reference else None]}
            for a in res.arms.values()
        },
        {
            r["arm"]: (r["mean"], r["low"], r["high"])
            for r, a in zip(res.arm_rows, res.arms.values(), strict=True)
            if r["mean"] is not None and not a.reference
        },
        folder / "runs.png",
        ylabel="success on the test episodes (%)" if spec.metric == "success" else spec.unit,
        title=f"{spec.name}: each run (dots; an untrained reference: its one test) and the "
        "mean over runs [95 % CI]",
        target=spec.target if spec.metric == "success" else None,
    )
    return md
