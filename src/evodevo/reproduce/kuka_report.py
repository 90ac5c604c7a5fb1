"""Kuka part of the reproduction report: thesis Table 4.2 per budget scale, each
baseline run paired with the trivial policies and its seed's GRN, and the runs not finished yet
(SPEC §4, §6)."""

from __future__ import annotations

from pathlib import Path

from evodevo.baselines.table_4_2 import markdown, read_run, write_table
from evodevo.errors import EvodevoError
from evodevo.reproduce.budget import ReproduceConfig
from evodevo.reproduce.run_files import (
    TRIVIAL_TITLES,
    finished,
    fmt_pair,
    kuka_run_dir,
    load_json,
    paired,
    pct,
    successes,
)
from evodevo.runs import RunDir
from evodevo.seeding import parse_seeds
from evodevo.stats import rate

__all__ = ["kuka_paired", "kuka_section", "learning_curve", "refill_notes", "unfinished_runs"]


def kuka_section(out: Path, cfg: ReproduceConfig) -> list[str]:
    """Thesis Table 4.2 per budget scale: every tested GRN run beside every tested baseline."""
    k, g = cfg.kuka, cfg.grn
    grn_dirs = sorted(p for p in (out / "grn").glob("*_s*") if p.is_dir())
    lines = [
        "## Kuka grasping baselines (thesis Table 4.2, SPEC §4)",
        "",
        f"Each baseline ({', '.join(k.methods)}; seeds {k.seeds}) trains for the environment "
        "steps its seed's GRN evolution used, times the scale in the heading, and is tested on "
        f"the same {g.test_episodes} test-object episodes as the GRN. Training time is the wall "
        "clock each run's summary.json records, on a machine that may have been shared; the GRN "
        "and NEAT can evaluate genomes in parallel worker processes, PPO and TD3 train in one "
        "process. NEAT stops at the end of the generation in which its budget runs out, so it "
        "may use up to one generation more (its env steps are in the table).",
        "",
    ]
    wrote = False
    for scale in k.budget_scales:
        dirs = [*grn_dirs]
        dirs += [kuka_run_dir(out, m, scale, s) for m in k.methods for s in parse_seeds(k.seeds)]
        tested: list[str | Path] = []
        for d in dirs:
            if not (d / "summary.json").is_file() or not finished(d / "summary.json"):
                continue  # not started, or (NEAT) still evolving: listed as unfinished below
            try:
                read_run(d)
            except EvodevoError:
                continue
            tested.append(d)
        pending = unfinished_runs([d for d in dirs if Path(d).parent.name == "kuka"], tested)
        if not any(Path(d).parent.name == "kuka" for d in tested):
            if pending:
                lines += [f"### Budget {scale:g}× the GRN's environment steps", "", *pending, ""]
            continue
        table, runs = write_table(tested, out / "kuka" / f"table_x{scale:g}")
        title = f"### Budget {scale:g}× the GRN's environment steps"
        lines += [markdown(table, runs, 0.5, title=title), ""]
        lines += [*pending, ""] if pending else []
        baselines = [Path(d) for d in tested if Path(d).parent.name == "kuka"]
        lines += refill_notes(baselines)
        lines += kuka_paired(out, cfg, baselines)
        lines += [f"#### Where we differ and why ({scale:g}×)", ""]
        for r in table:
            if r.thesis_success is None:
                continue
            inside = 100 * r.ci_low <= r.thesis_success <= 100 * r.ci_high
            lines.append(
                f"- {r.method}: {100 * r.success_rate:.1f} % [{100 * r.ci_low:.1f}, "
                f"{100 * r.ci_high:.1f}] over {r.episodes} held-out-object episodes "
                f"({r.runs} run{'s' if r.runs > 1 else ''}, {r.env_steps:.0f} env steps per run) vs the "
                f"thesis' {r.thesis_success:.1f} % over {r.thesis_episodes:.0f} episodes: the "
                f"thesis' value lies {'inside' if inside else 'outside'} our interval."
            )
        lines += [
            "- The thesis gave its baselines other budgets than its GRN (its Table 4.1); here every "
            f"baseline gets its seed's GRN env steps (× {scale:g}), so the training times measure "
            "the methods' cost per env step on this machine, not a budget choice.",
            "",
        ]
        wrote = True
    if not wrote:
        lines += [
            "(no tested Kuka baseline yet: the baseline steps were not run or did not finish)",
            "",
        ]
    return lines


def learning_curve(d: Path) -> list[tuple[int, float]]:
    """(env steps, training-time success) rows of a baseline run's ``learning_curve.csv``."""
    if not (d / "learning_curve.csv").is_file():
        return []
    rows = RunDir(d, create=False).read_csv("learning_curve.csv")
    return [(int(float(r["env_steps"])), float(r["success"])) for r in rows]


def refill_notes(run_dirs: list[Path]) -> list[str]:
    """One line per TD3 run that resumed without its replay buffer (not an uninterrupted run).

    Replay buffers (~0.7 GB) are never committed, so a TD3 run resumed in a fresh checkout
    refills its buffer (:func:`evodevo.baselines.sb3_kuka.refill_replay_buffer`); its summary's
    ``replay_buffer_refilled_at`` lists the env steps at which that happened.
    """
    lines = []
    for d in run_dirs:
        at = (load_json(d / "summary.json") or {}).get("replay_buffer_refilled_at") or []
        if at:
            steps = ", ".join(f"{int(x):,}" for x in at)
            lines.append(
                f"- `{d.name}` is not an uninterrupted run: it was resumed at {steps} env steps "
                "without its replay buffer (buffers are not committed), which SB3 refilled as at a "
                "run's start (learning_starts random-action steps, no update) before training "
                "went on from the checkpoint's networks."
            )
    return [*lines, ""] if lines else []


