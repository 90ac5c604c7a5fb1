"""The optimisers of the shared evolution loop: CMA-ES (``evolution.optimizer: cmaes``) beside
the GA, on a cheap quadratic problem and on the fake Kuka env: it improves, it is
deterministic, it resumes exactly (in process, after SIGKILL, across evaluator backends), its
state file is data that cannot run code, and the GA is unchanged bit for bit."""

from __future__ import annotations

import csv
import hashlib
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_grn_evaluator import _Stop, _StopAfterFirst, fake_config, history, record_evaluations
from test_grn_fakeenv import FAKE_ID

from evodevo.callbacks import Callback
from evodevo.config import from_dict, load_config, to_dict
from evodevo.errors import CheckpointError, ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import EpisodeResults, Evaluator
from evodevo.grn.evolution import (
    CHECKPOINT_FILE,
    EPISODE_KEY,
    Evolution,
    evolve_run,
    training_episodes,
)
from evodevo.grn.genome import load_arrays, save_arrays
from evodevo.grn.optimizers import CmaEsOptimizer, GeneticOptimizer, make_optimizer
from evodevo.grn.optimizers.vector import GenomeVector

ROOT = Path(__file__).resolve().parents[1]
TARGET = np.linspace(-0.6, 0.6, 24).reshape(8, 3)


class QuadraticProblem:
    """Stands in for the evaluator: an open-loop genome's reward is minus its mean squared
    distance to ``TARGET``, the same on every episode; success when closer than 0.01."""

    def evaluate(self, genomes, episodes, measure_distance=False, **kw) -> EpisodeResults:
        d = np.array([np.mean((g.actions - TARGET) ** 2) for g in genomes])
        reward = np.repeat(-d[:, None], len(episodes), axis=1)
        return EpisodeResults(reward, reward > -0.01, np.ones(reward.shape, int))


def _quadratic_config(seed: int = 0, generations: int = 25, **evolution) -> GrnConfig:
    return from_dict(
        GrnConfig,
        {
            "seed": seed,
            "controller": "open_loop",
            "evolution": {
                "optimizer": "cmaes",
                "population": 8,
                "generations": generations,
                "early_stop": False,
                **evolution,
            },
            "evaluation": {"episodes": 2},
        },
    )


def _quadratic_run(cfg: GrnConfig, callbacks=()) -> Evolution:
    return Evolution(cfg, make_controller(cfg, 3), QuadraticProblem(), callbacks).run()  # type: ignore[arg-type]


def _distance(genome) -> float:
    return float(np.mean((genome.actions - TARGET) ** 2))


def test_cmaes_improves_fitness_on_a_cheap_problem():
    evo = _quadratic_run(_quadratic_config())
    first, last = evo.history[0], evo.history[-1]
    assert evo.optimizer.name == "cmaes"
    assert last.best_fitness > first.best_fitness + 0.1
    assert last.mean_fitness > first.mean_fitness + 0.2
    # the distribution's mean has moved most of the way to the target
    start = _distance(evo.controller.init_genome(np.random.default_rng(0)))
    assert _distance(evo.optimizer.mean_genome()) < 0.25 * start
    assert evo.episodes_run == 8 * 2 * 25  # population x episodes x generations


def test_cmaes_same_seed_same_run_other_seed_other_run():
    a, b = (
        _quadratic_run(_quadratic_config(generations=6)),
        _quadratic_run(_quadratic_config(generations=6)),
    )
    c = _quadratic_run(_quadratic_config(seed=1, generations=6))
    assert [r.best_fitness for r in a.history] == [r.best_fitness for r in b.history]
    assert a.best_genome.actions.tobytes() == b.best_genome.actions.tobytes()
    assert a.optimizer.es.mean.tobytes() == b.optimizer.es.mean.tobytes()
    assert [r.best_fitness for r in a.history] != [r.best_fitness for r in c.history]


class _StopAt(Callback):
    def __init__(self, generation: int) -> None:
        self.generation = generation

    def on_generation(self, record):
        if record.generation == self.generation:
            raise _Stop


