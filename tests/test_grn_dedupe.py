"""identical genomes of a generation are evaluated once (``evaluation.dedupe``).

Every genome of a generation plays the same episodes with the same noise seeds, so a clone
scores what its twin scores: a run with dedupe must give the same history and best genome as
one without, having run fewer episodes.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest
from test_grn_evaluator import fake_config
from test_grn_fakeenv import FAKE_ID

from evodevo.config import from_dict
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.evaluator import Episode, Evaluator, genome_key
from evodevo.grn.evolution import evolve_run
from evodevo.runs import read_json

pytestmark = pytest.mark.usefixtures("one_torch_thread")

WALL = {"eval_s", "evals_per_s", "elapsed_s"}
# few mutations: most children are unmutated clones of their parent (or of an elite)
CLONING = {"p_struct": 0.0, "p_weight": 0.05, "p_param": 0.05}


def _history(path) -> list[dict[str, str]]:
    with open(path / "history.csv") as fh:
        return [{k: v for k, v in r.items() if k not in WALL} for r in csv.DictReader(fh)]


def _same_run(a, b) -> None:
    """Same history (but episodes_saved) and the same best genome, bit for bit."""
    ha, hb = _history(a), _history(b)
    for r in (*ha, *hb):
        r.pop("episodes_saved")
    assert ha == hb
    ga, gb = np.load(a / "best_genome.npz"), np.load(b / "best_genome.npz")
    assert sorted(ga.files) == sorted(gb.files)
    for k in ga.files:
        if k != "__meta__":
            assert ga[k].tobytes() == gb[k].tobytes(), k


def _evolve(tmp_path, name: str, dedupe: bool, env: dict | None = None, **sections):
    data = {
        "evolution": {"population": 6, "generations": 3, "early_stop": False},
        "evaluation": {"episodes": 2, "lockstep": 3, "dedupe": dedupe},
        "mutation": CLONING,
        **sections,
    }
    cfg = fake_config(**data) if env is None else from_dict(GrnConfig, {**data, "env": env})
    out = tmp_path / name
    summary = evolve_run(cfg, out, workers=1, progress=False)
    return out, summary


def test_dedupe_gives_the_same_run_with_fewer_episodes(tmp_path):
    on, s_on = _evolve(tmp_path, "on", True)
    off, s_off = _evolve(tmp_path, "off", False)
    _same_run(on, off)
    saved = [int(r["episodes_saved"]) for r in _history(on)]
    assert s_on["episodes_saved"] == sum(saved) > 0
    assert s_off["episodes_saved"] == 0
    assert {int(r["episodes_saved"]) for r in _history(off)} == {0}
    assert s_on["episodes_run"] == s_off["episodes_run"]  # episodes scored, copies included
    assert read_json(on / "summary.json")["episodes_saved"] == sum(saved)


def test_dedupe_on_a_vector_env_with_noise(tmp_path):
    """Pendulum (no encoder) with expression noise drawn from every episode's generator."""
    env = {"id": "Pendulum-v1", "kwargs": {"max_episode_steps": 20}}
    sections = {
        "sensors": {"n_visual": 0, "n_proprio": 3},
        "dynamics": {"noise_std": 0.05},
    }
    on, s_on = _evolve(tmp_path, "on", True, env=env, **sections)
    off, _ = _evolve(tmp_path, "off", False, env=env, **sections)
    _same_run(on, off)
    assert s_on["episodes_saved"] > 0


def test_twins_get_their_twins_rows(tmp_path):
    cfg = fake_config(evaluation={"lockstep": 2})
    off = fake_config(evaluation={"lockstep": 2, "dedupe": False})
    ctrl = make_controller(cfg, 3)
    rng = np.random.default_rng(0)
    a, b = ctrl.init_genome(rng), ctrl.init_genome(rng)
    genomes = [a, b, a.copy(), b, a]
    eps = [Episode(1), Episode(2, noisy=True), Episode(3)]
    with Evaluator(cfg, None if cfg.sensors.blind else _encoder()) as ev:
        res = ev.evaluate(genomes, eps)
        ref = ev.evaluate(genomes, eps, config=off)
        assert ev.episodes_saved == 3 * len(eps)
    assert res.episodes_saved == 3 * len(eps) and ref.episodes_saved == 0
    for name in ("reward", "success", "steps"):
        assert np.array_equal(getattr(res, name), getattr(ref, name)), name
    assert np.array_equal(res.reward[0], res.reward[2])


def _encoder():
    from evodevo.grn.encoder import Encoder

    return Encoder.from_seed(0)


def test_genome_keys():
    cfg = fake_config()
    ctrl = make_controller(cfg, 3)
    g = ctrl.init_genome(np.random.default_rng(0))
    h = g.copy()
    assert genome_key(g) == genome_key(h)
    h.theta[0] = np.nextafter(h.theta[0], 2.0)  # one ulp: another genome
    assert genome_key(g) != genome_key(h)
    assert genome_key(None) == genome_key(None)
    a, b = object(), object()  # no arrays, no key: merged only with itself
    assert genome_key(a) == genome_key(a) != genome_key(b)
    assert FAKE_ID  # the fake env's module is imported (registers it)


def test_neat_key_ignores_the_genome_id(tmp_path):
    pytest.importorskip("neat")
    import copy

    from evodevo.baselines.kuka_config import KukaBaselineConfig
    from evodevo.baselines.neat_kuka import write_neat_config
    from evodevo.baselines.policies import NeatNet, neat_config
    from evodevo.runs import RunDir

    run = RunDir(tmp_path / "run")
    ini = write_neat_config(from_dict(KukaBaselineConfig, {"method": "neat"}), 3, run)
    import neat

    config = neat_config(ini)
    g = next(iter(neat.Population(config, seed=0).population.values()))
    twin = copy.deepcopy(g)
    twin.key, twin.fitness = 7, 0.5
    a, b = NeatNet.from_genome(g, ini), NeatNet.from_genome(twin, ini)
    assert a.genome != b.genome and genome_key(a) == genome_key(b)
    twin.mutate(config.genome_config)
    assert genome_key(NeatNet.from_genome(twin, ini)) != genome_key(a)
