"""The reaching-map options of the vision preset: ``dynamics.restart`` and
``sensors.proprio`` (SPEC §2.1, §2.2), for the plain and the neuromodulated GRN."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evodevo.config import load_config
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController
from evodevo.grn.dynamics import expression_step, motor_output
from evodevo.grn.genome import init_genome
from evodevo.grn.neuromodulated import NeuromodGrnController
from evodevo.grn.vision_preset import vision_preset

ROOT = Path(__file__).resolve().parents[1]


def _cfg(**over: dict) -> GrnConfig:
    return load_config(GrnConfig, None, {**vision_preset(), **over})


def _step(ctrl, state, feats, prop, seed=0):
    n = feats.shape[0]
    rngs = [np.random.default_rng(seed + b) for b in range(n)]
    return ctrl.step(state, np.arange(n), feats, prop, rngs, np.zeros(n, bool))


def test_thesis_defaults_carry_the_expression_and_read_proprioception():
    cfg = GrnConfig()
    assert cfg.dynamics.restart is False and cfg.sensors.proprio is True
    thesis = load_config(GrnConfig, ROOT / "configs" / "grn.yaml")
    assert thesis.dynamics.restart is False and thesis.sensors.proprio is True
    vision = load_config(GrnConfig, ROOT / "configs" / "grn_vision.yaml")
    assert vision.dynamics.restart is True and vision.sensors.proprio is False


@pytest.mark.parametrize("kind", [PlainGrnController, NeuromodGrnController])
def test_restart_makes_each_control_step_start_from_x0(kind):
    ctrl = kind(_cfg(), 3)
    g = ctrl.init_genome(np.random.default_rng(0))
    feats = np.array([[1.0, -0.5, 0.4, 1.0]])
    prop = np.zeros((1, 4))
    state = ctrl.reset_state([g])
    _step(ctrl, state, np.array([[-2.0, 2.0, 0.4, 1.0]]), prop)  # a different first input
    a_after = _step(ctrl, state, feats, prop, seed=7)
    a_fresh = _step(ctrl, ctrl.reset_state([g]), feats, prop, seed=7)
    if kind is PlainGrnController:  # no memory at all: the same input gives the same action
        assert np.array_equal(a_after, a_fresh)
    else:  # only the modulators (Eq. 3.1, once per control step) remember; expression restarts
        assert np.all(np.isfinite(a_after))
    # without restart the first input is remembered
    carry = kind(_cfg(dynamics={**vision_preset()["dynamics"], "restart": False}), 3)
    state = carry.reset_state([g])
    _step(carry, state, np.array([[-2.0, 2.0, 0.4, 1.0]]), prop)
    assert not np.array_equal(_step(carry, state, feats, prop, seed=7), a_fresh)


def test_restart_step_is_substeps_euler_steps_from_x0():
    cfg = _cfg(dynamics={"dt": 0.1, "substeps": 4, "restart": True, "noise_std": 0.0})
    ctrl = PlainGrnController(cfg, 3)
    g = init_genome(cfg, 3, np.random.default_rng(1))
    state = ctrl.reset_state([g])
    feats, prop = np.array([[0.7, -1.2, 0.5, 1.0]]), np.zeros((1, 4))
    _step(ctrl, state, -feats, prop)
    a = _step(ctrl, state, feats, prop)
    s = np.concatenate([feats @ g.P, prop], axis=1)
    x = np.full((1, 50), cfg.dynamics.x0)
    for _ in range(4):
        x = expression_step(
            x, s, g.W_s[None], g.W_r[None], g.theta[None], g.delta[None], g.alpha[None], 0.1,
            np.zeros((1, 50)),
        )  # fmt: skip
    np.testing.assert_allclose(state.x, x)
    np.testing.assert_allclose(a, motor_output(x, g.W_m[None]))


@pytest.mark.parametrize("kind", [PlainGrnController, NeuromodGrnController])
def test_proprio_off_hides_proprioception_not_vision(kind):
    ctrl = kind(_cfg(), 3)
    g = ctrl.init_genome(np.random.default_rng(2))
    feats = np.array([[1.0, -0.5, 0.4, 1.0], [1.0, -0.5, 0.4, 1.0]])
    prop = np.array([[0.9, -0.9, 0.8, 1.0], [-0.3, 0.4, -0.5, 0.2]])
    a = _step(ctrl, ctrl.reset_state([g, g]), feats, prop, seed=3)
    b = _step(ctrl, ctrl.reset_state([g, g]), feats, prop[::-1], seed=3)
    assert np.array_equal(a, b)  # proprioception does not reach the genes
    c = _step(ctrl, ctrl.reset_state([g, g]), feats * [[-1, -1, 1, 1]], prop, seed=3)
    assert not np.array_equal(a, c)  # the target offset does
    on = kind(_cfg(sensors={**vision_preset()["sensors"], "proprio": True}), 3)
    d = _step(on, on.reset_state([g, g]), feats, prop, seed=3)
    assert not np.array_equal(d[0], d[1])


def test_search_surrogate_rows_are_configs():
    """The committed surrogate (docs/results/grn_vision/search_surrogate.py) runs a row."""
    import importlib.util

    path = ROOT / "docs" / "results" / "grn_vision" / "search_surrogate.py"
    spec = importlib.util.spec_from_file_location("search_surrogate", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    for over in mod.ROWS.values():
        load_config(GrnConfig, None, mod._merge(vision_preset(), over))  # every row is valid
    tiny = mod._merge(mod.ROWS["new preset, 12 x 6 x 10 (720)"], mod._budget(4, 2, 2))
    med, within = mod.evolve(tiny, seed=0)
    assert med >= 0 and 0 <= within <= 1