@pytest.mark.parametrize("diagonal", [True, False])
def test_cmaes_resumes_exactly_from_its_checkpoint_file(tmp_path, diagonal):
    cfg = _quadratic_config(generations=8)
    cfg.cmaes.diagonal = diagonal
    full = _quadratic_run(cfg)

    class Save(Callback):
        def on_generation(self, record):
            self.owner.save_checkpoint(tmp_path / CHECKPOINT_FILE)

    with pytest.raises(_Stop):
        _quadratic_run(cfg, [Save(), _StopAt(2)])
    resumed = Evolution(cfg, make_controller(cfg, 3), QuadraticProblem())  # type: ignore[arg-type]
    resumed.load_checkpoint(tmp_path / CHECKPOINT_FILE)
    assert resumed.generation == 3
    resumed.run()
    assert [r.best_fitness for r in resumed.history] == [r.best_fitness for r in full.history]
    assert resumed.best_genome.actions.tobytes() == full.best_genome.actions.tobytes()
    assert resumed.optimizer.es.mean.tobytes() == full.optimizer.es.mean.tobytes()
    assert resumed.optimizer.es.sigma == full.optimizer.es.sigma
    _, meta = load_arrays(tmp_path / CHECKPOINT_FILE, "grn_checkpoint")
    assert (
        meta["optimizer"] == "cmaes" and meta["cmaes"]["tree"]["object"] == "CMAEvolutionStrategy"
    )


def test_cmaes_with_the_plain_grn_samples_only_present_connections():
    cfg = fake_config(evolution={"optimizer": "cmaes", "population": 6})
    ctrl = make_controller(cfg, 3)
    opt = make_optimizer(cfg, ctrl, np.random.default_rng(0))
    assert isinstance(opt, CmaEsOptimizer)
    pattern = opt.space.template["W_r"] != 0
    for g in opt.ask():
        assert np.array_equal(g.W_r != 0, pattern)  # sparsity fixed as sampled at init
        for name, (lo, hi) in (("theta", (0.1, 1.0)), ("delta", (0.05, 1.0))):
            assert getattr(g, name).min() >= lo and getattr(g, name).max() <= hi
    assert opt.space.dim == 8 * 50 + int(pattern.sum()) + 50 * 3 + 3 * 50 + 128 * 4
    # the vision preset: the proprioceptive rows of W_s read zeros, so they do not evolve
    vis = from_dict(GrnConfig, {"sensors": {"proprio": False}})
    space = GenomeVector(
        make_controller(vis, 3), make_controller(vis, 3).init_genome(np.random.default_rng(0))
    )
    assert dict(zip(space.names(), [b[1].size for b in space.blocks], strict=True))["W_s"] == 4 * 50


def test_cmaes_on_the_fake_env_uses_common_episodes_and_the_budget(tmp_path):
    cfg = fake_config(
        evolution={"optimizer": "cmaes", "population": 5, "generations": 3, "early_stop": False}
    )
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        evo = Evolution(cfg, make_controller(cfg, ev.n_actions), ev)
        calls = record_evaluations(ev)
        evo.run()
    assert len(calls) == 3
    for g, (genomes, episodes, res) in enumerate(calls):
        assert len(genomes) == 5 and res.reward.shape == (5, 3)  # one call: the same episodes
        assert episodes == training_episodes(cfg.seed, EPISODE_KEY, g, 3, 0.3)
    assert evo.episodes_run == 5 * 3 * 3


def test_cmaes_results_equal_on_one_worker_a_process_pool_and_ray(tmp_path):
    cfg = load_config(
        GrnConfig,
        ROOT / "configs" / "grn_pendulum.yaml",
        {
            "evolution": {"optimizer": "cmaes", "population": 4, "generations": 2},
            "evaluation": {"episodes": 2, "lockstep": 2},
        },
    )
    backends = [("one", 1, "local"), ("pool", 2, "local")]
    try:
        import ray  # noqa: F401

        backends.append(("ray", 2, "ray"))
    except ImportError:
        pass
    runs = {
        name: evolve_run(cfg, tmp_path / name, workers=w, backend=b, progress=False)[
            "fitness_history"
        ]
        for name, w, b in backends
    }
    assert all(h == runs["one"] for h in runs.values())
    assert len(runs) == len(backends)


