"""CartPole as the thesis sequence's first task (d_max 8), final greedy return per protocol and
seed (issue 21). Usage: python docs/results/biarm_sweep/cp_testbed/table.py

A run is ``docs/results/biarm_sweep/testbed.sh CartPole-v1 NAME VARIANT``: ``evodevo biarm train --variant V --tasks
CartPole-v1 --seed S --set network.d_max=8 [overrides]``, which gives the first column of a
full 4-task run bit for bit (PNN seed 1: 258.6 in both, after 40,252 steps). Columns: kept
network on the 20 evaluation seeds @ the episode it was validated at; the last network's mean on
the same seeds; validation checks that scored 500 out of all checks.
"""

import csv
import json
from pathlib import Path

root = Path(__file__).parent
rows: dict[str, dict[int, dict[str, float]]] = {}
for d in sorted(root.glob("*__s*")):
    if not (d / "summary.json").is_file():
        continue
    name, s = d.name.rsplit("__s", 1)
    t = json.loads((d / "summary.json").read_text())["tasks"][0]
    last = t["validation"]["last_network_returns"]
    with (d / "validation.csv").open() as f:
        checks = [float(r["return"]) for r in csv.DictReader(f)]
    rows.setdefault(name, {})[int(s)] = {
        "kept": t["final_return"],
        "at": t["validation"]["best_episode"],
        "last": sum(last) / len(last),
        "hits": sum(c >= 500 for c in checks),
        "checks": len(checks),
    }
print(
    "| protocol_variant | kept, mean | per seed: kept @ episode | last network, mean | checks at 500 |"
)
print("|---|---|---|---|---|")
for name, r in rows.items():
    n = len(r)
    kept = sum(v["kept"] for v in r.values()) / n
    last = sum(v["last"] for v in r.values()) / n
    per = ", ".join(f"{v['kept']:.1f} @ {v['at']:.0f}" for _, v in sorted(r.items()))
    hits = sum(v["hits"] for v in r.values())
    checks = sum(v["checks"] for v in r.values())
    print(f"| {name} (n={n}) | {kept:.1f} | {per} | {last:.1f} | {hits} of {checks} |")