def unfinished_runs(expected: list[Path], tested: list[str | Path]) -> list[str]:
    """One line naming the budget's baseline runs that are not in the table, with their progress.

    A run without a tested ``summary.json`` is either in progress (its learning curve shows the
    env steps reached, against the budget in its ``config.json``) or not started.
    """
    done = {Path(d) for d in tested}
    parts = []
    for d in expected:
        if d in done:
            continue
        budget = ((load_json(d / "config.json") or {}).get("config", {}).get("budget") or {}).get(
            "env_steps"
        )
        rows = learning_curve(d)
        if rows:
            of = f" of {int(budget):,}" if budget else ""
            parts.append(f"`{d.name}` (in progress: {rows[-1][0]:,}{of} env steps)")
        else:
            parts.append(f"`{d.name}` (not started)")
    if not parts:
        return []
    return [
        "Not in this table because they have not finished (their checkpoints resume them): "
        + ", ".join(parts)
        + "."
    ]


def kuka_paired(out: Path, cfg: ReproduceConfig, run_dirs: list[Path]) -> list[str]:
    """Each tested baseline run against the trivial policies and the GRN on the same episodes.

    Differences in points with the exact McNemar p (SPEC §2.5: every table carries its trivial
    baselines); the GRN is the first controller's run of the same seed (whose env steps set the
    baseline's budget). Runs without a per-episode file are left out.
    """
    gdir = out / "grn"
    g = cfg.grn
    triv = {n: successes(gdir / "baselines_test_episodes.csv", n) for n in TRIVIAL_TITLES}
    rows = []
    turn_cells: list[tuple[float, float]] = []
    fell: list[str] = []
    for d in run_dirs:
        res = load_json(d / "repro_test_clean.json")
        ep = successes(d / "eval_test_0_episodes.csv", "genome")
        summ = load_json(d / "summary.json") or {}
        conf = (load_json(d / "config.json") or {}).get("config", {})
        if res is None or ep is None:
            continue
        seed = int(conf.get("seed", -1))
        gs = successes(
            gdir / f"{g.controllers[0]}_s{seed}" / "eval_test_0.03_episodes.csv", "genome"
        )
        pairs = {name: paired(ep, triv.get(name)) for name in TRIVIAL_TITLES}
        cells = [fmt_pair(pr) for pr in (*pairs.values(), paired(ep, gs))]
        turn = pairs.get("turn")
        if turn is not None:
            turn_cells.append(turn)
        curve = [s for _, s in learning_curve(d)]
        train = f"{max(curve):.2f} / {curve[-1]:.2f}" if curve else "—"
        if curve and max(curve) - curve[-1] >= 0.3:
            fell.append(
                f"{conf.get('method', d.name)} seed {seed} ({max(curve):.2f} → {curve[-1]:.2f})"
            )
        rows.append(
            f"| {conf.get('method', d.name)} | {seed} | {summ.get('env_steps', '?')} | {train} | "
            f"{pct(res)} | " + " | ".join(cells) + " |"
        )
    if not rows:
        return []
    heads = " | ".join(f"− {TRIVIAL_TITLES[n].split(' (')[0]}" for n in TRIVIAL_TITLES)
    rates = []
    for name, title in TRIVIAL_TITLES.items():
        t = triv.get(name)
        if t:
            rates.append(f"{title} {rate(sum(t), len(t)).fmt()}")
    above = sum(1 for c in turn_cells if c[0] > 0 and c[1] < 0.05)
    below = sum(1 for c in turn_cells if c[0] < 0 and c[1] < 0.05)
    return [
        "Paired on the same test episodes: the run's success minus the policy's, in points "
        "(exact McNemar p, uncorrected). GRN: the plain GRN of the same seed, whose env steps set "
        "the budget. Training success: the training-object success of the run's periodic "
        "evaluations (PPO, TD3) or best genome per generation (NEAT), best and last. Trivial "
        "policies on these episodes: " + "; ".join(rates) + ".",
        "",
        f"| run | seed | env steps | training success best / last | success [95 % CI] | {heads} "
        "| − GRN same seed |",
        "|---|---|---|---|---|" + "---|" * (len(TRIVIAL_TITLES) + 1),
        *rows,
        "",
        f"Against the constant turn, {above} of {len(turn_cells)} runs are significantly better "
        f"and {below} significantly worse (McNemar p < 0.05, uncorrected).",
        "",
    ] + (
        [
            "Training success fell by 0.3 or more from its best to its last evaluation in "
            + ", ".join(fell)
            + " (each evaluation is a few training-object episodes, 10 for PPO and TD3, so one "
            "value is uncertain by about ±0.3; the test column is the measurement). The tested "
            "policy is the last one (PPO, TD3: the final model; NEAT: the last generation's best "
            "genome; no checkpoint is selected), so longer training can test worse.",
            "",
        ]
        if fell
        else []
    )
