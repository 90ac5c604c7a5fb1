"""Kuka episodes per CPU-second with and without the settled-scene cache (issue 24; SPEC §2.4-2.5).

Two workloads of the thesis protocol, each run by the GRN evaluator in this process (one
worker, lockstep 4, as ``evodevo grn evolve``/``evaluate`` run them), once with
``scene_cache=False`` (every reset drops and settles its objects) and once with a fresh, empty
settled-scene cache (the first reset of a drop settles it, later ones place it):

* **generation**: one generation, 12 genomes (an evolved genome and 11 mutants of it) × 10
  common episode seeds (3 of them with visual noise), training objects; a third arm,
  ``cached_dedupe``, adds ``evaluation.dedupe``: a mutant whose mutation changed nothing (a
  clone of the evolved genome, :func:`evodevo.grn.evaluator.genome_key`) is not run again but
  gets its twin's results, as the evaluator does for one generation's call (its episodes count
  as scored, so its rate is episodes scored per CPU-second);
* **test**: the 200-episode test (fixed test seeds, held-out objects) of one policy, repeated
  for 7 policies: the evolved GRN, its noisy twin, the all-zero, uniform-random and
  constant-turn policies, and two mutants of the GRN (stand-ins for ablated genomes).

The arms alternate genome by genome (policy by policy), so all see the same machine load.
Rates are episodes per second of process CPU time; ``ratio`` = cached / uncached,
``ratio_dedupe`` = cached_dedupe / uncached. The cached and uncached arms
play the same seeds and actions: ``same_success`` counts the episodes whose success is the same
in both (the uncached arm settles the objects in the episode's own world, whose contact caches
the episode inherits, so single outcomes can differ; docs/kuka_env.md, "Settled-scene cache").

Usage::

    python benchmarks/evolution_speed.py [--quick] [--seeds N] [--test-seeds N] [--no-test] [--json]

The last line of output is JSON. ``--quick`` (a smoke run for ``python -m benchmarks --quick``;
its ratios mean little): 2 genomes × 1 seed and 2 policies × 1 seed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import time
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["DEFAULT_RUN", "run", "main"]

#: A committed thesis-protocol GRN run (plain controller, CNN encoder): its evolved genome.
DEFAULT_RUN = Path(__file__).resolve().parents[1] / "docs/results/thesis/grn/plain_s1"


def _load(run_dir: Path) -> tuple[Any, Any, Any, Any]:
    """(config, encoder, controller, evolved genome) of a GRN run, or of a fresh one."""
    from evodevo.grn.controller import make_controller

    try:
        from evodevo.grn.evaluation import load_run

        loaded = load_run(run_dir)
        config, encoder, genome = loaded.config, loaded.encoder, loaded.genome
        controller = make_controller(config, 3)
    except Exception:  # noqa: BLE001 - no committed run: random genomes time the same physics
        from evodevo.config import load_config
        from evodevo.grn.config import GrnConfig
        from evodevo.grn.encoder import Encoder

        root = Path(__file__).resolve().parents[1]
        config = load_config(GrnConfig, root / "configs/grn.yaml")
        encoder = Encoder.from_seed(config.seed)
        controller = make_controller(config, 3)
        genome = controller.init_genome(np.random.default_rng(0))
    return config, encoder, controller, genome


def _with_env(config: Any, **kwargs: Any) -> Any:
    env = dataclasses.replace(config.env, kwargs={**config.env.kwargs, **kwargs})
    return dataclasses.replace(config, env=env)


def run(
    quick: bool = False,
    genomes: int | None = None,
    seeds: int | None = None,
    policies: int | None = None,
    test_seeds: int | None = None,
    run_dir: str | Path = DEFAULT_RUN,
    test: bool = True,
) -> dict[str, Any]:
    """Time both workloads cached and uncached; see the module docstring.

    Args:
        quick: Smoke budgets (2 genomes × 1 seed, 2 policies × 1 seed).
        genomes: Genomes of the generation (default 12).
        seeds: Common episode seeds of the generation (default 10).
        policies: Policies of the test, at most 7 (default 7).
        test_seeds: Test episodes per policy (default 200).
        run_dir: GRN run whose evolved genome, encoder and config are used.
        test: also time the test workload (False: the generation only).

    Returns:
        Per workload: episodes, CPU seconds and episodes per CPU-second of every arm, the
        ``ratio`` (and for the generation ``ratio_dedupe``, ``clones``, ``dedupe_same``: the
        dedupe arm's outcomes equal the cached arm's), ``same_success`` and the cache's hits
        and misses; ``max_rss_mib``.
    """
    from evodevo.envs.scene_cache import SceneCache
    from evodevo.grn.evaluation import test_episodes
    from evodevo.grn.evaluator import Evaluator, genome_key
    from evodevo.grn.evolution import EPISODE_KEY, training_episodes

    n_gen = genomes if genomes is not None else (2 if quick else 12)
    n_seeds = seeds if seeds is not None else (1 if quick else 10)
    n_pol = min(policies if policies is not None else (2 if quick else 7), 7)
    n_test = test_seeds if test_seeds is not None else (1 if quick else 200)
    config, encoder, controller, best = _load(Path(run_dir))
    rng = np.random.default_rng(24)
    population = [best] + [controller.mutate(best, rng) for _ in range(n_gen - 1)]
    train = training_episodes(
        config.seed, EPISODE_KEY, 0, n_seeds, config.evaluation.noisy_fraction
    )
    res: dict[str, Any] = {"run": str(run_dir)}

    def arms() -> dict[str, Any]:
        cache = SceneCache()
        return {
            "uncached": {"config": _with_env(config, scene_cache=False), "cache": None},
            "cached": {"config": _with_env(config, scene_cache=cache), "cache": cache},
        }

    def timed(evaluator: Evaluator, *args: Any, **kwargs: Any) -> tuple[np.ndarray, float]:
        c0 = time.process_time()
        out = evaluator.evaluate(*args, **kwargs)
        return out.success.ravel(), time.process_time() - c0

    # one generation: genome by genome, alternating the arms
    gen = arms()
    dedupe_cache = SceneCache()
    evs = {name: Evaluator(a["config"], encoder) for name, a in gen.items()}
    evs["cached_dedupe"] = Evaluator(_with_env(config, scene_cache=dedupe_cache), encoder)
    success: dict[str, list[np.ndarray]] = {name: [] for name in evs}
    cpu = dict.fromkeys(evs, 0.0)
    seen: dict[Any, np.ndarray] = {}  # the dedupe arm's distinct genomes so far
    try:
        for g in population:
            for name, ev in evs.items():
                key = genome_key(g)
                if name == "cached_dedupe" and key in seen:
                    success[name].append(seen[key])  # a twin's copy: no episode run
                    continue
                s, c = timed(ev, [g], train)
                success[name].append(s)
                cpu[name] += c
                if name == "cached_dedupe":
                    seen[key] = s
    finally:
        for ev in evs.values():
            ev.close()
    dedupe_success = success.pop("cached_dedupe")
    dedupe_cpu = cpu.pop("cached_dedupe")
    res["generation"] = g_res = _summary(
        gen, success, cpu, f"{n_gen} genomes x {n_seeds} common seeds"
    )
    g_res["clones"] = n_gen - len(seen)
    g_res["cached_dedupe_episodes_run"] = len(seen) * n_seeds
    g_res["cached_dedupe_cpu_s"] = round(dedupe_cpu, 2)
    g_res["cached_dedupe_episodes_per_cpu_s"] = rate = (
        n_gen * n_seeds / dedupe_cpu if dedupe_cpu > 0 else None
    )
    base = g_res["uncached_episodes_per_cpu_s"]
    g_res["ratio_dedupe"] = rate / base if rate and base else None
    same = np.concatenate(dedupe_success) == np.concatenate(success["cached"])
    g_res["dedupe_same"] = f"{int(same.sum())}/{same.size}"
    g_res["dedupe_cache_hits"], g_res["dedupe_cache_misses"] = (
        dedupe_cache.hits,
        dedupe_cache.misses,
    )
    res["ratio_generation"] = g_res["ratio"]
    res["ratio_generation_dedupe"] = g_res["ratio_dedupe"]
    if not test:
        res["max_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
        return res

    # the test of n_pol policies on the same n_test held-out-object seeds
    clean = test_episodes(config.evaluation.test_seed, n_test, test_objects=True)
    noisy = test_episodes(config.evaluation.test_seed, n_test, test_objects=True, noisy=True)
    mutants = [controller.mutate(best, rng) for _ in range(2)]
    plan: list[tuple[str, list[Any], list[Any], str | None]] = [
        ("grn", [best], clean, None),
        ("zero", [None], clean, "zero"),
        ("grn_noisy", [best], noisy, None),
        ("random", [None], clean, "random"),
        ("turn", [None], clean, "turn"),
        ("mutant_a", [mutants[0]], clean, None),
        ("mutant_b", [mutants[1]], clean, None),
    ][:n_pol]
    test = arms()
    evs = {name: Evaluator(a["config"], encoder) for name, a in test.items()}
    success = {name: [] for name in test}
    cpu = dict.fromkeys(test, 0.0)
    try:
        for _, gs, eps, baseline in plan:
            for name, ev in evs.items():
                s, c = timed(ev, gs, eps, baseline=baseline)
                success[name].append(s)
                cpu[name] += c
    finally:
        for ev in evs.values():
            ev.close()
    res["test"] = _summary(test, success, cpu, f"{n_pol} policies x {n_test} test seeds")
    res["test"]["policies"] = [name for name, *_ in plan]
    res["max_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    res["ratio_test"] = res["test"]["ratio"]
    return res


def _summary(
    arms: dict[str, Any], success: dict[str, list[np.ndarray]], cpu: dict[str, float], what: str
) -> dict[str, Any]:
    out: dict[str, Any] = {"workload": what}
    for name in arms:
        n = int(sum(len(s) for s in success[name]))
        out[f"{name}_episodes"] = n
        out[f"{name}_cpu_s"] = round(cpu[name], 2)
        out[f"{name}_episodes_per_cpu_s"] = n / cpu[name] if cpu[name] > 0 else None
        out[f"{name}_success"] = float(np.mean(np.concatenate(success[name])))
    a, b = out["cached_episodes_per_cpu_s"], out["uncached_episodes_per_cpu_s"]
    out["ratio"] = a / b if a and b else None
    same = np.concatenate(success["cached"]) == np.concatenate(success["uncached"])
    out["same_success"] = f"{int(same.sum())}/{same.size}"
    cache = arms["cached"]["cache"]
    out["cache_hits"], out["cache_misses"] = cache.hits, cache.misses
    return out


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print only the JSON result line")
    ap.add_argument("--quick", action="store_true", help="small budgets")
    ap.add_argument("--genomes", type=int, default=None)
    ap.add_argument("--seeds", type=int, default=None)
    ap.add_argument("--policies", type=int, default=None)
    ap.add_argument("--test-seeds", type=int, default=None)
    ap.add_argument("--no-test", action="store_true", help="time the generation only")
    ap.add_argument("--run", default=str(DEFAULT_RUN), help="GRN run directory")
    ap.add_argument("--out", default=None, help="write the JSON result here too")
    args = ap.parse_args(argv)
    res = run(
        args.quick,
        args.genomes,
        args.seeds,
        args.policies,
        args.test_seeds,
        args.run,
        test=not args.no_test,
    )
    if not args.json:
        for k, v in res.items():
            print(f"{k}: {v}")
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))
    print(json.dumps(res))


if __name__ == "__main__":
    main()
