"""The arms of "does regulation help?": the GRN without regulation (``genome.regulation:
false``) and the evolved linear and MLP policies (``controller: linear | mlp``), as configs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_grn_evaluator import fake_config, record_evaluations

from evodevo.config import from_dict
from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import Evaluator
from evodevo.grn.evolution import Evolution
from evodevo.grn.feedforward import FeedForwardGenome, LinearController, MlpController
from evodevo.grn.genome import init_genome


@pytest.mark.parametrize("optimizer", ["ga", "cmaes"])
def test_without_regulation_w_r_stays_zero_through_evolution(optimizer):
    cfg = fake_config(
        genome={"regulation": False},
        # every mutation kind as often as possible, the thesis' dense W_r noise included
        mutation={"p_struct": 1.0, "p_weight": 1.0, "dense_regulatory_noise": True},
        evolution={"optimizer": optimizer, "population": 5, "generations": 3, "early_stop": False},
    )
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        evo = Evolution(cfg, make_controller(cfg, ev.n_actions), ev)
        calls = record_evaluations(ev)
        evo.run()
    evaluated = [g for genomes, _, _ in calls for g in genomes]
    assert len(evaluated) == 15
    assert all(not np.any(g.W_r) for g in [*evaluated, *evo.population, evo.best_genome])
    assert all(r.best_connections == 0 for r in evo.history)
    # the other arrays differ between genomes: evolution did run
    assert len({g.W_s.tobytes() for g in evaluated}) > 5


def test_without_regulation_the_other_arrays_are_the_regulated_arms():
    on, off = GrnConfig(), from_dict(GrnConfig, {"genome": {"regulation": False}})
    a = init_genome(on, 3, np.random.default_rng(4))
    b = init_genome(off, 3, np.random.default_rng(4))
    assert a.connections() > 0 and b.connections() == 0
    for name in ("W_s", "W_m", "theta", "delta", "alpha", "P"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    ctrl = make_controller(off, 3)
    assert "W_r" not in ctrl.evolvable(b)  # no W_r coordinates for CMA-ES


def test_a_genome_with_regulation_is_refused_by_the_no_regulation_arm(tmp_path):
    g = init_genome(GrnConfig(), 3, np.random.default_rng(0))
    g.save(tmp_path / "g.npz", {"sensors": {"encoder": "cnn"}})
    off = make_controller(from_dict(GrnConfig, {"genome": {"regulation": False}}), 3)
    with pytest.raises(CheckpointError, match="regulation: false"):
        off.load_genome(tmp_path / "g.npz")
    with pytest.raises(CheckpointError, match="regulation: false"):
        off.genome_from_arrays(g.arrays())


def _ff_config(**sensors) -> GrnConfig:
    """The vision preset's inputs: 4 blob features and 4 proprioceptive values."""
    return from_dict(
        GrnConfig,
        {
            "sensors": {"encoder": "blob", "feature_dim": 4, **sensors},
            "feedforward": {"hidden": 2},
            "evaluation": {"visual_noise": 0.5},
        },
    )


FEATURES = np.array([[0.5, -1.0, 0.2, 1.0], [0.0, 2.0, 0.0, 1.0]])
PROPRIO = np.array([[0.1, 0.2, 0.3, 0.4], [-0.5, 0.0, 0.5, 1.0]])


def _rngs() -> list[np.random.Generator]:
    return [np.random.default_rng(1), np.random.default_rng(2)]


def test_linear_policy_actions_match_a_hand_computed_case():
    ctrl = LinearController(_ff_config(), n_actions=3)
    W = np.zeros((8, 3))
    W[0, 0], W[1, 1], W[7, 2] = 2.0, 1.0, -3.0  # dx -> a0, dy -> a1, last proprio -> a2
    b = np.array([0.0, 0.5, 0.1])
    g = FeedForwardGenome(W, b)
    state = ctrl.reset_state([g, g])
    a = ctrl.step(state, np.arange(2), FEATURES, PROPRIO, _rngs(), np.array([False, False]))
    want = np.tanh(
        [
            [2.0 * 0.5, -1.0 + 0.5, -3.0 * 0.4 + 0.1],
            [0.0, 2.0 + 0.5, -3.0 * 1.0 + 0.1],
        ]
    )
    np.testing.assert_allclose(a, want, rtol=0, atol=1e-15)


