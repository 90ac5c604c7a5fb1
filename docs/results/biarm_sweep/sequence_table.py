"""Per-seed table of a full-sequence BIARM/PNN grid (issue 21; SPEC §1.7), for docs/results/biarm.md.

    python docs/results/biarm_sweep/sequence_table.py docs/results/thesis/biarm_scaled

For every finished run (``runs/<variant>__s<seed>/summary.json``): the final greedy return per
task on the 20 evaluation seeds, the MountainCar training episodes that reached the flag
(return > −200, from ``metrics.csv``) and the run's CPU minutes (summed over resumed sessions
when ``timing_complete``; else marked "≥"). Then per task: the mean over seeds of each variant,
the thesis' Table 3.2, and BIARM − PNN paired by seed with the exact sign-flip test.

    python docs/results/biarm_sweep/sequence_table.py docs/results/thesis/biarm_pertask --versus biarm

adds a table of every variant's mean ± std per task and its difference from the ``--versus``
variant, paired by seed (exact sign-flip p), for the ablations and the continual baselines.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

from evodevo.neuromod.thesis_numbers import TABLE_3_2
from evodevo.stats import permutation_test

ENVS = ("CartPole-v1", "Acrobot-v1", "MountainCar-v0", "LunarLander-v3")


def _flags(run: Path) -> int:
    with (run / "metrics.csv").open() as f:
        return sum(
            1
            for r in csv.DictReader(f)
            if r["env_id"] == "MountainCar-v0" and float(r["return"]) > -200
        )


def _mean_std(v: list[float]) -> str:
    m = sum(v) / len(v)
    sd = (sum((x - m) ** 2 for x in v) / (len(v) - 1)) ** 0.5 if len(v) > 1 else 0.0
    return f"{m:.1f} ± {sd:.1f}"


def versus_table(finals: dict[str, dict[int, dict[str, float]]], ref: str) -> None:
    """Every variant's mean ± std per task, and its paired difference from ``ref``."""
    if ref not in finals:
        raise SystemExit(f"--versus {ref!r}: no finished run of that variant in the grid")
    others = [v for v in finals if v != ref]
    print()
    print(f"| task | {ref} (n) | " + " | ".join(f"{v} (n; − {ref}, p)" for v in others) + " |")
    print("|---" * (len(others) + 2) + "|")
    for e in ENVS:
        base = {k: r[e] for k, r in finals[ref].items() if e in r}
        cells = [f"{_mean_std(list(base.values()))} ({len(base)})"]
        for v in others:
            runs = {k: r[e] for k, r in finals[v].items() if e in r}
            if not runs:
                cells.append("–")
                continue
            seeds = sorted(set(runs) & set(base))
            cell = f"{_mean_std(list(runs.values()))} ({len(runs)}"
            if len(seeds) >= 2:
                d = sum(runs[k] - base[k] for k in seeds) / len(seeds)
                p = permutation_test(
                    [runs[k] for k in seeds], [base[k] for k in seeds], paired=True
                )
                cell += f"; {d:+.1f}, p = {p:.2g}"
            cells.append(cell + ")")
        print(f"| {e} | " + " | ".join(cells) + " |")


def main(grid: Path, versus: str | None = None) -> None:
    finals: dict[str, dict[int, dict[str, float]]] = {}
    print(
        "| run | " + " | ".join(e.split("-")[0] for e in ENVS) + " | MountainCar flags | CPU min |"
    )
    print("|---" * (len(ENVS) + 3) + "|")
    for run in sorted((grid / "runs").glob("*__s*")):
        if not (run / "summary.json").is_file():
            continue
        s = json.loads((run / "summary.json").read_text())
        by_env = {t["env_id"]: float(t["final_return"]) for t in s["tasks"]}
        finals.setdefault(s["variant"], {})[int(s["seed"])] = by_env
        if "cpu_seconds" in s:
            mark = "" if s.get("timing_complete", False) else "≥ "
            cost = f"{mark}{s['cpu_seconds'] / 60:.1f}"
        else:  # sb3-dqn's summary records wall time only
            cost = f"{s['wall_seconds'] / 60:.1f} (wall)"
        cells = " | ".join(f"{by_env.get(e, float('nan')):.2f}" for e in ENVS)
        print(f"| {run.name} | {cells} | {_flags(run)} of 800 | {cost} |")
    print()
    print(
        "| task | PNN mean (n) | BIARM mean (n) | thesis PNN / BIARM | BIARM − PNN paired (p; seeds higher) |"
    )
    print("|---|---|---|---|---|")
    for e in ENVS:
        pnn = {k: v[e] for k, v in finals.get("pnn", {}).items() if e in v}
        bi = {k: v[e] for k, v in finals.get("biarm", {}).items() if e in v}
        seeds = sorted(set(pnn) & set(bi))
        diff = "–"
        if len(seeds) >= 2:
            d = [bi[k] - pnn[k] for k in seeds]
            p = permutation_test([bi[k] for k in seeds], [pnn[k] for k in seeds], paired=True)
            diff = f"{sum(d) / len(d):+.1f} (p = {p:.2g}; {sum(x > 0 for x in d)}/{len(d)})"
        th = TABLE_3_2.get(e)
        thesis = f"{th['pnn'][0]:.1f} / {th['biarm'][0]:.1f}" if th else "–"

        def mean(v: dict[int, float]) -> str:
            return f"{sum(v.values()) / len(v):.1f} ({len(v)})" if v else "–"

        print(f"| {e} | {mean(pnn)} | {mean(bi)} | {thesis} | {diff} |")
    if versus:
        versus_table(finals, versus)


if __name__ == "__main__":
    args = sys.argv[1:]
    ref = None
    if "--versus" in args:
        i = args.index("--versus")
        ref = args[i + 1]
        del args[i : i + 2]
    main(Path(args[0] if args else "docs/results/thesis/biarm_scaled"), ref)
