"""The test of SPEC §2.5: fixed test seeds, Wilson intervals, trivial policies on the same seeds.

:func:`load_run` rebuilds a run (config, the saved encoder — never a fresh one — and the best
genome) from its directory. :func:`evaluate_run` tests the best genome on ``episodes`` fixed
seeds (derived from ``evaluation.test_seed``, not from the run seed, so every run and every
baseline meets the same episodes) on test or training objects. With a visual-noise sigma > 0 the
genome is tested clean and noisy and the retention noisy/clean is reported. The all-zero and
uniform-random policies run on the same seeds in the same call. It writes
``eval_<objects>_<noise>.json`` and ``eval_<objects>_<noise>_episodes.csv`` (with
``_seed<S>`` before the extension when the test seed S is not the run's own, :func:`eval_name`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from evodevo.config import from_dict, merge, replace, to_dict
from evodevo.errors import ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import BASELINES, make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import Episode, EpisodeResults, Evaluator
from evodevo.grn.frontends import load_frontend
from evodevo.runs import RunDir, machine_info, write_json
from evodevo.seed_split import range_label
from evodevo.seeding import derive
from evodevo.stats import rate

__all__ = [
    "LoadedRun",
    "load_run",
    "test_episodes",
    "rate_dict",
    "evaluate_run",
    "eval_name",
    "set_suffix",
]


@dataclass
class LoadedRun:
    """A run directory's config, encoder, controller kind and best genome."""

    run: RunDir
    config: GrnConfig
    encoder: Encoder | Any
    genome: Any
    kind: str


RunLoader = Callable[[RunDir, dict[str, Any]], LoadedRun]

RUN_LOADERS: dict[str, RunLoader] = {}
"""Loaders ``(run, saved_config) -> LoadedRun`` of other run kinds the same test applies to,
registered by the package that writes them (:func:`register_run_loader`; the Kuka baselines'
``baseline`` runs when :mod:`evodevo.baselines` is imported)."""

#: Run kinds whose loader registers when the named package is imported.
_PROVIDED_BY = {"baseline": "evodevo.baselines"}


def register_run_loader(kind: str, loader: RunLoader) -> None:
    """Let :func:`load_run` (and so ``grn evaluate``) load runs of ``kind`` with ``loader``."""
    RUN_LOADERS[kind] = loader


__all__ += ["RUN_LOADERS", "RunLoader", "register_run_loader"]


#: The config sections a test of a trained run may change (``--set``): what it is tested on,
#: never what was trained.
TEST_SECTIONS = ("evaluation", "env")


def test_overrides(config: GrnConfig, overrides: Mapping[str, Any] | None) -> GrnConfig:
    """``config`` with ``overrides`` (``--set`` of a test) applied to :data:`TEST_SECTIONS`;
    a key of another section is one :class:`ConfigError` naming it."""
    if not overrides:
        return config
    for key in overrides:
        if key not in TEST_SECTIONS:
            raise ConfigError(
                f"--set {key}.…: a test may change only "
                f"{', '.join(s + '.*' for s in TEST_SECTIONS)}; {key} is what the run was "
                "trained with"
            )
    return from_dict(GrnConfig, merge(to_dict(config), overrides))


def load_run(path: str | Path, overrides: Mapping[str, Any] | None = None) -> LoadedRun:
    """Load ``config.json``, ``encoder.pt`` and ``best_genome.npz`` of a GRN run directory.

    A run of a kind in :data:`RUN_LOADERS` (e.g. a Kuka baseline) is loaded by its own loader,
    with its policy in place of the genome, so it is tested by the same code. ``overrides``
    change the test (:func:`test_overrides`).
    """
    run = RunDir(path, create=False)
    saved = run.read_config()
    kind = str(saved.get("kind"))
    if kind in _PROVIDED_BY and kind not in RUN_LOADERS:
        raise EvodevoError(
            f"{str(run.path)!r} holds a {kind!r} run, loaded by {_PROVIDED_BY[kind]}: import it "
            "first (the CLI does)"
        )
    if kind in RUN_LOADERS:
        loaded = RUN_LOADERS[kind](run, saved)
        return dataclasses.replace(loaded, config=test_overrides(loaded.config, overrides))
    if saved.get("kind") != "grn":
        raise EvodevoError(
            f"{str(run.path)!r} holds a {saved.get('kind')!r} run, not a GRN run (evodevo grn evolve)"
        )
    config = test_overrides(from_dict(GrnConfig, saved["config"]), overrides)
    encoder = load_frontend(config, run.path)
    from evodevo.grn.evaluator import action_dims, make_env

    env = make_env(config.env.id, config.env.kwargs)
    try:
        n_actions = action_dims(env.action_space)
    finally:
        env.close()
    controller = make_controller(config, n_actions)
    genome = controller.load_genome(run / "best_genome.npz")
    return LoadedRun(run, config, encoder, genome, config.controller)


