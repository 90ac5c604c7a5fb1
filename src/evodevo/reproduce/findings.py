"""The "Findings" that open the reproduction report: what was measured and what it shows.

One line per method (BIARM, GRN, Kuka baselines) with its headline numbers, read from the same
run files as the tables below it, each naming its runs and the seed range its episodes came
from (SPEC §6). Under the ``quick`` budget the section says that these are smoke-budget numbers:
they show that every part runs end to end, not how the methods compare.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evodevo.baselines.table_4_2 import build_table
from evodevo.errors import EvodevoError
from evodevo.neuromod.compare import collect
from evodevo.neuromod.table_format import format_seeds
from evodevo.reproduce.biarm_protocols import grids
from evodevo.reproduce.budget import ReproduceConfig, preset
from evodevo.reproduce.run_files import finished, kuka_run_dir, load_json
from evodevo.seed_split import range_label
from evodevo.seeding import parse_seeds
from evodevo.stats import rate

__all__ = ["findings"]

#: BIARM variants named first on the findings line (the method and its base network).
HEADLINE_VARIANTS = ("biarm", "pnn")


def findings(out: Path, cfg: ReproduceConfig) -> list[str]:
    """The ``## Findings`` section of ``out/report.md``: one line per method that has results."""
    rows = []
    if cfg.biarm.enabled:
        rows += _biarm_line(out, cfg)
    if cfg.grn.enabled:
        rows += _grn_line(out, cfg)
    if cfg.kuka.enabled:
        rows += _kuka_line(out, cfg)
    if cfg == preset("thesis"):
        lead = "Budget `thesis`: the full protocol."
    elif cfg.name == "quick":
        lead = (
            "Budget `quick`: **smoke-budget numbers**. They show that every part runs end to end "
            "on this machine, not how the methods compare; only `--budget thesis` is comparable "
            "with the thesis (what this budget leaves out is listed under Coverage)."
        )
    else:
        lead = (
            f"Budget `{cfg.name}`, which differs from the full protocol (`--budget thesis`) as "
            "listed under Coverage."
        )
    return [
        "## Findings",
        "",
        lead + " Headline numbers, from the run files the tables below are drawn from:",
        "",
        *(rows or ["- no part of the budget has finished yet"]),
        "",
    ]


def _biarm_line(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Mean final greedy return per task of the first grid with runs, per variant."""
    for folder, protocol in grids(cfg):
        try:
            runs = collect(out / folder)
        except EvodevoError:  # no finished run (yet)
            continue
        names = [v for v in HEADLINE_VARIANTS if v in runs]
        names += [v for v in cfg.biarm.variants if v in runs and v not in names]
        first = next(iter(next(iter(runs.values())).values()))
        tasks = [t["env_id"] for t in first["tasks"]]
        parts = []
        for v in names:
            per_task = [
                [s["tasks"][i]["final_return"] for s in runs[v].values() if len(s["tasks"]) > i]
                for i in range(len(tasks))
            ]
            means = " / ".join(f"{sum(r) / len(r):.1f}" if r else "n/a" for r in per_task)
            parts.append(f"{v} {means} ({len(runs[v])} run{'s' if len(runs[v]) != 1 else ''})")
        return [
            f"- **BIARM** (`{folder}/`, protocol `{protocol}`), mean final greedy return per task "
            f"({' / '.join(tasks)}) after the whole sequence, seeds "
            f"{format_seeds(sorted({s for r in runs.values() for s in r}))}, "
            f"{_biarm_range(first)}: " + "; ".join(parts) + "."
        ]
    return []


def _biarm_range(summary: dict[str, Any]) -> str:
    """``"evaluation seeds 1000000-1000019 (test range)"`` of a BIARM run summary."""
    seeds = [int(s) for s in summary.get("eval_seeds", [])]
    if not seeds:
        return "evaluation seeds not recorded"
    lo, hi = min(seeds), max(seeds)
    return f"evaluation seeds {lo}-{hi} ({range_label(lo, hi - lo + 1)} range)"


def _grn_line(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Clean test-object success per GRN controller (per seed and pooled) and the constant turn."""
    g = cfg.grn
    parts, first_seed, turn = [], None, None
    for c in g.controllers:
        tests = {
            s: t
            for s in parse_seeds(g.seeds)
            if (t := load_json(out / "grn" / f"{c}_s{s}" / "repro_test_noisy.json")) is not None
        }
        if not tests:
            continue
        clean = {s: t.get("clean", t) for s, t in tests.items()}
        k = sum(int(r["successes"]) for r in clean.values())
        n = sum(int(t["episodes"]) for t in tests.values())
        pooled = rate(k, n)
        per_seed = " / ".join(
            f"{100 * int(clean[s]['successes']) / int(tests[s]['episodes']):.1f}" for s in clean
        )
        parts.append(
            f"{c} {per_seed} % on seeds {' / '.join(map(str, clean))} (pooled {100 * pooled.rate:.1f} % "
            f"[{100 * pooled.ci_low:.1f}, {100 * pooled.ci_high:.1f}])"
        )
        t0 = next(iter(tests.values()))
        first_seed = t0.get("test_seed", first_seed)
        turn = t0.get("baselines", {}).get("turn", turn)
    if not parts:
        return []
    where = (
        f"first seed {first_seed}, {range_label(int(first_seed))} range"
        if first_seed is not None
        else "seed range not recorded"
    )
    ref = (
        f"; the constant turn action gets {100 * float(turn['success_rate']):.1f} % on the same "
        "episodes"
        if turn
        else ""
    )
    return [
        f"- **GRN**, success on {g.test_episodes} held-out-object test episodes per run "
        f"({where}; pooled intervals Wilson 95 % over episodes): " + "; ".join(parts) + ref + "."
    ]


def _kuka_line(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Pooled test success of every finished Kuka baseline, per budget scale."""
    k = cfg.kuka
    parts = []
    for scale in k.budget_scales:
        dirs = [kuka_run_dir(out, m, scale, s) for m in k.methods for s in parse_seeds(k.seeds)]
        done: list[str | Path] = [
            d for d in dirs if (d / "summary.json").is_file() and finished(d / "summary.json")
        ]
        try:
            table, runs = build_table(done) if done else ([], [])
        except EvodevoError:
            continue
        if not table:
            continue
        first = runs[0].test_seed
        parts.append(
            f"at {scale:g}× the GRN's env steps ({range_label(first)} range, first seed {first}): "
            + ", ".join(
                f"{r.method.upper()} {100 * r.success_rate:.1f} % [{100 * r.ci_low:.1f}, "
                f"{100 * r.ci_high:.1f}] ({r.runs} run{'s' if r.runs != 1 else ''})"
                for r in table
            )
        )
    if not parts:
        return []
    return ["- **Kuka baselines**, pooled test-object success: " + "; ".join(parts) + "."]
