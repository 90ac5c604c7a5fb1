"""Neuromodulated GRN (SPEC §5): Eq. 5.2–5.4, Eq. 3.1/3.5 and the DA→5HT, NE→ACh order, by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evodevo.config import replace
from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig, NeuromodConfig
from evodevo.grn.modulation import (
    modulated_decay,
    modulated_regulation,
    modulated_threshold,
    modulator_update,
    regulatory_gain,
    target_network,
)
from evodevo.grn.neuromodulated import NeuromodGrnController


def sigmoid(z: float) -> float:
    return 1.0 / (1.0 + math.exp(-z))


def test_eq_5_2_decay_is_exponential_in_dopamine():
    delta = np.array([[0.2, 0.6]])
    # m_DA = 1, gamma 2: factor e^1; m_DA = 0.25, gamma -2: factor e^0.5
    out = modulated_decay(delta, np.array([1.0]), np.array([2.0]))
    np.testing.assert_allclose(out, [[0.2 * math.e, 0.6 * math.e]], rtol=1e-15)
    out = modulated_decay(delta, np.array([0.25]), np.array([-2.0]))
    assert out[0, 0] == pytest.approx(0.32974425414002564, rel=1e-15)
    # batch items keep their own modulator: m = 0.5 leaves delta unchanged
    both = modulated_decay(np.vstack([delta, delta]), np.array([0.5, 0.0]), np.array([3.0, 1.0]))
    assert both[0].tolist() == [0.2, 0.6]
    assert both[1] == pytest.approx([0.2 * math.exp(-0.5), 0.6 * math.exp(-0.5)])


def test_eq_5_3_threshold_is_linear_in_serotonin():
    theta = np.array([[0.4, 1.0]])
    out = modulated_threshold(theta, np.array([0.9]), np.array([1.5]))  # 1 + 1.5 * 0.4 = 1.6
    np.testing.assert_allclose(out, [[0.64, 1.6]], rtol=1e-15)
    out = modulated_threshold(theta, np.array([0.0]), np.array([1.5]))  # 1 - 0.75 = 0.25
    np.testing.assert_allclose(out, [[0.1, 0.25]], rtol=1e-15)


def test_eq_5_4_regulation_scales_every_weight_and_keeps_absent_links_absent():
    W = np.array([[[0.3, 0.0], [-0.2, 0.1]]])
    m_ne, m_ach = np.array([0.7]), np.array([0.2])
    g_ne, g_ach = np.array([1.0]), np.array([-0.5])
    gain = regulatory_gain(m_ne, m_ach, g_ne, g_ach)  # 1 + 0.2 + 0.15
    assert gain == pytest.approx([1.35])
    out = modulated_regulation(W, m_ne, m_ach, g_ne, g_ach)
    np.testing.assert_allclose(out, [[[0.405, 0.0], [-0.27, 0.135]]], rtol=1e-15)
    assert out[0, 0, 1] == 0.0


def test_gamma_zero_factors_are_exactly_one():
    rng = np.random.default_rng(0)
    delta, theta = rng.uniform(0.05, 1, (3, 5)), rng.uniform(0.1, 1, (3, 5))
    W = rng.normal(0, 0.1, (3, 5, 5))
    m = rng.uniform(0, 1, (3, 4))
    z = np.zeros(3)
    assert np.array_equal(modulated_decay(delta, m[:, 0], z), delta)
    assert np.array_equal(modulated_threshold(theta, m[:, 1], z), theta)
    assert np.array_equal(modulated_regulation(W, m[:, 2], m[:, 3], z, z), W)


def test_eq_3_1_update_and_target_network_by_hand():
    assert modulator_update(np.array(0.5), np.array(0.9), np.array(0.1)) == pytest.approx(0.54)
    v = np.array([[[1.0, 2.0]]])  # B=1, k=1, d=2
    U1 = np.array([[[[1.0, -1.0], [0.5, 1.0]]]])  # v U1 = [2, 1]
    c1 = np.array([[[0.0, -2.0]]])  # relu([2, -1]) = [2, 0]
    U2 = np.array([[[0.5, 3.0]]])  # z = 1
    out = target_network(v, U1, c1, U2, np.array([[0.0]]))
    assert out[0, 0] == pytest.approx(sigmoid(1.0), rel=1e-14)
    big = target_network(v, U1 * 1e4, c1, U2, np.array([[0.0]]))  # no overflow warning
    assert big[0, 0] == pytest.approx(1.0)


def _hand_controller(n_sensors: int = 2) -> tuple[NeuromodGrnController, object]:
    cfg = GrnConfig(controller="neuromodulated")
    cfg = replace(
        cfg,
        sensors=replace(cfg.sensors, n_visual=0, n_proprio=n_sensors),
        neuromod=replace(cfg.neuromod, hidden=1),
    )
    ctrl = NeuromodGrnController(cfg, n_actions=1)
    g = ctrl.init_genome(np.random.default_rng(0))
    for name in ("U1", "c1", "U2", "c2"):
        getattr(g, name)[:] = 0.0
    g.U2[:, 0] = 1.0  # every target = sigmoid(relu(signal weight * signal + c1) + c2)
    return ctrl, g


def test_dependency_order_5ht_reads_new_da_ach_reads_new_ne():
    ctrl, g = _hand_controller()
    d = 2  # index of the task-signal input (after the 2 sensors)
    g.c2[0] = 2.0  # DA target sigmoid(2)
    g.c2[2] = -1.0  # NE target sigmoid(-1)
    g.U1[1, d, 0] = 1.0  # 5HT target sigmoid(m_DA)
    g.U1[3, d, 0] = 2.0  # ACh target sigmoid(2 m_NE)
    state = ctrl.reset_state([g])
    m = ctrl.update_modulators(state, np.array([0]), np.zeros((1, 2)))[0]
    da = 0.5 + 0.1 * (sigmoid(2.0) - 0.5)
    ne = 0.5 + 0.05 * (sigmoid(-1.0) - 0.5)
    sht = 0.5 + 0.5 * (sigmoid(da) - 0.5)
    ach = 0.5 + 0.3 * (sigmoid(2 * ne) - 0.5)
    assert m == pytest.approx([da, sht, ne, ach], rel=1e-14)
    assert m[1] != pytest.approx(0.5 + 0.5 * (sigmoid(0.5) - 0.5))  # not the old DA state
    assert np.array_equal(state.m[0], m)


def test_task_signals_reward_so_far_and_novelty_decay():
    ctrl, g = _hand_controller()
    g.U1[0, 2, 0] = 1.0  # DA target sigmoid(relu(tanh(scale * R)))
    g.U1[2, 2, 0] = 1.0  # NE target sigmoid(relu(novelty))
    state = ctrl.reset_state([g, g])
    idx = np.array([0, 1])
    features, proprio = None, np.zeros((2, 2))
    rngs = [np.random.default_rng(1), np.random.default_rng(2)]
    novelty, da, ne = 1.0, 0.5, 0.5
    for t in range(3):
        assert state.novelty == pytest.approx([novelty, novelty])
        ctrl.step(state, idx, features, proprio, rngs, np.zeros(2, bool))
        ne = ne + 0.05 * (sigmoid(novelty) - ne)
        da = da + 0.1 * (sigmoid(math.tanh(0.3 * t)) - da)  # reward so far = 0.3 t for slot 0
        assert state.m[0, 2] == pytest.approx(ne, rel=1e-14)
        assert state.m[0, 0] == pytest.approx(da, rel=1e-14)
        novelty *= 0.995
        ctrl.observe_reward(state, np.array([0]), np.array([0.3]))
    assert state.reward.tolist() == pytest.approx([0.9, 0.0])
    assert state.novelty[1] == pytest.approx(0.995**3)


def test_config_rejects_5ht_bounds_that_would_zero_a_threshold():
    with pytest.raises(ConfigError, match="gamma_5ht_bounds"):
        NeuromodConfig(gamma_5ht_bounds=(-2.0, 1.0)).validate()
    with pytest.raises(ConfigError, match="tau"):
        NeuromodConfig(tau=(0.1, 1.5, 0.05, 0.3)).validate()
    NeuromodConfig().validate()