def test_mlp_policy_actions_match_a_hand_computed_case():
    ctrl = MlpController(_ff_config(), n_actions=3)
    W1 = np.zeros((8, 2))
    W1[0, 0], W1[4, 1] = 1.0, -2.0  # unit 0 reads dx, unit 1 the first proprio
    b1 = np.array([0.0, 0.3])
    W2 = np.array([[1.0, 0.0, 2.0], [0.0, -1.0, 1.0]])
    b2 = np.array([0.1, 0.0, -0.2])
    g = FeedForwardGenome(W1, b1, W2, b2)
    a = ctrl.step(
        ctrl.reset_state([g]),
        np.arange(1),
        FEATURES[:1],
        PROPRIO[:1],
        _rngs()[:1],
        np.zeros(1, bool),
    )
    h = np.tanh([0.5, -2.0 * 0.1 + 0.3])
    want = np.tanh([h[0] + 0.1, -h[1], 2.0 * h[0] + h[1] - 0.2])
    np.testing.assert_allclose(a[0], want, rtol=0, atol=1e-15)


def test_feedforward_inputs_follow_blind_proprio_and_noise():
    g = FeedForwardGenome(np.eye(8, 3), np.zeros(3))
    noisy = np.array([True, False])
    seeing = LinearController(_ff_config(), 3)
    s = seeing.inputs(FEATURES, PROPRIO, _rngs(), noisy)
    noise = np.random.default_rng(1).normal(0.0, 0.5, 4)  # slot 0's generator, first draw
    np.testing.assert_allclose(s[0], [*(FEATURES[0] + noise), *PROPRIO[0]])
    np.testing.assert_allclose(s[1], [*FEATURES[1], *PROPRIO[1]])
    blind = LinearController(_ff_config(blind=True), 3)
    assert not blind.uses_encoder
    np.testing.assert_array_equal(blind.inputs(None, PROPRIO, _rngs(), noisy)[:, :4], 0.0)
    no_prop = LinearController(_ff_config(proprio=False), 3)
    np.testing.assert_array_equal(no_prop.inputs(FEATURES, PROPRIO, _rngs(), noisy)[:, 4:], 0.0)
    assert seeing.step(
        seeing.reset_state([g, g]), np.arange(2), FEATURES, PROPRIO, _rngs(), noisy
    ).shape == (2, 3)


@pytest.mark.parametrize("kind", [LinearController, MlpController])
def test_feedforward_genomes_save_load_and_mutate(tmp_path, kind):
    cfg = _ff_config()
    ctrl = kind(cfg, 3)
    g = ctrl.init_genome(np.random.default_rng(0))
    g.save(tmp_path / "g.npz", {"sensors": {"encoder": "blob"}})
    back = ctrl.load_genome(tmp_path / "g.npz")
    assert all(
        np.array_equal(a, b)
        for a, b in zip(g.arrays().values(), back.arrays().values(), strict=True)
    )
    a1 = ctrl.step(
        ctrl.reset_state([g]),
        np.arange(1),
        FEATURES[:1],
        PROPRIO[:1],
        _rngs()[:1],
        np.ones(1, bool),
    )
    a2 = ctrl.step(
        ctrl.reset_state([back]),
        np.arange(1),
        FEATURES[:1],
        PROPRIO[:1],
        _rngs()[:1],
        np.ones(1, bool),
    )
    np.testing.assert_array_equal(a1, a2)
    child = ctrl.mutate(g, np.random.default_rng(1))
    assert all(
        not np.array_equal(a, b)
        for a, b in zip(g.arrays().values(), child.arrays().values(), strict=True)
    )
    other = (MlpController if kind is LinearController else LinearController)(cfg, 3)
    with pytest.raises(CheckpointError, match="another controller"):
        other.load_genome(tmp_path / "g.npz")


@pytest.mark.parametrize(
    ("controller", "optimizer"), [("linear", "ga"), ("mlp", "cmaes"), ("plain", "cmaes")]
)
def test_the_arms_evolve_through_the_cli_with_set(tmp_path, controller, optimizer):
    from typer.testing import CliRunner

    from evodevo.cli import app

    cfg = tmp_path / "fake.yaml"
    cfg.write_text(json.dumps({"env": {"id": fake_config().env.id}}))
    out = tmp_path / "run"
    args = ["grn", "evolve", "--config", str(cfg), "--population", "4", "--generations", "2"]
    args += ["--episodes", "2", "--set", f"controller={controller}"]
    args += ["--set", f"evolution.optimizer={optimizer}", "--set", "genome.regulation=false"]
    res = CliRunner().invoke(app, [*args, "--quiet", "--out", str(out)])
    assert res.exit_code == 0, (res.output, res.exception)
    saved = json.loads((out / "config.json").read_text())["config"]
    assert saved["controller"] == controller and saved["evolution"]["optimizer"] == optimizer
    summary = json.loads((out / "summary.json").read_text())
    assert summary["generations_run"] == 2 and summary["episodes_run"] == 4 * 2 * 2
    genome = make_controller(from_dict(GrnConfig, saved), 3).load_genome(out / "best_genome.npz")
    if controller == "plain":
        assert not np.any(genome.W_r)
