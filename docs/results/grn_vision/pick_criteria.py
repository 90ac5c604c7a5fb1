"""Which criterion should the final pick use? Success, or the reach the shaped fitness reads.

Issue 22, 2026-12-05 (docs/results/history.md, "The final pick, paid from the budget"). For a
run evolved with ``evolution.final_pick_episodes``, re-runs its final pick exactly (the elites
bred after the last generation, the same fresh clean episodes of seed stream
``FINAL_PICK_KEY``), this time also reading the gripper-to-nearest-object distance when the
automatic grasp starts (the reach; simulator, training only). Prints per elite: successes (must
equal the run's own ``final_pick.successes``), mean reach, and the elite each criterion would
keep. ``--test RANK`` also tests that elite on the
usual 200 held-out-object episodes (test seed 10000).

Run: ``python docs/results/grn_vision/pick_criteria.py RUN_DIR [--test RANK]``; writes
``RUN_DIR/pick_criteria.json`` (and ``RUN_DIR/pick_criteria_test_RANK_episodes.csv``).
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np
from final_pick import checkpoint_evolution  # this folder's script

from evodevo.config import replace
from evodevo.grn.evaluation import load_run, test_episodes
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.evolution import FINAL_PICK_KEY, training_episodes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--test", type=int, default=None, help="test this elite rank on 200 episodes")
    args = ap.parse_args()
    lr = load_run(args.run)
    cfg = lr.config
    evo = checkpoint_evolution(cfg, args.run)
    pick = evo.final_pick
    if not pick:
        raise SystemExit(f"{args.run} made no final pick (evolution.final_pick_episodes 0)")
    elites = evo.population[: cfg.evolution.elites]
    eps = training_episodes(
        cfg.seed, FINAL_PICK_KEY, pick["after_generation"], pick["episodes"], 0.0
    )
    out: dict[str, object] = {"run_pick": pick}
    with Evaluator(cfg, lr.encoder, workers=1) as ev:
        c = replace(cfg, evaluation=replace(cfg.evaluation, distance_at="grasp"))
        res = ev.evaluate(elites, eps, config=c, measure_distance=True)
        wins = res.success.sum(axis=1).astype(int)
        if wins.tolist() != pick["successes"]:
            raise SystemExit(f"successes {wins.tolist()} differ from the run's pick {pick}")
        assert res.distance is not None
        reach = np.nanmean(res.distance, axis=1)
        out["successes"] = wins.tolist()
        out["reach_cm"] = [round(100 * float(d), 2) for d in reach]
        out["pick_by_success"] = int(np.argmax(wins))
        out["pick_by_reach"] = int(np.argmin(reach))
        if args.test is not None:
            test = test_episodes(cfg.evaluation.test_seed, 200, True)
            succ = ev.evaluate([elites[args.test]], test).success[0].astype(int)
            out[f"test_rank_{args.test}"] = int(succ.sum())
            name = f"pick_criteria_test_{args.test}_episodes.csv"
            with open(args.run / name, "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["policy", "episode", "seed", "success"])
                for i, (e, s) in enumerate(zip(test, succ, strict=True)):
                    w.writerow(["genome", i, e.seed, int(s)])
    path = args.run / "pick_criteria.json"
    old = json.loads(path.read_text()) if path.is_file() else {}
    path.write_text(json.dumps({**old, **out}, indent=2) + "\n")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
