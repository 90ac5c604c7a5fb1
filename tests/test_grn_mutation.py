"""Mutation (SPEC §2.4): bounds always hold, sparsity changes only through structural mutation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.grn.genome import init_genome
from evodevo.grn.mutation import mutate_genome
from evodevo.grn.open_loop import OpenLoopController


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    sigma=st.floats(0.0, 5.0),
    p=st.floats(0.0, 1.0),
    rounds=st.integers(1, 5),
)
def test_bounds_hold_after_any_mutation(seed, sigma, p, rounds):
    cfg = from_dict(
        GrnConfig,
        {
            "dynamics": {"n_genes": 10},
            "mutation": {"sigma": sigma, "p_param": p, "p_weight": p, "p_struct": p},
        },
    )
    rng = np.random.default_rng(seed)
    g = init_genome(cfg, 3, rng)
    for _ in range(rounds):
        g = mutate_genome(g, cfg, rng)
    for name in ("theta", "delta", "alpha"):
        lo, hi = getattr(cfg.genome, f"{name}_bounds")
        v = getattr(g, name)
        assert np.all(v >= lo) and np.all(v <= hi), name
        assert np.all(np.isfinite(v))


def test_sparsity_changes_only_through_structural_mutation():
    cfg = from_dict(GrnConfig, {"mutation": {"p_struct": 0.0, "p_weight": 1.0, "sigma": 0.5}})
    rng = np.random.default_rng(0)
    parent = init_genome(cfg, 3, rng)
    child = mutate_genome(parent, cfg, rng)
    np.testing.assert_array_equal(child.W_r != 0, parent.W_r != 0)
    assert not np.array_equal(child.W_r, parent.W_r)  # weights did move
    dense = from_dict(
        GrnConfig, {"mutation": {"p_struct": 0.0, "p_weight": 1.0, "dense_regulatory_noise": True}}
    )
    grown = mutate_genome(parent, dense, rng)
    assert np.count_nonzero(grown.W_r) > np.count_nonzero(parent.W_r) + 1000


def test_structural_mutation_toggles_exactly_one_connection():
    cfg = from_dict(GrnConfig, {"mutation": {"p_struct": 1.0, "p_weight": 0.0, "p_param": 0.0}})
    rng = np.random.default_rng(1)
    parent = init_genome(cfg, 3, rng)
    before = parent.W_r.copy()
    changes = set()
    for _ in range(30):
        child = mutate_genome(parent, cfg, rng)
        diff = np.argwhere(child.W_r != before)
        assert len(diff) == 1
        k, i = diff[0]
        changes.add(bool(before[k, i] != 0))
        np.testing.assert_array_equal(parent.W_r, before)  # parent untouched
    assert changes == {True, False}  # both removals (present) and additions (absent) occurred


def test_open_loop_mutation_stays_in_action_range():
    ctrl = OpenLoopController(from_dict(GrnConfig, {"open_loop": {"sigma": 3.0}}), 3)
    rng = np.random.default_rng(0)
    g = ctrl.init_genome(rng)
    child = ctrl.mutate(g, rng)
    assert child.actions.shape == (8, 3) and np.abs(child.actions).max() <= 1.0
    assert not np.array_equal(child.actions, g.actions)


def test_block_sigma_and_block_p_act_on_the_named_blocks_only():
    base = {"p_struct": 0.0, "p_weight": 1.0, "p_param": 1.0, "sigma": 0.1}
    plain = from_dict(GrnConfig, {"mutation": base})
    parent = init_genome(plain, 3, np.random.default_rng(0))
    same = from_dict(GrnConfig, {"mutation": {**base, "block_sigma": {}, "block_p": {}}})
    a = mutate_genome(parent, plain, np.random.default_rng(1))
    b = mutate_genome(parent, same, np.random.default_rng(1))
    for name in ("W_s", "W_r", "W_m", "P", "theta", "delta", "alpha"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    # W_s with 10 x the step, W_r frozen: the same draws, scaled or skipped
    blocks = from_dict(
        GrnConfig, {"mutation": {**base, "block_sigma": {"W_s": 1.0}, "block_p": {"W_r": 0.0}}}
    )
    c = mutate_genome(parent, blocks, np.random.default_rng(1))
    np.testing.assert_allclose(c.W_s - parent.W_s, 10 * (a.W_s - parent.W_s))
    np.testing.assert_array_equal(c.W_r, parent.W_r)
    assert not np.array_equal(c.W_m, parent.W_m)


@pytest.mark.parametrize(
    "mutation, match",
    [
        ({"block_sigma": {"W_x": 0.1}}, "unknown block 'W_x'"),
        ({"block_p": {"W_s": 1.5}}, r"mutation.block_p.W_s=1.5"),
        ({"block_sigma": {"theta": -0.1}}, r"mutation.block_sigma.theta=-0.1"),
        ({"block_sigma": {"W_m": "big"}}, "must be a number"),
    ],
)
def test_bad_block_mutation_values_name_the_value(mutation, match):
    with pytest.raises(ConfigError, match=match):
        from_dict(GrnConfig, {"mutation": mutation})
