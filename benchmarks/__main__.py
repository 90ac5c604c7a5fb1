"""Run every benchmark and print one JSON object: ``python -m benchmarks [--quick] [--json]``.

Each benchmark measures a *ratio* within one run (the machines are shared and noisy, so
absolute times drift while ratios measured side by side hold). A benchmark that cannot run here
(e.g. the original Kuka environment is not installed in its isolated venv) reports why instead
of a number.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
import traceback
from typing import Any

#: module name -> what it measures
SUITE = {
    "biarm_overhead": "BIARM time per training step / plain PNN's (SPEC §1.3; thesis +52-87 %)",
    "biarm_floor": "BIARM / PNN parameters, update FLOPs (the method's floor) and our update's time",
    "biarm_adam": "direct fused Adam call / Adam.step() per BIARM column, and its share of an update",
    "dqn_throughput": "our DQN training steps/s / Stable-Baselines3 DQN's, same network and schedule",
    "env_speed": "our KukaDiverseObject-v0 episodes/s / the original pybullet_envs class's",
    "evolution_speed": "Kuka episodes/CPU-s with the settled-scene cache and the skipped lift "
    "/ the port before them: one thesis generation (12 genomes x 10 seeds; also with dedupe) "
    "and the 7-policy test",
    "grn_step": "share of a Kuka env step spent in the GRN controller (encoder + dynamics)",
    "scaling": "GRN evolution speed-up with 2 worker processes and with 2 Ray actors vs 1 worker",
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small budgets (under two minutes)")
    parser.add_argument("--json", action="store_true", help="print only the JSON object")
    parser.add_argument("--only", default="", help="comma-separated subset of: " + ", ".join(SUITE))
    args = parser.parse_args(argv)
    names = [n for n in args.only.split(",") if n] or list(SUITE)
    unknown = [n for n in names if n not in SUITE]
    if unknown:
        parser.error(f"unknown benchmark {unknown[0]!r}; choose from {', '.join(SUITE)}")
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
    results: dict[str, Any] = {}
    for name in names:
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(f"benchmarks.{name}")
            res = dict(mod.run(quick=args.quick))
        except Exception as exc:  # noqa: BLE001 - report and go on with the other benchmarks
            res = {"error": f"{type(exc).__name__}: {exc}"}
            if not args.json:
                traceback.print_exc()
        res["seconds"] = round(time.perf_counter() - t0, 1)
        res["measures"] = SUITE[name]
        results[name] = res
        if not args.json:
            print(f"{name}: {json.dumps(res)}", file=sys.stderr, flush=True)
    print(json.dumps(results))
    return 0 if not any("error" in r for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
