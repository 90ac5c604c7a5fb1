"""The evaluator and optimiser on the cheap fake env: results independent of workers and lockstep,
elitism, exact resume, dead workers, clear errors, encoder save/load."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import torch
from test_grn_fakeenv import FAKE_ID

from evodevo.callbacks import Callback
from evodevo.config import from_dict
from evodevo.errors import ConfigError, EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import Episode, Evaluator
from evodevo.grn.evolution import Evolution, evolve_run


def fake_config(**sections) -> GrnConfig:
    data = {
        "env": {"id": FAKE_ID},
        "evolution": {"population": 4, "generations": 2, "elite_fraction": 0.25},
        "evaluation": {"episodes": 3},
    }
    for k, v in sections.items():
        data[k] = {**data.get(k, {}), **v} if isinstance(v, dict) else v
    return from_dict(GrnConfig, data)


def record_evaluations(ev: Evaluator) -> list:
    """Wrap ``ev.evaluate``; the returned list gets (genomes, episodes, results) of each call."""
    calls: list = []
    original = ev.evaluate

    def spy(genomes, episodes, **kw):
        res = original(genomes, episodes, **kw)
        calls.append((list(genomes), list(episodes), res))
        return res

    ev.evaluate = spy  # type: ignore[method-assign]
    return calls


def history(path) -> list[dict[str, str]]:
    with open(path / "history.csv") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:  # timings differ between runs
        for k in ("eval_s", "evals_per_s", "elapsed_s"):
            r.pop(k)
    return rows


def test_results_do_not_depend_on_workers_or_lockstep(tmp_path):
    cfg = fake_config()
    evolve_run(cfg, tmp_path / "w1", workers=1, progress=False)
    evolve_run(cfg, tmp_path / "w2", workers=2, progress=False)
    cfg1 = fake_config(evaluation={"lockstep": 1})
    evolve_run(cfg1, tmp_path / "l1", workers=1, progress=False)
    h1 = history(tmp_path / "w1")
    assert len(h1) == 2
    assert h1 == history(tmp_path / "w2") == history(tmp_path / "l1")
    a = np.load(tmp_path / "w1" / "best_genome.npz")
    b = np.load(tmp_path / "w2" / "best_genome.npz")
    for k in a.files:
        if k != "__meta__":
            assert a[k].tobytes() == b[k].tobytes()


class _Stop(Exception):
    pass


class _StopAfterFirst(Callback):
    def on_generation(self, record):
        raise _Stop


def test_interrupted_run_resumes_exactly(tmp_path):
    cfg = fake_config(evolution={"generations": 3})
    evolve_run(cfg, tmp_path / "full", progress=False)
    with pytest.raises(_Stop):
        evolve_run(cfg, tmp_path / "cut", callbacks=[_StopAfterFirst()], progress=False)
    with pytest.raises(EvodevoError, match="--resume"):
        evolve_run(cfg, tmp_path / "cut", progress=False)
    evolve_run(cfg, tmp_path / "cut", resume=True, progress=False)
    assert history(tmp_path / "full") == history(tmp_path / "cut")


def test_extending_a_finished_run_equals_a_longer_run(tmp_path):
    """--resume with more generations continues as if the run had been started with them."""
    import json

    short = fake_config(evolution={"generations": 2, "early_stop": False})
    longer = fake_config(evolution={"generations": 4, "early_stop": False})
    evolve_run(longer, tmp_path / "long", progress=False)
    evolve_run(short, tmp_path / "ext", progress=False)
    summary = evolve_run(longer, tmp_path / "ext", resume=True, progress=False)
    assert history(tmp_path / "long") == history(tmp_path / "ext")
    assert summary["generations_run"] == 4 and summary["reevaluated_generations"] == []
    saved = json.loads((tmp_path / "ext" / "config.json").read_text())
    assert saved["config"]["evolution"]["generations"] == 4
    assert saved["extended_from_generations"] == [2]
    # fewer generations, or any other change, is still refused
    with pytest.raises(EvodevoError, match="only --generations may grow"):
        evolve_run(short, tmp_path / "ext", resume=True, progress=False)


def test_elites_pass_unchanged_and_every_genome_is_reevaluated():
    cfg = fake_config(
        evolution={"population": 5, "elite_fraction": 0.4, "generations": 3, "early_stop": False}
    )
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        ctrl = make_controller(cfg, ev.n_actions)
        evo = Evolution(cfg, ctrl, ev)
        before = list(evo.population)
        calls = []
        original = ev.evaluate

        def spy(genomes, episodes, **kw):
            calls.append((list(genomes), list(episodes)))
            return original(genomes, episodes, **kw)

        ev.evaluate = spy  # type: ignore[method-assign]
        evo.step()
        res_genomes, eps = calls[0]
        assert len(res_genomes) == 5 and len(eps) == 3
        assert [e.noisy for e in eps] == [False, False, True]  # 70/30 of 3 episodes
        evo.step()
        # the first two of generation 2 are generation 1's best two, the very same objects
        assert all(any(g is b for b in before) for g in calls[1][0][:2])
        assert calls[1][1] != eps  # fresh seeds each generation, shared by all genomes


def test_final_pick_reselects_the_last_elites_on_fresh_clean_episodes(tmp_path):
    """evolution.final_pick_episodes: the elites bred after the last generation are scored on
    the same fresh clean episodes; the one with the most successes is returned (SPEC §2.4)."""
    from evodevo.grn.evolution import EPISODE_KEY, FINAL_PICK_KEY, training_episodes

    cfg = fake_config(
        seed=3,
        evolution={
            "population": 4,
            "elite_fraction": 0.5,
            "generations": 2,
            "early_stop": False,
            "final_pick_episodes": 8,
        },
    )
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        evo = Evolution(cfg, make_controller(cfg, ev.n_actions), ev)
        calls = record_evaluations(ev)
        evo.run()
    assert len(calls) == 3  # two generations, then the pick
    genomes, eps, res = calls[-1]
    assert genomes == evo.population[:2]  # the elites, best first
    assert eps == training_episodes(cfg.seed, FINAL_PICK_KEY, 2, 8, 0.0)
    assert not any(e.noisy for e in eps)
    seen = {e.seed for g in range(2) for e in training_episodes(cfg.seed, EPISODE_KEY, g, 3, 0.3)}
    assert seen.isdisjoint(e.seed for e in eps)
    wins = res.success.sum(axis=1)
    assert wins.tolist() == [1, 2]  # this seed's second elite wins more: it is returned
    assert evo.best_genome is genomes[1] and evo.final_pick["picked_rank"] == 1
    assert evo.final_pick["successes"] == wins.astype(int).tolist()
    assert evo.episodes_run == 4 * 3 * 2 + 2 * 8  # the pick is paid from the budget
    # through a run directory: recorded, and a resumed finished run does not pick again
    summary = evolve_run(cfg, tmp_path / "r", progress=False)
    assert summary["final_pick"]["picked_rank"] == evo.final_pick["picked_rank"]
    again = evolve_run(cfg, tmp_path / "r", resume=True, progress=False)
    assert again["episodes_run"] == summary["episodes_run"] == 40


def test_final_pick_needs_two_elites():
    with pytest.raises(ConfigError, match="final_pick_episodes=5 needs at least 2 elites"):
        fake_config(evolution={"population": 4, "elite_fraction": 0.25, "final_pick_episodes": 5})


def test_dead_worker_is_retried_through_the_evaluator(tmp_path):
    cfg = fake_config()
    eps = [Episode(s) for s in (11, 12, 13)]
    genome = make_controller(cfg, 3).init_genome(np.random.default_rng(0))
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        expect = ev.evaluate([genome, genome], eps)
    marker = tmp_path / "crash-once"
    marker.write_text("x")
    crashing = from_dict(
        GrnConfig, {**_plain(cfg), "env": {"id": FAKE_ID, "kwargs": {"crash_marker": str(marker)}}}
    )
    with Evaluator(crashing, Encoder.from_seed(0), workers=2) as ev:
        got = ev.evaluate([genome, genome], eps)
        assert ev.pool.restarts >= 1
    np.testing.assert_array_equal(got.success, expect.success)
    np.testing.assert_array_equal(got.steps, expect.steps)


def _plain(cfg):
    from evodevo.config import to_dict

    d = to_dict(cfg)
    d.pop("env")
    return d


def test_non_box_action_space_is_a_clear_error():
    cfg = from_dict(GrnConfig, {"env": {"id": "CartPole-v1", "kwargs": {}}})
    with pytest.raises(EvodevoError, match="flat continuous Box"):
        Evaluator(cfg, None)


def test_encoder_is_deterministic_saved_and_reloaded(tmp_path):
    a, b = Encoder.from_seed(3), Encoder.from_seed(3)
    imgs = np.random.default_rng(0).integers(0, 255, (5, 48, 48, 3), dtype=np.uint8)
    fa = a.features(imgs)
    np.testing.assert_array_equal(fa, b.features(imgs))
    np.testing.assert_allclose(np.linalg.norm(fa, axis=1), 1.0, rtol=1e-5)
    assert not np.allclose(fa, Encoder.from_seed(4).features(imgs))
    a.save(tmp_path / "encoder.pt")
    np.testing.assert_array_equal(Encoder.load(tmp_path / "encoder.pt").features(imgs), fa)
    # one batched forward equals per-image forwards
    np.testing.assert_allclose(
        np.concatenate([a.features(imgs[i : i + 1]) for i in range(5)]), fa, atol=1e-6
    )
    state = torch.get_rng_state()
    Encoder.from_seed(5)
    assert torch.equal(state, torch.get_rng_state())  # the global torch RNG is left alone


def test_evolution_on_ray_equals_the_process_pool(tmp_path):
    """the same seed gives the same history on 1 worker, 2 processes and 2 Ray actors."""
    import pytest

    pytest.importorskip("ray")
    from pathlib import Path

    from evodevo.config import load_config
    from evodevo.grn.config import GrnConfig
    from evodevo.grn.evolution import evolve_run

    cfg = load_config(
        GrnConfig,
        Path(__file__).resolve().parents[1] / "configs" / "grn_pendulum.yaml",
        {
            "evolution": {"population": 4, "generations": 2},
            "evaluation": {"episodes": 2, "lockstep": 2},
        },
    )
    runs = {
        name: evolve_run(cfg, tmp_path / name, workers=w, backend=b, progress=False)[
            "fitness_history"
        ]
        for name, w, b in (("one", 1, "local"), ("pool", 2, "local"), ("ray", 2, "ray"))
    }
    assert runs["one"] == runs["pool"] == runs["ray"]
