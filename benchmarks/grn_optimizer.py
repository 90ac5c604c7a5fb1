"""Time to a grasping controller: evolve the vision preset with the GA or CMA-ES against a
wall-clock budget, then test the returned genome on the locked test episodes.

The question it measures: does ``evolution.optimizer`` (or any ``--set`` change, e.g. an arm of
"does regulation help?") give a controller that grasps >= 70 % of held-out-object episodes
within 15 minutes of wall time on 2 cores?

* **Setup** (counted in the wall time): the vision preset (``configs/grn_vision.yaml``, the
  default of ``evodevo grn evolve``) with ``--optimizer`` and ``--set`` overrides; the blob
  front-end's calibration; the evaluator's ``--workers`` processes.
* **Evolution**: generations run one after another while the next one still fits before the
  deadline, ``--minutes`` after the start: a generation starts only if the longest one so far
  would end by then (the first always runs), so the genome is returned within the budget — or
  until the config's generations are spent (``--generations``, default 1000, i.e. only the
  clock stops it). The returned genome follows the preset's ``evolution.keep`` rule
  (``record``) and its early stop. (Until 2026-12-07 a generation started before the deadline
  ran to its end, which overran the budget by up to one generation: 8-23 s.)
* **Test** (not counted): ``--test-episodes`` clean episodes on held-out objects, seeds from
  ``evaluation.test_seed`` (1000000.., the locked test range of SPEC §6), success with its
  Wilson 95 % interval. One run is one seed; comparing optimisers needs several (SPEC §6).

It is not part of ``python -m benchmarks`` (a full run takes the budget plus the test, about
25 minutes on 2 cores). ``--quick`` is a smoke run (4 genomes x 1 episode, 2 generations at
most, 4 test episodes) that checks the script works, not the optimiser.

Usage::

    python benchmarks/grn_optimizer.py --optimizer cmaes --minutes 15 --workers 2 [--seed 0]
        [--test-episodes 200] [--set key=value ...] [--out DIR] [--json] [--quick]

With ``--out`` the run folder is a normal ``grn evolve`` run (config, front-end, history,
best genome, summary, checkpoints), so ``evodevo grn evaluate DIR`` works on it. The last line
of output is JSON: optimizer, seed, generations and episodes run, setup/evolution/test seconds,
``wall_to_controller_s``, evaluation episodes per second, the training success of the returned
genome and its test success with interval, and ``reached_target`` (test success >= --target).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["run", "main"]


def run(
    optimizer: str = "cmaes",
    minutes: float = 15.0,
    workers: int = 2,
    seed: int = 0,
    test_episodes: int = 200,
    generations: int = 1000,
    overrides: list[str] | None = None,
    out: str | Path | None = None,
    target: float = 0.7,
    quick: bool = False,
    progress: bool = True,
) -> dict[str, Any]:
    """Evolve against the clock and test the returned genome; see the module docstring.

    Args:
        optimizer: ``evolution.optimizer`` (ga or cmaes).
        minutes: wall-clock budget from the start to the returned genome.
        workers: evaluator worker processes.
        seed: run seed.
        test_episodes: locked test episodes on held-out objects.
        generations: most generations (the clock normally stops first).
        overrides: ``key.sub=value`` config changes (as ``grn evolve --set``).
        out: run folder to keep (default: a temporary one).
        target: test success that counts as reached.
        quick: smoke budget.
        progress: one line per generation on stderr.
    """
    from evodevo.config import load_config, merge, parse_sets, to_dict
    from evodevo.grn.config import GrnConfig
    from evodevo.grn.controller import make_controller
    from evodevo.grn.evaluation import rate_dict
    from evodevo.grn.evaluation import test_episodes as locked_test_episodes
    from evodevo.grn.evaluator import Evaluator
    from evodevo.grn.evolution import Checkpointer, Evolution, ProgressPrinter
    from evodevo.grn.frontends import make_frontend, save_frontend
    from evodevo.grn.vision_preset import vision_preset
    from evodevo.parallel import set_single_thread
    from evodevo.runs import RunDir

    if quick:
        generations, test_episodes = min(generations, 2), min(test_episodes, 4)
    ov: dict[str, Any] = {
        "seed": seed,
        "evolution": {"optimizer": optimizer, "generations": generations},
    }
    if quick:
        ov["evolution"].update(population=4)
        ov["evaluation"] = {"episodes": 1}
    cfg = load_config(GrnConfig, None, merge(merge(vision_preset(), ov), parse_sets(overrides)))
    set_single_thread()
    folder = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix="grn_optimizer_"))
    t0 = time.perf_counter()
    run_dir = RunDir(folder)
    frontend = make_frontend(cfg)
    save_frontend(frontend, run_dir.path)
    run_dir.write_config(to_dict(cfg), kind="grn")
    with Evaluator(cfg, frontend, workers=workers) as ev:
        hooks: list[Any] = [Checkpointer(run_dir)]
        if progress:
            hooks.append(ProgressPrinter())
        evo = Evolution(cfg, make_controller(cfg, ev.n_actions), ev, hooks)
        t_setup = time.perf_counter() - t0
        deadline = t0 + 60.0 * minutes
        longest = 0.0  # the longest generation so far: the next one must fit before the deadline
        while not evo.done and (not evo.history or time.perf_counter() + longest <= deadline):
            g0 = time.perf_counter()
            evo.step()
            longest = max(longest, time.perf_counter() - g0)
        evo.finish()
        wall = time.perf_counter() - t0
        t1 = time.perf_counter()
        eps = locked_test_episodes(cfg.evaluation.test_seed, test_episodes, test_objects=True)
        res = ev.evaluate([evo.best_genome], eps)
        test_s = time.perf_counter() - t1
    test = rate_dict(res.success[0])
    eval_s = sum(r.eval_s for r in evo.history)
    last = evo.history[-1] if evo.history else None
    return {
        "optimizer": cfg.evolution.optimizer,
        "controller": cfg.controller,
        "seed": cfg.seed,
        "workers": workers,
        "budget_minutes": minutes,
        "generations_run": evo.generation,
        "stopped_by": "early stop"
        if evo.stopped_early
        else ("generations" if evo.done else "clock"),
        "episodes_run": evo.episodes_run,
        "setup_s": round(t_setup, 1),
        "evolve_s": round(wall - t_setup, 1),
        "wall_to_controller_s": round(wall, 1),
        "within_budget": bool(wall <= 60.0 * minutes),
        "longest_generation_s": round(longest, 1),
        "episodes_per_s": round(evo.episodes_run / eval_s, 3) if eval_s > 0 else None,
        "kept": cfg.evolution.keep,
        "champion": evo.champion_record(),
        "last_best_training_success": last.best_success if last else None,
        "test_episodes": test_episodes,
        "test_seed": cfg.evaluation.test_seed,
        "test": test,
        "test_s": round(test_s, 1),
        "target": target,
        "reached_target": bool(test["success_rate"] >= target),
        "run_dir": str(folder),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--optimizer", default="cmaes", choices=["ga", "cmaes"])
    ap.add_argument("--minutes", type=float, default=15.0, help="wall-clock budget [15]")
    ap.add_argument("--workers", type=int, default=2, help="evaluator processes [2]")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--test-episodes", type=int, default=200)
    ap.add_argument("--generations", type=int, default=1000, help="most generations [1000]")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--target", type=float, default=0.7, help="test success to reach [0.7]")
    ap.add_argument("--out", type=Path, default=None, help="keep the run folder here")
    ap.add_argument("--quick", action="store_true", help="smoke run (seconds, meaningless)")
    ap.add_argument("--json", action="store_true", help="print only the JSON line")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    res = run(
        optimizer=args.optimizer,
        minutes=args.minutes,
        workers=args.workers,
        seed=args.seed,
        test_episodes=args.test_episodes,
        generations=args.generations,
        overrides=args.overrides,
        out=args.out,
        target=args.target,
        quick=args.quick,
        progress=not args.json,
    )
    if not args.json:
        t = res["test"]
        print(
            f"{res['optimizer']}: {res['generations_run']} generations in "
            f"{res['wall_to_controller_s']:.0f} s ({res['stopped_by']}); test "
            f"{t['successes']}/{t['n']} = {t['success_rate']:.3f} "
            f"[{t['ci_low']:.3f}, {t['ci_high']:.3f}]",
            file=sys.stderr,
        )
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
