"""``report.md`` and ``report.html`` of ``evodevo reproduce``, from saved run files only.

Every table sits beside the thesis' number, names its budget, seeds, object split and machine
(SPEC §6), and ends with a short "where we differ and why" that is computed from the numbers in
the table, not written in advance.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError
from evodevo.grn.ablation_pooling import (
    pool_ablations,
    pooled_ablations_markdown,
    read_ablation_tables,
)
from evodevo.grn.return_rule import describe_rule, rules_sentence
from evodevo.neuromod.aggregate_table import AGGREGATE_TITLE, aggregate_markdown
from evodevo.neuromod.compare import CL_TITLE, collect, continual_markdown
from evodevo.neuromod.table_format import format_seeds, table_markdown
from evodevo.neuromod.tables import STATS_NOTE, report_tables, run_facts, seeds_sentence
from evodevo.reproduce.biarm_differences import biarm_differences
from evodevo.reproduce.biarm_protocols import grids, protocol_table
from evodevo.reproduce.budget import GrnBudget, ReproduceConfig, preset
from evodevo.reproduce.findings import findings
from evodevo.reproduce.grn_controls import controls_block
from evodevo.reproduce.html_report import markdown_to_html
from evodevo.reproduce.kuka_report import kuka_section
from evodevo.reproduce.run_files import fmt_pair, load_json, paired, pct, successes
from evodevo.runs import atomic_write_text, machine_info
from evodevo.seed_split import range_label
from evodevo.seeding import parse_seeds
from evodevo.stats import mcnemar_exact_counts, rate

__all__ = [
    "write_report",
    "grn_section",
    "biarm_section",
    "coverage",
    "markdown_to_html",
    "THESIS_GRN",
]

Runs = dict[str, dict[int, dict[str, Any]]]

#: Thesis Chapter 4 numbers (Table 4.2 and Section 4.6.2): test success on *training* objects
#: over 40 episodes, the noisy success and the retention.
THESIS_GRN = {
    "success": 0.575,
    "noisy": 0.528,
    "retention": 0.918,
    "episodes": 40,
    "train_min": 6.5,
}


def _grid_runs(out: Path, cfg: ReproduceConfig) -> list[tuple[str, str, Runs]]:
    """``(folder, protocol, runs)`` of every BIARM grid of the budget (runs empty if none
    finished)."""
    found = []
    for folder, protocol in grids(cfg):
        try:
            runs = collect(out / folder)
        except EvodevoError:  # no finished run (yet)
            runs = {}
        found.append((folder, protocol, runs))
    return found


_FACTS = ("model", "evaluation", "machine")


def _split_facts(
    out: Path, found: list[tuple[str, str, Runs]]
) -> tuple[dict[str, str], dict[str, dict[str, str]]]:
    """The model, evaluation and machine facts every grid with runs shares (stated once at the
    top), and per grid folder those in which the grids differ (stated under that grid)."""
    per = {folder: run_facts(runs, out / folder) for folder, _, runs in found if runs}
    common: dict[str, str] = {}
    own: dict[str, dict[str, str]] = {folder: {} for folder in per}
    for key in _FACTS:
        values = {folder: f[key] for folder, f in per.items() if key in f}
        if not values:
            continue
        if len(set(values.values())) == 1 and len(values) == len(per):
            common[key] = next(iter(values.values()))
        else:
            for folder, value in values.items():
                own[folder][key] = value
    return common, own


def _facts_text(facts: dict[str, str]) -> str:
    """``model; evaluation. Machine: ...`` of the facts given, in that order."""
    head = "; ".join(facts[k] for k in ("model", "evaluation") if k in facts)
    machine = f"Machine: {facts['machine']}." if "machine" in facts else ""
    return " ".join(x for x in ((head + ".") if head else "", machine) if x)


def biarm_section(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Every BIARM grid of the budget (one per DQN protocol, SPEC §1.6), side by side first.

    Budget, seeds and machine are stated once, at the top (a grid whose model, evaluation or
    machine differs from the others says so under its heading); each table has a one-line
    caption.
    """
    b = cfg.biarm
    found = _grid_runs(out, cfg)
    common, own = _split_facts(out, found)
    episodes = f"episodes × {b.episodes_scale:g} of the thesis' (400/500/800/800)" + (
        "".join(f", {env} {n}" for env, n in b.task_episodes.items())
    )
    seeds = parse_seeds(b.seeds)
    if "evaluation" not in common:
        common = {"evaluation": f"{b.eval_episodes} greedy evaluation episodes per task"} | common
    lines = [
        "## BIARM (thesis Chapter 3)",
        "",
        f"Budget: tasks {', '.join(b.tasks)}; {episodes}; variants {', '.join(b.variants)}; "
        f"seeds {format_seeds(seeds)} ({len(seeds)} per variant); "
        + _facts_text(common)
        + f" {STATS_NOTE} Thesis numbers are in their own columns. DQN protocols (SPEC §1.6): "
        + "; ".join(f"`{p}` in `{f}/`" for f, p in grids(cfg))
        + ".",
        "",
    ]
    lines += protocol_table(out, cfg)
    for folder, protocol, runs in found:
        lines += _biarm_grid(out, cfg, folder, protocol, runs, own.get(folder, {}))
    return lines