def test_episodes(test_seed: int, n: int, test_objects: bool, noisy: bool = False) -> list[Episode]:
    """The fixed test episodes: seeds ``derive(test_seed, i)``, i < n (shared by every policy)."""
    return [Episode(derive(test_seed, i), noisy=noisy, test_objects=test_objects) for i in range(n)]


test_episodes.__test__ = False  # type: ignore[attr-defined]  # not a pytest test


def rate_dict(success: np.ndarray) -> dict[str, Any]:
    """Success count, rate and Wilson 95 % interval of a boolean vector."""
    r = rate(int(np.sum(success)), int(np.size(success)))
    return asdict(r) | {"success_rate": r.rate}


def eval_name(
    objects: str,
    noise: float,
    overrides: Mapping[str, Any] | None = None,
    test_seed: int | None = None,
    run_test_seed: int | None = None,
) -> str:
    """Base name of the evaluation files, e.g. ``eval_test_0`` or ``eval_test_0.03``; a test
    changed by ``--set`` adds a short digest of the changes (``eval_test_0_set-3f2a9c1b``), and
    a test on other episodes than the run's own test seed (``run_test_seed``, its config's
    ``evaluation.test_seed``) adds that seed, so re-testing an older run on the locked range
    (SPEC §6) never overwrites the test it was reported with.

    >>> eval_name("test", 0.03)
    'eval_test_0.03'
    >>> eval_name("test", 0.0, test_seed=1000000, run_test_seed=10000)
    'eval_test_0_seed1000000'
    >>> eval_name("test", 0.0, test_seed=1000000, run_test_seed=1000000)
    'eval_test_0'
    """
    seed = "" if test_seed is None or test_seed == run_test_seed else f"_seed{test_seed}"
    return f"eval_{objects}_{noise:g}{seed}{set_suffix(overrides)}"


def set_suffix(overrides: Mapping[str, Any] | None) -> str:
    """The file-name suffix of a test changed by ``--set``: ``""`` for none, else ``_set-`` and
    a short digest of the changes, so a changed test never overwrites the plain one.

    >>> set_suffix(None), set_suffix({"env": {"kwargs": {"dark_after": 2}}})
    ('', '_set-33390c09')
    """
    if not overrides:
        return ""
    digest = hashlib.sha256(json.dumps(overrides, sort_keys=True).encode()).hexdigest()[:8]
    return f"_set-{digest}"


def _rows(policy: str, episodes: list[Episode], res: EpisodeResults) -> list[dict[str, Any]]:
    return [
        {
            "policy": policy,
            "episode": i,
            "seed": ep.seed,
            "noisy": int(ep.noisy),
            "test_objects": int(ep.test_objects),
            "reward": float(res.reward[0, i]),
            "success": int(res.success[0, i]),
            "steps": int(res.steps[0, i]),
        }
        for i, ep in enumerate(episodes)
    ]


