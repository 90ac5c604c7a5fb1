"""The table of docs/grn.md, "A task that needs memory", from the saved per-episode files.

Usage: python docs/results/grn_memory/table.py  (reads docs/results/grn_memory/*_episodes.csv)

Each file is one `evodevo grn baselines` call on the same 40 validation-range episodes (test
seed 10000, training objects), e.g. for one object, 2 cm steps, k = 1:

    evodevo grn baselines --out docs/results/grn_memory/objects1_step2cm_k1.json \\
        --objects train --test-seed 10000 --test-episodes 40 \\
        --policies scripted,scripted_memory --set env.kwargs.num_objects=1 \\
        --set env.kwargs.lateral_dv=0.02 --set env.kwargs.dark_after=1

The memoryless scripted policy (`scripted`) and its remembering twin (`scripted_memory`) meet
the same episodes, so they are compared pairwise (exact McNemar test on the discordant pairs).
The constant turn moves no sideways and reads no image, so one measurement per object count
serves every row of that count.
"""

from __future__ import annotations

import csv
from pathlib import Path

from evodevo.stats import mcnemar_exact_counts, rate

HERE = Path(__file__).resolve().parent
#: (objects, sideways step in cm) of each setting, in table order.
SETTINGS = ((5, 6), (5, 2), (1, 6), (1, 2))


def load(path: Path) -> dict[str, list[int]]:
    """Per-episode successes of every policy in one ``*_episodes.csv``, in episode order."""
    out: dict[str, list[int]] = {}
    with path.open() as fh:
        for row in csv.DictReader(fh):
            out.setdefault(row["policy"], []).append(int(row["success"]))
    return out


def fmt(s: list[int] | None) -> str:
    if s is None:
        return "—"
    r = rate(sum(s), len(s))
    return f"{100 * r.rate:.1f} % [{100 * r.ci_low:.0f}, {100 * r.ci_high:.0f}]"


def main() -> None:
    print(
        "| objects | sideways step | k | memoryless scripted | remembering scripted "
        "| difference (discordant pairs, McNemar p) | lit scripted | constant turn |"
    )
    print("|---|---|---|---|---|---|---|---|")
    turns: dict[int, list[int]] = {}
    for path in sorted(HERE.glob("*_episodes.csv")):
        if "turn" in (d := load(path)):
            turns.setdefault(int(path.name.split("_")[0].removeprefix("objects")), d["turn"])
    for objects, step in SETTINGS:
        stem = f"objects{objects}_step{step}cm"
        lit_path = HERE / f"{stem}_lit_episodes.csv"
        lit = load(lit_path) if lit_path.is_file() else {}
        for k in (1, 2, 3):
            path = HERE / f"{stem}_k{k}_episodes.csv"
            if not path.is_file():
                continue
            d = load(path)
            a, b = d["scripted"], d["scripted_memory"]
            only_a = sum(1 for x, y in zip(a, b, strict=True) if x and not y)
            only_b = sum(1 for x, y in zip(a, b, strict=True) if y and not x)
            diff = (
                f"{100 * (sum(b) - sum(a)) / len(a):+.1f} points ({only_b} vs {only_a}, "
                f"p = {mcnemar_exact_counts(only_a, only_b):.2g})"
            )
            print(
                f"| {objects} | {step} cm | {k} | {fmt(a)} | {fmt(b)} | {diff} "
                f"| {fmt(lit.get('scripted'))} | {fmt(turns.get(objects))} |"
            )


if __name__ == "__main__":
    main()
