"""Each GRN preset against its controls in the reproduction report (SPEC §2.5, §6).

The controls are evolved with the same preset and budget (the blind GRN, the best open-loop
policy; the vision preset's blind twin) or untrained (all-zero, uniform-random, constant turn,
the scripted pipeline) and tested on the same episodes. :func:`controls_block` gives the table
(pooled GRN success, Fisher against the pool, McNemar per GRN seed: descriptions of single
runs) and :func:`run_level_block` the comparison with the evolution as the unit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evodevo.evidence.normalise import SUCCESS_RATE_MARGIN
from evodevo.evidence.verdict import compare, holm_table, to_markdown
from evodevo.grn.return_rule import describe_rule
from evodevo.reproduce.budget import GrnBudget
from evodevo.reproduce.run_files import TRIVIAL_TITLES, fmt_pair, load_json, paired, successes
from evodevo.seeding import parse_seeds
from evodevo.stats import fisher_exact, rate

__all__ = ["SUCCESS_DELTA_POINTS", "controls_block", "run_level_block"]

#: The equivalence margin of a success rate (SPEC §6), in points.
SUCCESS_DELTA_POINTS = 100 * SUCCESS_RATE_MARGIN


def _pooled(results: list[dict[str, Any]], key: str | None = None) -> tuple[int, int]:
    k = n = 0
    for r in results:
        src = r[key] if key else r
        k += int(src["successes"])
        n += int(r["episodes"])
    return k, n


def controls_block(
    gdir: Path, g: GrnBudget, grn: str, specs: list[tuple[str, str]], heading: str
) -> list[str]:
    """The controls table of one GRN controller (``grn``: its seeds' clean tests pooled, and
    paired per seed with each control on the same test episodes), then one verdict per
    control. ``specs``: (run label, title) of the evolved controls."""
    tests = [
        t
        for s in parse_seeds(g.seeds)
        if (t := load_json(gdir / f"{grn}_s{s}" / "repro_test_noisy.json")) is not None
    ]
    if not tests:
        return []
    kc, nc = _pooled(tests, "clean") if "clean" in tests[0] else _pooled(tests)
    grn_eps: dict[int, list[int]] = {}
    for s in parse_seeds(g.seeds):
        ep = successes(gdir / f"{grn}_s{s}" / "eval_test_0.03_episodes.csv", "genome")
        if ep is not None:
            grn_eps[s] = ep
    grn_rules = sorted(
        {
            describe_rule(conf, load_json(gdir / f"{grn}_s{s}" / "summary.json"))
            for s in parse_seeds(g.seeds)
            if (conf := load_json(gdir / f"{grn}_s{s}" / "config.json")) is not None
        }
    )
    ctrl_rows = [
        f"| GRN ({grn}, pooled over seeds) | {rate(kc, nc).fmt()} | — | — | "
        f"{' / '.join(grn_rules) or '—'} |"
    ]
    diffs = []
    controls, triv_base = _controls(gdir, g, specs, tests[0])
    for title, t, ep, rule in controls:
        k2, n2 = int(t["successes"]), int(t["episodes"])
        p = fisher_exact(kc, nc, k2, n2)
        per_seed: list[str] = []
        mcn: list[tuple[float, float]] = []
        for s, gs in grn_eps.items():
            pair = paired(gs, ep)
            if pair is not None:
                mcn.append(pair)
                per_seed.append(f"s{s}: {fmt_pair(pair)}")
        ctrl_rows.append(
            f"| {title} | {rate(k2, n2).fmt()} | {p:.3g} | {'; '.join(per_seed) or '—'} | {rule} |"
        )
        diffs.append((title, kc / nc - k2 / n2, p, mcn))
    lines = [
        f"### Does the GRN use vision? Controls evolved with the same budget (SPEC §2.5){heading}",
        "",
        f"GRN: the `{grn}` controller. The last column pairs each of its seeds with the policy on "
        "the same test episodes: the difference in points and the exact McNemar p.",
        "",
        "The Fisher column treats the pooled GRN episodes as independent of the policy's, though "
        "they share the test seeds; it is indicative only where a paired entry exists.",
        "",
        "| policy | test success [95 % CI] | Fisher p vs pooled GRN (unpaired) | GRN − policy per GRN seed, points (McNemar p) | return rule |",
        "|---|---|---|---|---|",
        *ctrl_rows,
        "",
    ]
    lines += run_level_block(gdir, g, grn, specs, triv_base)
    for title, d, p, mcn in diffs:
        if mcn:  # paired on the same episodes: the verdict is per GRN seed (exact McNemar)
            sig = sum(pm < 0.05 for _, pm in mcn)
            per = ", ".join(f"{100 * dd:+.1f}" for dd, _ in mcn)
            lines.append(
                f"- GRN ({grn}) vs {title}: {per} points per GRN seed; significantly different "
                f"(McNemar p < 0.05) in {sig} of {len(mcn)} seeds."
            )
            continue
        verdict = "significantly" if p < 0.05 else "not significantly"
        lines.append(
            f"- GRN ({grn}) vs {title}: {100 * d:+.1f} points, {verdict} different "
            f"(Fisher p = {p:.3g})."
        )
    return lines + [""]


Control = tuple[str, dict[str, Any], list[int] | None, str]


def _controls(
    gdir: Path, g: GrnBudget, specs: list[tuple[str, str]], first_test: dict[str, Any]
) -> tuple[list[Control], dict[str, Any]]:
    """Every control of a GRN controller (title, test result, per-episode successes, return
    rule): the evolved controls of ``specs`` per control seed, then the trivial policies on the
    same episodes; and the trivial policies' results."""
    controls: list[Control] = []
    for label, title in specs:
        for s in parse_seeds(g.control_seeds):
            cdir = gdir / f"{label}_s{s}"
            t = load_json(cdir / "repro_test_clean.json")
            if t is not None:
                ep = successes(cdir / "eval_test_0_episodes.csv", "genome")
                conf = load_json(cdir / "config.json")
                rule = describe_rule(conf, load_json(cdir / "summary.json")) if conf else "—"
                controls.append((f"{title}, seed {s}", t, ep, rule))
    trivial = load_json(gdir / "baselines_test.json")
    triv_base = trivial["baselines"] if trivial else first_test["baselines"]
    for name, title in TRIVIAL_TITLES.items():
        b = triv_base.get(name)
        if b is not None:
            ep = successes(gdir / "baselines_test_episodes.csv", name) if trivial else None
            row = {"successes": b["successes"], "episodes": b.get("n", first_test["episodes"])}
            controls.append((title, {**b, **row}, ep, "untrained"))
    return controls, triv_base