def _biarm_grid(
    out: Path,
    cfg: ReproduceConfig,
    folder: str,
    protocol: str,
    runs: Runs,
    own_facts: dict[str, str] | None = None,
) -> list[str]:
    """Tables 3.2-3.5, the extended table and the continual-learning metrics (SPEC §6) of one
    grid, computed from its saved runs, its differences from the thesis and its figures;
    ``own_facts``: the model, evaluation or machine facts in which this grid differs from the
    others."""
    bdir = out / folder
    b = cfg.biarm
    lines = [f"### BIARM under the `{protocol}` protocol (`{folder}/`)", ""]
    if not runs:
        return lines + ["(no BIARM tables: the BIARM part was not run or did not finish)", ""]
    if own_facts:
        differ = "; ".join(f"this grid's {k}: {v}" for k, v in own_facts.items())
        lines += [differ[0].upper() + differ[1:] + ".", ""]
    budget_seeds = parse_seeds(b.seeds)
    if any(sorted(seeds) != budget_seeds for seeds in runs.values()):
        lines += [
            f"The tables use every finished run, which differs from the budget's seeds "
            f"{format_seeds(budget_seeds)} for some variants. Finished runs: "
            f"{seeds_sentence(runs)}.",
            "",
        ]
    for _name, title, caption, header, rows in report_tables(dict(runs)):
        lines += [f"#### {title}", "", table_markdown(caption, header, rows).strip(), ""]
    lines += [f"#### {AGGREGATE_TITLE}", "", aggregate_markdown(runs).strip(), ""]
    lines += [f"#### {CL_TITLE}", "", continual_markdown(bdir).strip(), ""]
    lines += ["#### Where we differ and why", ""]
    lines += biarm_differences(runs, b.episodes_scale)
    figs = sorted(bdir.glob("*.png"))
    if figs:
        lines += ["#### Figures", ""] + [f"![{f.stem}]({f.relative_to(out)})" for f in figs] + [""]
    return lines


def grn_section(out: Path, cfg: ReproduceConfig) -> list[str]:
    """GRN test, robustness, controls and ablations from the captured evaluation JSON files."""
    g = cfg.grn
    gdir = out / "grn"
    lines = [
        "## GRN controller (thesis Chapter 4)",
        "",
        f"Budget per evolution: population {g.population}, ≤ {g.generations} generations, "
        f"{g.episodes} episodes per genome (70 % clean / 30 % noisy)"
        + (
            "; the vision runs use their preset's own (configs/grn_vision.yaml)"
            if g.vision_budget == "preset"
            else ""
        )
        + f". Test: {g.test_episodes} "
        f"episodes on held-out test objects with fixed seeds; {g.train_episodes} on training objects. "
        "Intervals are Wilson 95 %. The trivial policies (all-zero, uniform-random, constant turn) "
        "run on the same seeds.",
        "",
    ]
    main_rows, saved, test_seeds = _test_rows(gdir, g)
    if not main_rows:
        return lines + ["(no GRN results: the GRN part was not run or did not finish)", ""]
    ranges = ", ".join(f"first seed {t} ({range_label(t)} range)" for t in sorted(test_seeds))
    lines += [
        "### Test success, robustness and trivial policies (thesis Table 4.2 and Section 4.6.2)",
        "",
        f"Test episodes: {ranges or 'seeds not recorded'}. {rules_sentence(saved)}",
        "",
        "| controller | seed | generations | test objects, clean | test objects, noise 0.03 | retention | training objects | all-zero (test) | random (test) | return rule |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *main_rows,
        f"| **thesis** | ? | 6 | — | — | {100 * THESIS_GRN['retention']:.1f} % | "
        f"{100 * THESIS_GRN['success']:.1f} % (n=40) | — | — | last (last generation's best) |",
        "",
    ]
    lines += _controllers_paired(gdir, g.controllers, parse_seeds(g.seeds))
    lines += [
        "### Where we differ and why",
        "",
        "- The thesis tested on training objects over 40 episodes; we test on held-out objects "
        f"over {g.test_episodes} fixed-seed episodes, and show training objects separately.",
        "- Under the benchmark's height hack the arm descends and grasps by itself, so a do-nothing "
        "policy already succeeds often; a controller's value is its margin over the trivial "
        "policies and the controls in the tables below.",
        "",
    ]
    # Each preset's GRN against its own controls (evolved with the same preset and budget) and
    # the trivial policies: the thesis-preset GRN with the blind GRN and the open loop, the
    # vision preset with its blind twin. A controller is never pooled with another.
    thesis_grn = next((c for c in g.controllers if c != "vision"), None)
    if thesis_grn is not None:
        specs = [("blind", "blind GRN (no vision)"), ("openloop", "best open-loop policy")]
        lines += controls_block(gdir, g, thesis_grn, specs, "")
    if "vision" in g.controllers:
        specs = [("vision_blind", "blind GRN of the vision preset (no vision)")]
        lines += controls_block(gdir, g, "vision", specs, ", the vision preset")
    lines.append("")
    for c in g.controllers:
        lines += _ablations_and_figures(out, gdir, g, c)
    return lines


