"""Kuka episodes per CPU-second, the port before its speed-ups (scene cache, skipped lift) against them (SPEC §2.4-2.5).

Two workloads of the thesis protocol, each run by the GRN evaluator in this process (one
worker, lockstep 4, as ``evodevo grn evolve``/``evaluate`` run them), in several arms:

* ``uncached``: the port before the speed-ups, ``scene_cache=False`` (every reset drops and settles
  its objects) and ``skip_empty_lift=False`` (every grasp lifts for all 500 steps) — "today",
  the baseline of every ratio;
* ``cached``: a fresh, empty settled-scene cache per arm (the first reset of a drop settles it,
  later ones place it), full lifts;
* ``cached_skip``: the cache and the skipped lift (the lift of a failed grasp stops once the arm
  is clear of every object; docs/kuka_env.md, "Skipped lift");
* ``cached_skip_dedupe`` (generation only): also ``evaluation.dedupe``: a mutant whose mutation
  changed nothing (a clone of the evolved genome, :func:`evodevo.grn.evaluator.genome_key`) is
  not run again but gets its twin's results, as the evaluator does within one generation's
  call (its episodes count as scored, so its rate is episodes scored per CPU-second).

Workloads:

* **generation**: one generation, 12 genomes (an evolved genome and 11 mutants of it) × 10
  common episode seeds (3 of them with visual noise), training objects;
* **test**: the 200-episode test (fixed test seeds, held-out objects) of one policy, repeated
  for 7 policies: the evolved GRN, its noisy twin, the all-zero, uniform-random and
  constant-turn policies, and two mutants of the GRN (stand-ins for ablated genomes).

The arms alternate genome by genome (policy by policy), so all see the same machine load.
Rates are episodes per second of process CPU time; ``ratio[arm]`` = arm / uncached. The
headline ratios are ``ratio_generation`` (``cached_skip_dedupe``) and ``ratio_test``
(``cached_skip``): everything on against today. All arms play the same seeds and actions:
``same_success_as_uncached`` counts the episodes whose success equals the uncached arm's (the
uncached arm settles the objects in the episode's own world, whose contact caches the episode
inherits, so single outcomes can differ; docs/kuka_env.md, "Settled-scene cache");
``skip_same_as_cached`` and ``dedupe_same`` must be complete (the skip and dedupe change no
outcome).

Usage::

    python benchmarks/evolution_speed.py [--quick] [--lean] [--seeds N] [--test-seeds N]
                                         [--no-test] [--json]

The last line of output is JSON. ``--lean`` runs only the ``uncached`` arm and the arm with
everything on (the headline ratios at about half the CPU). ``--quick`` (a smoke run for
``python -m benchmarks --quick``, lean; its ratios mean little): 2 genomes × 1 seed and
2 policies × 1 seed.
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
    lean: bool = False,
) -> dict[str, Any]:
    """Time both workloads in every arm; see the module docstring.

    Args:
        quick: Smoke budgets (2 genomes × 1 seed, 2 policies × 1 seed).
        genomes: Genomes of the generation (default 12).
        seeds: Common episode seeds of the generation (default 10).
        policies: Policies of the test, at most 7 (default 7).
        test_seeds: Test episodes per policy (default 200).
        run_dir: GRN run whose evolved genome, encoder and config are used.
        test: also time the test workload (False: the generation only).
        lean: only the ``uncached`` arm and the arm with everything on (always with ``quick``).

    Returns:
        Per workload: episodes, CPU seconds, episodes per CPU-second, success rate and cache
        hits and misses of every arm, ``ratio`` and ``same_success_as_uncached`` per arm,
        ``skip_same_as_cached``, for the generation ``clones``, the dedupe arm's
        ``episodes_run`` and ``dedupe_same`` (its outcomes equal ``cached_skip``'s); the
        headline ``ratio_generation`` and ``ratio_test``; ``max_rss_mib``.
    """
    from evodevo.grn.evaluation import test_episodes
    from evodevo.grn.evaluator import Evaluator, genome_key
    from evodevo.grn.evolution import EPISODE_KEY, training_episodes

    lean = lean or quick
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
    res: dict[str, Any] = {"run": str(run_dir), "lean": lean}

    def timed(evaluator: Evaluator, *args: Any, **kwargs: Any) -> tuple[np.ndarray, float]:
        c0 = time.process_time()
        out = evaluator.evaluate(*args, **kwargs)
        return out.success.ravel(), time.process_time() - c0

    # one generation: genome by genome, alternating the arms
    names = GENERATION_LEAN if lean else GENERATION_ARMS
    gen = _arms(config, names)
    evs = {name: Evaluator(a["config"], encoder) for name, a in gen.items()}
    success: dict[str, list[np.ndarray]] = {name: [] for name in evs}
    cpu = dict.fromkeys(evs, 0.0)
    seen: dict[str, dict[Any, np.ndarray]] = {name: {} for name in evs}  # dedupe arms' genomes
    try:
        for g in population:
            for name, ev in evs.items():
                key = genome_key(g)
                if gen[name]["dedupe"] and key in seen[name]:
                    success[name].append(seen[name][key])  # a twin's copy: no episode run
                    continue
                s, c = timed(ev, [g], train)
                success[name].append(s)
                cpu[name] += c
                seen[name][key] = s
    finally:
        for ev in evs.values():
            ev.close()
    res["generation"] = g_res = _summary(
        gen, success, cpu, f"{n_gen} genomes x {n_seeds} common seeds"
    )
    g_res["clones"] = n_gen - len(seen["uncached"])
    for name in gen:
        if gen[name]["dedupe"]:  # its episodes count as scored; these ran
            g_res[f"{name}_episodes_run"] = len(seen[name]) * n_seeds
    if "cached_skip" in gen and "cached_skip_dedupe" in gen:
        same = np.concatenate(success["cached_skip_dedupe"]) == np.concatenate(
            success["cached_skip"]
        )
        g_res["dedupe_same"] = f"{int(same.sum())}/{same.size}"
    res["ratio_generation"] = g_res["ratio"]["cached_skip_dedupe"]
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
    tst = _arms(config, TEST_LEAN if lean else TEST_ARMS)
    evs = {name: Evaluator(a["config"], encoder) for name, a in tst.items()}
    success = {name: [] for name in tst}
    cpu = dict.fromkeys(tst, 0.0)
    try:
        for _, gs, eps, baseline in plan:
            for name, ev in evs.items():
                s, c = timed(ev, gs, eps, baseline=baseline)
                success[name].append(s)
                cpu[name] += c
    finally:
        for ev in evs.values():
            ev.close()
    res["test"] = _summary(tst, success, cpu, f"{n_pol} policies x {n_test} test seeds")
    res["test"]["policies"] = [name for name, *_ in plan]
    res["max_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    res["ratio_test"] = res["test"]["ratio"]["cached_skip"]
    return res


#: Arms: name -> (settled-scene cache, skipped lift, dedupe). ``uncached`` is the port before
#: the port before the speed-ups (every reset settles its drop, every grasp lifts fully): the baseline of every ratio.
ARM_SETTINGS = {
    "uncached": (False, False, False),
    "cached": (True, False, False),
    "cached_skip": (True, True, False),
    "cached_skip_dedupe": (True, True, True),
}
GENERATION_ARMS = ("uncached", "cached", "cached_skip", "cached_skip_dedupe")
GENERATION_LEAN = ("uncached", "cached_skip_dedupe")
TEST_ARMS = ("uncached", "cached", "cached_skip")
TEST_LEAN = ("uncached", "cached_skip")


def _arms(config: Any, names: tuple[str, ...]) -> dict[str, Any]:
    """Each arm's config (with its own fresh, empty cache) and whether it dedupes."""
    from evodevo.envs.scene_cache import SceneCache

    out = {}
    for name in names:
        cached, skip, dedupe = ARM_SETTINGS[name]
        cache = SceneCache() if cached else None
        cfg = _with_env(
            config, scene_cache=cache if cache is not None else False, skip_empty_lift=skip
        )
        out[name] = {"config": cfg, "cache": cache, "dedupe": dedupe}
    return out


def _summary(
    arms: dict[str, Any],
    success: dict[str, list[np.ndarray]],
    cpu: dict[str, float],
    what: str,
) -> dict[str, Any]:
    out: dict[str, Any] = {"workload": what}
    for name, arm in arms.items():
        n = int(sum(len(s) for s in success[name]))
        out[f"{name}_episodes"] = n
        out[f"{name}_cpu_s"] = round(cpu[name], 2)
        out[f"{name}_episodes_per_cpu_s"] = n / cpu[name] if cpu[name] > 0 else None
        out[f"{name}_success"] = float(np.mean(np.concatenate(success[name])))
        if arm["cache"] is not None:
            out[f"{name}_cache_hits_misses"] = [arm["cache"].hits, arm["cache"].misses]
    base = out["uncached_episodes_per_cpu_s"]
    out["ratio"] = {
        name: (out[f"{name}_episodes_per_cpu_s"] / base if base else None)
        for name in arms
        if name != "uncached"
    }
    ref = np.concatenate(success["uncached"])
    out["same_success_as_uncached"] = {
        name: f"{int((np.concatenate(success[name]) == ref).sum())}/{ref.size}"
        for name in arms
        if name != "uncached"
    }
    if "cached" in arms and "cached_skip" in arms:
        same = np.concatenate(success["cached_skip"]) == np.concatenate(success["cached"])
        out["skip_same_as_cached"] = f"{int(same.sum())}/{same.size}"
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
    ap.add_argument(
        "--lean", action="store_true", help="only the uncached arm and the arm with everything on"
    )
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
        lean=args.lean,
    )
    if not args.json:
        for k, v in res.items():
            print(f"{k}: {v}")
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))
    print(json.dumps(res))


if __name__ == "__main__":
    main()