def _test_rate(t: dict[str, Any]) -> float:
    """The clean test success of a captured evaluation (its noisy run carries it as "clean")."""
    c = t.get("clean", t)
    return float(c["successes"]) / float(c.get("n", t["episodes"]))


def run_level_block(
    gdir: Path,
    g: GrnBudget,
    grn: str,
    specs: list[tuple[str, str]],
    trivial: dict[str, Any],
) -> list[str]:
    """GRN − each control with the evolution as the unit (SPEC §6): per GRN seed its clean test
    success minus the control's (the evolved control of the same seed; an untrained policy's
    one number), an exact sign-flip test over seeds, Holm over the table, and a verdict
    against δ = 5 points."""
    grn_rates = {
        s: 100 * _test_rate(t)
        for s in parse_seeds(g.seeds)
        if (t := load_json(gdir / f"{grn}_s{s}" / "repro_test_noisy.json")) is not None
    }
    if len(grn_rates) < 2:
        return []
    comps = []
    for label, title in specs:
        ctrl = {
            s: 100 * _test_rate(t)
            for s in grn_rates
            if (t := load_json(gdir / f"{label}_s{s}" / "repro_test_clean.json")) is not None
        }
        shared = sorted(ctrl)
        if len(shared) >= 2:
            comps.append(
                compare(f"GRN ({grn})", [grn_rates[s] for s in shared], title,
                        [ctrl[s] for s in shared], delta=SUCCESS_DELTA_POINTS, task="success, points")
            )  # fmt: skip
    seeds = sorted(grn_rates)
    for name, title in TRIVIAL_TITLES.items():
        b = trivial.get(name)
        if b is not None:
            rate_b = 100 * float(b["successes"]) / float(b.get("n", b.get("episodes", 1)))
            comps.append(
                compare(f"GRN ({grn})", [grn_rates[s] for s in seeds], title,
                        [rate_b] * len(seeds), delta=SUCCESS_DELTA_POINTS, task="success, points")
            )  # fmt: skip
    if not comps:
        return []
    return [
        "Run-level comparisons (the unit is the evolution, SPEC §6; the Fisher and McNemar "
        "columns above describe single runs' episodes): per GRN seed, its clean test success "
        "minus the control's, an exact sign-flip test over seeds, Holm-corrected over this "
        f"table, with δ = {SUCCESS_DELTA_POINTS:g} points.",
        "",
        to_markdown(holm_table(comps), digits=1),
        "",
    ]