def test_cmaes_interrupted_run_resumes_exactly_through_evolve_run(tmp_path):
    cfg = fake_config(evolution={"optimizer": "cmaes", "generations": 3, "early_stop": False})
    evolve_run(cfg, tmp_path / "full", progress=False, workers=2)
    with pytest.raises(_Stop):
        evolve_run(cfg, tmp_path / "cut", callbacks=[_StopAfterFirst()], progress=False)
    evolve_run(cfg, tmp_path / "cut", resume=True, progress=False, workers=2)
    assert history(tmp_path / "full") == history(tmp_path / "cut")
    a = (tmp_path / "full" / "best_genome.npz").read_bytes()
    assert a == (tmp_path / "cut" / "best_genome.npz").read_bytes()
    summary = json.loads((tmp_path / "cut" / "summary.json").read_text())
    assert summary["optimizer"] == "cmaes"


# -- SIGKILL mid-run, then --resume (the CLI, Pendulum: fast generations) -----------------------
CLI_ARGS = [
    "--config",
    str(ROOT / "configs" / "grn_pendulum.yaml"),
    "--set",
    "evolution.optimizer=cmaes",
    "--population",
    "6",
    "--generations",
    "5",
    "--episodes",
    "10",
    "--seed",
    "2",
    "--quiet",
]