def evaluate_run(
    path: str | Path,
    episodes: int | None = None,
    objects: str = "test",
    noise: float = 0.0,
    seed: int | None = None,
    workers: int = 1,
    baselines: bool = True,
    baselines_from: str | Path | None = None,
    backend: str = "local",
    address: str | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Test a run's best genome (SPEC §2.5) and save the result files; returns the result dict.

    Args:
        path: run directory.
        episodes: test episodes (default ``evaluation.test_episodes`` of the run's config).
        objects: "test" (held-out objects) or "train".
        noise: std of visual-feature noise; > 0 adds a noisy test and the retention.
        seed: test seed (default ``evaluation.test_seed``).
        workers: worker processes.
        baselines: also run the trivial policies (BASELINES: all-zero, uniform random,
            constant turn) on the same seeds.
        baselines_from: a file of :func:`evaluate_baselines` for the same episodes, used
            instead of running the trivial policies again.
        backend: "local" (process pool) or "ray" (Ray actors); the results are the same.
        address: Ray cluster ("auto" or HOST:PORT); None starts a private local Ray.
        overrides: ``--set`` of the test, ``evaluation.*`` and ``env.*`` only
            (:func:`test_overrides`); the result records them and its files get a suffix, so a
            changed test never overwrites the plain one.
    """
    _check_test(objects, noise, episodes)
    loaded = load_run(path, overrides)
    cfg = loaded.config
    n = int(episodes if episodes is not None else cfg.evaluation.test_episodes)
    test_seed = int(seed if seed is not None else cfg.evaluation.test_seed)
    is_test = objects == "test"
    clean_eps = test_episodes(test_seed, n, is_test)
    rows: list[dict[str, Any]] = []
    out: dict[str, Any] = {}
    with Evaluator(cfg, loaded.encoder, workers=workers, backend=backend, address=address) as ev:
        clean = ev.evaluate([loaded.genome], clean_eps)
        rows += _rows("genome", clean_eps, clean)
        main = clean
        if noise > 0:
            noisy_eps = test_episodes(test_seed, n, is_test, noisy=True)
            noisy_cfg = replace(cfg, evaluation=replace(cfg.evaluation, visual_noise=float(noise)))
            main = ev.evaluate([loaded.genome], noisy_eps, config=noisy_cfg)
            rows += _rows("genome_noisy", noisy_eps, main)
            clean_rate = float(clean.success.mean())
            out["clean"] = rate_dict(clean.success[0]) | {"mean_reward": _mean_reward(clean)}
            out["retention"] = float(main.success.mean()) / clean_rate if clean_rate > 0 else None
        base: dict[str, Any] = {}
        if baselines_from is not None:
            base = _read_baselines(baselines_from, cfg, n, objects, test_seed)
        elif baselines:
            base, base_rows = _run_trivial(ev, clean_eps, default_baselines(cfg))
            rows += base_rows
        env_steps = ev.env_steps
    summary = rate_dict(main.success[0])
    result = {
        **{k: summary[k] for k in ("success_rate", "ci_low", "ci_high", "successes")},
        **_test_facts(loaded, n, objects, noise, test_seed),
        "mean_steps": float(main.steps.mean()),
        "mean_reward": _mean_reward(main),
        **out,
        "baselines": base,
        "env_steps": env_steps,
        **({"overrides": dict(overrides)} if overrides else {}),
        "machine": machine_info(),
    }
    name = eval_name(objects, noise, overrides, test_seed, int(cfg.evaluation.test_seed))
    write_json(loaded.run / f"{name}.json", result)
    loaded.run.write_csv(f"{name}_episodes.csv", rows)
    return result


def _test_facts(
    loaded: LoadedRun, n: int, objects: str, noise: float, test_seed: int
) -> dict[str, Any]:
    """What a test result says about its episodes and the run it tested."""
    return {
        "episodes": n,
        "objects": objects,
        "noise": float(noise),
        "test_seed": test_seed,
        "seed_range": range_label(test_seed),
        "controller": loaded.kind,
        "blind": loaded.config.sensors.blind,
        "run": str(loaded.run.path),
    }


def _check_test(objects: str, noise: float, episodes: int | None) -> None:
    """One clear error for a test option out of range, before anything is loaded."""
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    if noise < 0:
        raise EvodevoError(f"--noise {noise} must be >= 0")
    if episodes is not None and episodes < 1:
        raise EvodevoError(
            f"--test-episodes {episodes} must be at least 1 (the number of fixed test episodes)"
        )


KUKA_ID = "evodevo/KukaDiverseObject-v0"


def default_baselines(config: GrnConfig) -> list[str]:
    """The reference policies run by default: every one of BASELINES, but the scripted
    image-only pipeline only on the Kuka env with its height hack (it reads that camera), and
    its remembering twin only when that camera goes dark (``dark_after``; else they are one).
    The scripted two are registered by :mod:`evodevo.baselines` when it is imported (the CLI,
    ``reproduce`` and :func:`evodevo.load` import it; a script that calls :func:`evaluate_run`
    itself imports it to have them)."""
    kuka = config.env.id == KUKA_ID and config.env.kwargs.get("height_hack", True)
    dark = kuka and config.env.kwargs.get("dark_after") is not None
    needs = {"scripted": kuka, "scripted_memory": dark}
    return [n for n in BASELINES if needs.get(n, True)]


__all__ += ["default_baselines"]


def _run_trivial(
    ev: Evaluator, episodes: list[Episode], names: Sequence[str]
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Trivial policies ``names`` on ``episodes``: their rate dicts and per-episode rows."""
    base: dict[str, Any] = {}
    rows: list[dict[str, Any]] = []
    for name in names:
        res = ev.evaluate([None], episodes, baseline=name)
        rows += _rows(name, episodes, res)
        base[name] = rate_dict(res.success[0]) | {
            "mean_steps": float(res.steps.mean()),
            "mean_reward": _mean_reward(res),
        }
    return base, rows


def _mean_reward(res: EpisodeResults) -> float:
    """The mean episode return of one policy's test (the score beyond Kuka, where success is
    rare: Pendulum, MountainCarContinuous)."""
    return float(np.mean(res.reward[0]))


def _baseline_key(config: GrnConfig, n: int, objects: str, test_seed: int) -> dict[str, Any]:
    return {
        "env_id": config.env.id,
        "env_kwargs": dict(config.env.kwargs),
        "episodes": n,
        "objects": objects,
        "test_seed": test_seed,
    }


def evaluate_baselines(
    config: GrnConfig,
    out: str | Path,
    episodes: int | None = None,
    objects: str = "test",
    seed: int | None = None,
    workers: int = 1,
    policies: Sequence[str] | None = None,
) -> dict[str, Any]:
    """Run the trivial policies (SPEC §2.5) on the fixed test episodes; save to ``out``.

    The trivial policies need no genome, so one file serves every run tested on the same
    episodes (``evaluate --baselines-from``); the file records which episodes those were.
    ``policies`` (default: every key of BASELINES) are the ones to measure. If ``out`` already
    holds results for the same episodes, its policies are kept and only the missing ones run,
    so a file written before a policy was added is completed, not recomputed.
    """
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    names = default_baselines(config) if policies is None else list(policies)
    bad = [p for p in names if p not in BASELINES] or ([] if names else [""])
    if bad:
        raise EvodevoError(
            f"baseline policy {bad[0]!r} is not known; choose from {', '.join(BASELINES)}"
        )
    n = int(episodes if episodes is not None else config.evaluation.test_episodes)
    test_seed = int(seed if seed is not None else config.evaluation.test_seed)
    key = _baseline_key(config, n, objects, test_seed)
    out = Path(out)
    run = RunDir(out.parent)
    csv_name = f"{out.stem}_episodes.csv"
    base: dict[str, Any] = {}
    rows: list[dict[str, Any]] = []
    if out.is_file() and (out.parent / csv_name).is_file():
        from evodevo.runs import read_json

        old = read_json(out)
        if old.get("key") == key:
            base = dict(old["baselines"])
            rows = [r for r in run.read_csv(csv_name) if r["policy"] in base]
    todo = [p for p in names if p not in base]
    if todo:
        eps = test_episodes(test_seed, n, objects == "test")
        with Evaluator(config, None, workers=workers) as ev:
            new, new_rows = _run_trivial(ev, eps, todo)
        base |= new
        rows += new_rows
    result = {"key": key, "baselines": base, "machine": machine_info()}
    write_json(out, result)
    run.write_csv(csv_name, rows)
    return result


def _read_baselines(
    path: str | Path, config: GrnConfig, n: int, objects: str, test_seed: int
) -> dict[str, Any]:
    from evodevo.runs import read_json

    data = read_json(path)
    want = _baseline_key(config, n, objects, test_seed)
    if data.get("key") != want:
        raise EvodevoError(
            f"--baselines-from {str(path)!r} was measured on {data.get('key')}, not on {want}; "
            "use a file for the same episodes or let evaluate run the baselines"
        )
    return dict(data["baselines"])


__all__ += ["evaluate_baselines"]