def _test_rows(gdir: Path, g: GrnBudget) -> tuple[list[str], list[dict[str, Any]], set[int]]:
    """One table row per tested evolution (clean, noisy, training objects, trivial policies,
    return rule), the evolutions' saved configs and the test seeds they used."""
    main_rows = []
    saved: list[dict[str, Any]] = []
    test_seeds: set[int] = set()
    for c in g.controllers:
        for s in parse_seeds(g.seeds):
            rdir = gdir / f"{c}_s{s}"
            t = load_json(rdir / "repro_test_noisy.json")
            tr = load_json(rdir / "repro_train_clean.json")
            summ = load_json(rdir / "summary.json") or {}
            if t is None:
                continue
            clean = t.get("clean", t)
            zero = t["baselines"].get("zero")
            rnd = t["baselines"].get("random")
            conf = load_json(rdir / "config.json")
            if conf is not None:
                saved.append(conf)
            if "test_seed" in t:
                test_seeds.add(int(t["test_seed"]))
            main_rows.append(
                f"| {c} | {s} | {summ.get('generations_run', '?')} | {pct(clean)} | {pct(t)} | "
                f"{(t.get('retention') or 0) * 100:.1f} % | {pct(tr) if tr else 'n/a'} | "
                f"{pct(zero) if zero else 'n/a'} | {pct(rnd) if rnd else 'n/a'} | "
                f"{describe_rule(conf, summ) if conf is not None else '—'} |"
            )
    return main_rows, saved, test_seeds


def _ablations_and_figures(out: Path, gdir: Path, g: GrnBudget, c: str) -> list[str]:
    """Controller ``c``'s ablations pooled over its seeds (with a link to each seed's table)
    and the figures of its first seed."""
    lines: list[str] = []
    s0 = parse_seeds(g.seeds)[0]
    dirs = {s: gdir / f"{c}_s{s}" for s in parse_seeds(g.seeds)}
    for name, title in (
        ("ablations", "Ablations (thesis Section 4.7)"),
        ("modulator_ablations", "Modulator ablations (SPEC §5: each gamma set to 0)"),
    ):
        tables = read_ablation_tables(dirs, f"{name}.json")
        if not tables:
            continue
        links = ", ".join(
            f"[seed {s}]({(dirs[s] / f'{name}.md').relative_to(out)})" for s in tables
        )
        lines += [
            f"### {title}, {c}, seeds {', '.join(map(str, tables))}",
            "",
            pooled_ablations_markdown(pool_ablations(tables)).strip(),
            "",
            f"Each seed's own table (with Fisher and Holm-adjusted McNemar p): {links}.",
            "",
        ]
    figs = sorted((gdir / f"{c}_s{s0}" / "figures").glob("*.png"))
    if figs:
        lines += (
            [f"### Figures, {c} seed {s0}", ""]
            + [f"![{f.stem}]({f.relative_to(out)})" for f in figs]
            + [""]
        )
    return lines