def _cli(out: Path, *extra: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "evodevo", "grn", "evolve", *CLI_ARGS, *extra, "--out", str(out)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _rows(run: Path) -> list[dict[str, str]]:
    if not (run / "history.csv").is_file():
        return []
    with (run / "history.csv").open() as fh:
        return [
            {k: v for k, v in r.items() if k not in ("eval_s", "evals_per_s", "elapsed_s")}
            for r in csv.DictReader(fh)
        ]


def test_cmaes_killed_with_sigkill_then_resumed_ends_as_an_uninterrupted_run(tmp_path):
    ref = _cli(tmp_path / "ref")
    victim = _cli(tmp_path / "victim")
    deadline = time.time() + 240
    while time.time() < deadline and victim.poll() is None and not _rows(tmp_path / "victim"):
        time.sleep(0.01)
    victim.kill()
    victim.wait(timeout=60)
    assert victim.returncode == -signal.SIGKILL, "the victim finished before it could be killed"
    done = len(_rows(tmp_path / "victim"))
    assert done >= 1 and done < 5  # killed after a checkpoint, before the end
    resumed = _cli(tmp_path / "victim", "--resume")
    out = resumed.communicate(timeout=240)[0]
    assert resumed.returncode == 0, out
    assert ref.communicate(timeout=240) and ref.returncode == 0
    assert _rows(tmp_path / "victim") == _rows(tmp_path / "ref")
    assert len(_rows(tmp_path / "ref")) == 5
    best = [(tmp_path / r / "best_genome.npz").read_bytes() for r in ("ref", "victim")]
    assert best[0] == best[1]


# -- the checkpoint is data ---------------------------------------------------------------------
def _cmaes_checkpoint(tmp_path: Path) -> tuple[GrnConfig, Path]:
    cfg = _quadratic_config(generations=2)
    evo = _quadratic_run(cfg)
    path = tmp_path / CHECKPOINT_FILE
    evo.save_checkpoint(path)
    return cfg, path


def _load(cfg: GrnConfig, path: Path) -> Evolution:
    evo = Evolution(cfg, make_controller(cfg, 3), QuadraticProblem())  # type: ignore[arg-type]
    evo.load_checkpoint(path)
    return evo


class _Payload:
    """Unpickling this would create ``marker`` (the attack a planted pickle makes)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        import os

        return (os.mkdir, (str(self.marker),))


def test_a_planted_pickle_in_the_cmaes_state_executes_nothing(tmp_path):
    cfg, path = _cmaes_checkpoint(tmp_path)
    arrays, meta = load_arrays(path)
    marker = tmp_path / "pwned"
    payload = np.empty(1, dtype=object)
    payload[0] = _Payload(marker)
    arrays["optimizer__es.sm.C"] = payload  # np.savez pickles object arrays
    kind = meta.pop("kind")
    meta.pop("format_version")
    save_arrays(path, kind, arrays, meta)
    with pytest.raises(CheckpointError):
        _load(cfg, path)
    assert not marker.exists()


@pytest.mark.parametrize(
    ("where", "node"),
    [
        (["sm", "attrs", "randn"], {"value": "os.system"}),  # a callable replaced by text
        (["__class__"], {"value": "builtins.exec"}),
        (["opts"], {"dict": {"randn": {"value": "os.system"}}}),  # options are never restored
        (["sigma"], {"scalar": "|O", "value": 1}),  # an object dtype
        (["mean"], {"array": "no such array"}),
        (["ask"], {"value": 1}),  # would hide a method
        (["adapt_sigma"], {"object": "Popen", "attrs": {}}),  # another type
    ],
)
def test_a_planted_cmaes_state_tree_is_refused(tmp_path, where, node):
    cfg, path = _cmaes_checkpoint(tmp_path)
    arrays, meta = load_arrays(path)
    tree = meta["cmaes"]["tree"]["attrs"]
    for key in where[:-1]:
        tree = tree[key]
    tree[where[-1]] = node
    save_arrays(
        path, meta.pop("kind"), arrays, {k: v for k, v in meta.items() if k != "format_version"}
    )
    with pytest.raises(CheckpointError, match="CMA-ES state"):
        _load(cfg, path)


def test_checkpoints_name_their_optimizer_and_cma_version(tmp_path):
    cfg, path = _cmaes_checkpoint(tmp_path)
    ga = _quadratic_config(generations=2, optimizer="ga")
    with pytest.raises(CheckpointError, match="optimizer 'cmaes'"):
        _load(ga, path)
    arrays, meta = load_arrays(path)
    meta["cmaes"]["cma_version"] = "0.0.1"
    save_arrays(
        path, meta.pop("kind"), arrays, {k: v for k, v in meta.items() if k != "format_version"}
    )
    with pytest.raises(CheckpointError, match="cma '0.0.1'"):
        _load(cfg, path)


def test_optimizer_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="evolution.optimizer"):
        from_dict(GrnConfig, {"evolution": {"optimizer": "pso"}})
    with pytest.raises(ConfigError, match="population >= 4"):
        from_dict(GrnConfig, {"evolution": {"optimizer": "cmaes", "population": 2}})
    with pytest.raises(ConfigError, match="sigma0"):
        from_dict(GrnConfig, {"cmaes": {"sigma0": 0}})
    with pytest.raises(EvodevoError, match="only be told"):
        opt = make_optimizer(
            _quadratic_config(), make_controller(_quadratic_config(), 3), np.random.default_rng(0)
        )
        pop = opt.ask()
        opt.tell(pop[::-1], np.zeros(8), np.arange(8))


# -- the GA is the thesis' --------------------------------------------------------------------------
GA_GOLDEN = "e4f2836cd4e8a611d4b08bce06bdd728eac181deca480b89ae3d721f5677a9b7"
"""sha256 of the best genome's arrays of the run below, computed with the code before the
optimisers were pluggable (commit f35b62e): the GA must draw exactly the same numbers."""


def test_the_ga_is_unchanged_bit_for_bit(tmp_path):
    cfg = load_config(
        GrnConfig,
        ROOT / "configs" / "grn.yaml",
        {
            "env": {"id": FAKE_ID},
            "evolution": {"population": 5, "generations": 3},
            "evaluation": {"episodes": 3},
        },
    )
    assert cfg.evolution.optimizer == "ga"
    evolve_run(cfg, tmp_path / "run", progress=False)
    a = np.load(tmp_path / "run" / "best_genome.npz")
    h = hashlib.sha256()
    for k in sorted(a.files):
        if k != "__meta__":
            h.update(a[k].tobytes())
    assert h.hexdigest() == GA_GOLDEN
    assert isinstance(
        make_optimizer(cfg, make_controller(cfg, 3), np.random.default_rng(0)), GeneticOptimizer
    )
    assert to_dict(cfg)["evolution"]["optimizer"] == "ga"
