"""Evolution scaling: GRN evolution wall time with 1 and 2 worker processes and with
2 Ray actors, on the same seed, as speed-up ratios measured in one run.

    python benchmarks/scaling.py --json [--quick]

The last line is ``{"speedup_pool2": t1 / t_pool2, "speedup_ray2": t1 / t_ray2,
"ray_vs_pool": t_ray2 / t_pool2, "ray_start_s": ..., "same_history": ..., "*_steady": ...}``;
the ``_steady`` ratios compare the evaluation time of generations 2.. only, i.e. without
starting the worker processes / actors and their environments, which a long evolution pays
once. The local Ray
instance is started before its evolution is timed (as a cluster is already running) and its
start-up time is reported separately. ``same_history`` checks that the three
runs produced identical fitness histories (the result must not depend on the backend). On a
2-core machine the ceiling is 2x; anything else running on the machine lowers it.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any


def _evolve(
    backend: str, workers: int, population: int, episodes: int, generations: int, out: Path
) -> tuple[float, list[float], float]:
    """Wall time, fitness history, and the evaluation seconds of generations 2.. (steady state:
    the first generation also pays for starting the workers and their environments)."""
    from evodevo.config import load_config
    from evodevo.grn.config import GrnConfig
    from evodevo.grn.evolution import evolve_run

    cfg = load_config(
        GrnConfig,
        None,
        {
            "seed": 0,
            # no early-stop retest: its 20 extra episodes would come whenever a 1-episode
            # evaluation happens to succeed, so the workload would depend on luck
            "evolution": {
                "population": population,
                "generations": generations,
                "early_stop": False,
            },
            "evaluation": {"episodes": episodes},
        },
    )
    t0 = time.perf_counter()
    summary = evolve_run(cfg, out, workers=workers, backend=backend, progress=False)
    wall = time.perf_counter() - t0
    with (out / "history.csv").open() as fh:
        steady = sum(float(r["eval_s"]) for r in list(csv.DictReader(fh))[1:])
    return wall, [float(f) for f in summary["fitness_history"]], steady


def run(quick: bool = False) -> dict[str, Any]:
    """Time the same evolution on 1 worker, a 2-process pool and 2 Ray actors."""
    from evodevo.parallel import set_single_thread

    set_single_thread()
    population, episodes, generations = (4, 1, 2) if quick else (8, 4, 3)
    res: dict[str, Any] = {
        "population": population,
        "episodes": episodes,
        "generations": generations,
    }
    with tempfile.TemporaryDirectory() as tmp:
        t1, h1, s1 = _evolve("local", 1, population, episodes, generations, Path(tmp) / "w1")
        t2, h2, s2 = _evolve("local", 2, population, episodes, generations, Path(tmp) / "w2")
        res.update(
            seconds_1=round(t1, 2),
            seconds_pool2=round(t2, 2),
            speedup_pool2=round(t1 / t2, 3),
            speedup_pool2_steady=round(s1 / s2, 3),
        )
        same = h1 == h2
        try:
            import ray
        except ImportError:
            res["ray"] = "not installed (pip install 'evodevo[ray]')"
        else:
            # Start the local Ray instance first (what a running cluster already is), timed
            # on its own: the evolution then pays only for its actors, as the pool pays only
            # for its processes. The evolution reuses the running instance (RayPool).
            t0 = time.perf_counter()
            from evodevo.ray_pool import local_ray_options

            ray.init(include_dashboard=False, log_to_driver=False, **local_ray_options(2))
            res["ray_start_s"] = round(time.perf_counter() - t0, 2)
            try:
                tr, hr, sr = _evolve("ray", 2, population, episodes, generations, Path(tmp) / "r2")
            finally:
                ray.shutdown()
            res.update(
                seconds_ray2=round(tr, 2),
                speedup_ray2=round(t1 / tr, 3),
                ray_vs_pool=round(tr / t2, 3),
                speedup_ray2_steady=round(s1 / sr, 3),
                ray_vs_pool_steady=round(sr / s2, 3),
            )
            same = same and h1 == hr
        res["same_history"] = same
    return res


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--json", action="store_true")
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    res = run(quick=args.quick)
    if not args.json:
        for k, v in res.items():
            print(f"{k}: {v}", file=sys.stderr)
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