def _controllers_paired(gdir: Path, controllers: list[str], seeds: list[int]) -> list[str]:
    """Each further controller against the first (e.g. neuromodulated vs plain GRN), per seed
    on the same clean test episodes (exact McNemar), and pooled over the seeds."""
    if len(controllers) < 2:
        return []
    first = controllers[0]
    out: list[str] = []
    for other in controllers[1:]:
        rows, ka, kb, n, only_a, only_b = [], 0, 0, 0, 0, 0
        for s in seeds:
            a = successes(gdir / f"{other}_s{s}" / "eval_test_0.03_episodes.csv", "genome")
            b = successes(gdir / f"{first}_s{s}" / "eval_test_0.03_episodes.csv", "genome")
            pair = paired(a, b)
            if pair is None or a is None or b is None:
                continue
            ka, kb, n = ka + sum(a), kb + sum(b), n + len(a)
            only_a += sum(x > y for x, y in zip(a, b, strict=True))
            only_b += sum(y > x for x, y in zip(a, b, strict=True))
            rows.append(
                f"| {s} | {rate(sum(b), len(b)).fmt()} | {rate(sum(a), len(a)).fmt()} | "
                f"{fmt_pair(pair)} |"
            )
        if not rows:
            continue
        out += [
            f"### {other} vs {first} GRN, paired on the same test episodes",
            "",
            f"Clean test-object episodes; the last column is {other} − {first} in points with "
            "the exact McNemar p of that seed's episodes.",
            "",
            f"| seed | {first} | {other} | difference (McNemar p) |",
            "|---|---|---|---|",
            *rows,
            f"| pooled | {rate(kb, n).fmt()} | {rate(ka, n).fmt()} | "
            f"{100 * (ka - kb) / n:+.1f} (p = {mcnemar_exact_counts(only_a, only_b):.2g}, "
            "discordant episodes summed over seeds) |",
            "",
        ]
    return out


def _this_time(wall_s: float | None, steps_run: int | None) -> str:
    """The header's account of this invocation: how many steps it ran, in how long."""
    if steps_run == 0:
        return "; no step ran this time (the report is drawn from the saved runs)."
    if wall_s is None:
        return "."
    n = "" if steps_run is None else f"{steps_run} step{'s' if steps_run != 1 else ''} "
    return f"; {n}ran this time, in {wall_s / 60:.1f} min."


def write_report(
    out: Path, cfg: ReproduceConfig, wall_s: float | None = None, steps_run: int | None = None
) -> Path:
    """Write ``out/report.md`` and ``out/report.html``; return the Markdown path.

    ``wall_s`` and ``steps_run``: the wall time and number of the steps this invocation ran
    (0: only the report was rewritten), for the header.
    """
    m = machine_info()
    lines = [
        f"# evodevo reproduction report: budget `{cfg.name}`",
        "",
        f"Written {dt.datetime.now(dt.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} on {m['platform']} "
        f"({m['cpus']} CPUs, Python {m['python']}), {cfg.workers} worker processes"
        + _this_time(wall_s, steps_run),
        "Every number below was measured by this run; the thesis' numbers are shown beside ours. "
        "Logs of every step are in `logs/`, the resolved budget in `config.json`.",
        "",
    ]
    lines += findings(out, cfg)
    lines += coverage(cfg)
    if cfg.biarm.enabled:
        lines += biarm_section(out, cfg)
    if cfg.grn.enabled:
        lines += grn_section(out, cfg)
    if cfg.kuka.enabled:
        lines += kuka_section(out, cfg)
    md = "\n".join(lines) + "\n"
    path = out / "report.md"
    atomic_write_text(path, md)
    atomic_write_text(out / "report.html", markdown_to_html(md, out))
    return path


def coverage(cfg: ReproduceConfig) -> list[str]:
    """What this budget leaves out of the full protocol (``--budget thesis``), field by field.

    Empty for the thesis budget itself; otherwise a list a reader can hold every table against
    (a part turned off, fewer seeds, variants or methods, smaller episode counts).
    """
    full = preset("thesis")
    if cfg == full:
        return []
    rows = []
    for part in ("biarm", "grn", "kuka"):
        ours, theirs = getattr(cfg, part), getattr(full, part)
        if not ours.enabled:
            rows.append(f"- `{part}`: not run (the full protocol runs it)")
            continue
        for name in theirs.__dataclass_fields__:
            a, b = getattr(ours, name), getattr(theirs, name)
            if a == b:
                continue
            if name == "seeds" or name == "control_seeds":
                a, b = parse_seeds(a), parse_seeds(b)
                missing = [x for x in b if x not in a]
                if not missing:
                    continue
                rows.append(f"- `{part}.{name}`: {a} (full protocol {b}; missing {missing})")
            elif isinstance(b, list):
                missing = [x for x in b if x not in a]
                extra = [x for x in a if x not in b]
                if missing or extra:
                    rows.append(
                        f"- `{part}.{name}`: {a} (full protocol {b}"
                        + (f"; missing {missing}" if missing else "")
                        + (f"; not in it {extra}" if extra else "")
                        + ")"
                    )
            else:
                rows.append(f"- `{part}.{name}`: {a} (full protocol {b})")
    if not rows:
        return []
    return [
        "## Coverage against the full protocol (`--budget thesis`)",
        "",
        f"This report's budget `{cfg.name}` differs from the full protocol here; every table "
        "below holds only what was run:",
        "",
        *rows,
        "",
    ]
