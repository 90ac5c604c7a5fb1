"""Eq. 4.1-4.4 (SPEC §2.1): hand-worked numbers and the per-gene Algorithm 2 reference loop."""

from __future__ import annotations

import numpy as np
import pytest

from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import make_controller
from evodevo.grn.dynamics import expression_step, hill, motor_output
from evodevo.grn.genome import init_genome, stack_genomes


def test_hill_hand_worked():
    u = np.array([0.5, -1.0, 0.0, 2.0])
    theta = np.array([0.5, 0.5, 0.3, 1.0])
    np.testing.assert_allclose(hill(u, theta), [0.5, -0.8, 0.0, 0.8])


def test_one_step_hand_worked():
    # n_s = 1 sensor, n = 2 genes; worked by hand in the comments.
    s = np.array([[1.0]])
    W_s = np.array([[[0.5, -1.0]]])
    W_r = np.array([[[0.0, 0.2], [0.4, 0.0]]])
    x = np.array([[0.3, 0.5]])
    alpha = np.array([[1.0, 2.0]])
    theta = np.array([[0.5, 0.5]])
    delta = np.array([[0.1, 0.2]])
    # u0 = 0.5 + 0.4*0.5*2 = 0.9;  u1 = -1 + 0.2*0.3*1 = -0.94
    # f0 = 0.81/1.06;  f1 = -0.8836/1.1336
    # x0' = 0.3 + 0.05 (f0 - 0.03);  x1' = 0.5 + 0.05 (f1 - 0.1)
    f0, f1 = 0.81 / 1.06, -0.8836 / 1.1336
    expect = [0.3 + 0.05 * (f0 - 0.03), 0.5 + 0.05 * (f1 - 0.1)]
    new = expression_step(x, s, W_s, W_r, theta, delta, alpha, 0.05, np.zeros((1, 2)))
    np.testing.assert_allclose(new[0], expect, rtol=1e-12)
    np.testing.assert_allclose(new[0], [0.33670755, 0.45602682], atol=1e-8)
    W_m = np.array([[[1.0], [-2.0]]])
    np.testing.assert_allclose(motor_output(new, W_m)[0], [np.tanh(new[0, 0] - 2 * new[0, 1])])


def test_clipping_to_unit_interval():
    x = np.array([[0.999, 0.001]])
    new = expression_step(
        x,
        np.array([[10.0]]),
        np.array([[[5.0, -5.0]]]),
        np.zeros((1, 2, 2)),
        np.full((1, 2), 0.1),
        np.full((1, 2), 0.05),
        np.ones((1, 2)),
        1.0,
        np.zeros((1, 2)),
    )
    np.testing.assert_array_equal(new, [[1.0, 0.0]])


def reference_step(x, s, g, dt, eta):
    """Algorithm 2, lines 7-16, one gene at a time (the reference, not the implementation)."""
    n = len(x)
    x_new = np.empty(n)
    for i in range(n):
        u = sum(g.W_s[j, i] * s[j] for j in range(len(s)))
        u += sum(g.W_r[k, i] * x[k] * g.alpha[k] for k in range(n))
        f = u * u / (g.theta[i] ** 2 + u * u) * np.sign(u)
        x_new[i] = min(1.0, max(0.0, x[i] + dt * (f - g.delta[i] * x[i] + eta[i])))
    a = np.tanh(
        np.array([sum(g.W_m[i, k] * x_new[i] for i in range(n)) for k in range(g.W_m.shape[1])])
    )
    return x_new, a


def test_vectorised_equals_per_gene_reference():
    cfg = GrnConfig()
    rng = np.random.default_rng(3)
    genomes = [init_genome(cfg, 3, rng) for _ in range(4)]
    batch = stack_genomes(genomes)
    x = rng.uniform(0, 1, (4, 50))
    for _ in range(5):  # several steps, same noise on both sides
        s = rng.normal(0, 1, (4, 8))
        eta = rng.normal(0, 0.01, (4, 50))
        new = expression_step(
            x, s, batch.W_s, batch.W_r, batch.theta, batch.delta, batch.alpha, 0.05, eta
        )
        act = motor_output(new, batch.W_m)
        for b, g in enumerate(genomes):
            ref_x, ref_a = reference_step(x[b], s[b], g, 0.05, eta[b])
            np.testing.assert_allclose(new[b], ref_x, atol=1e-12)
            np.testing.assert_allclose(act[b], ref_a, atol=1e-12)
        x = new


def test_controller_step_matches_reference_with_its_noise():
    """The controller draws visual noise then eta from the slot's generator, per slot."""
    cfg = GrnConfig()
    ctrl = make_controller(cfg, 3)
    g = ctrl.init_genome(np.random.default_rng(0))
    feats = np.random.default_rng(1).normal(size=(1, 128))
    prop = np.array([[0.1, -0.2, 0.3, 0.9]])
    state = ctrl.reset_state([g])
    a = ctrl.step(state, np.array([0]), feats, prop, [np.random.default_rng(9)], np.array([True]))
    r = np.random.default_rng(9)
    vis = feats[0] @ g.P + r.normal(0, 0.03, 4)
    eta = r.normal(0, 0.01, 50)
    ref_x, ref_a = reference_step(np.full(50, 0.3), np.concatenate([vis, prop[0]]), g, 0.05, eta)
    np.testing.assert_allclose(state.x[0], ref_x, atol=1e-12)
    np.testing.assert_allclose(a[0], ref_a, atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_values_raise(bad):
    cfg = GrnConfig()
    g = stack_genomes([init_genome(cfg, 3, np.random.default_rng(0))])
    s = np.zeros((1, 8))
    s[0, 2] = bad
    with pytest.raises(EvodevoError, match="non-finite"):
        expression_step(
            np.full((1, 50), 0.3),
            s,
            g.W_s,
            g.W_r,
            g.theta,
            g.delta,
            g.alpha,
            0.05,
            np.zeros((1, 50)),
        )
