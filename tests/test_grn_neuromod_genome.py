"""Neuromodulated GRN genome (SPEC §5): .npz round trip, checkpoints, mutation bounds (hypothesis)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evodevo.config import replace
from evodevo.errors import CheckpointError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController, make_controller
from evodevo.grn.neuromodulated import NeuromodGrnController, NeuromodGrnGenome

CFG = GrnConfig(controller="neuromodulated")


def test_registered_and_initialised_within_bounds():
    ctrl = make_controller(CFG, 3)
    assert isinstance(ctrl, NeuromodGrnController)
    g = ctrl.init_genome(np.random.default_rng(0))
    assert g.base.W_s.shape == (8, 50) and g.U1.shape == (4, 9, 8) and g.c2.shape == (4,)
    for v, (lo, hi) in zip(g.gamma, CFG.neuromod.gamma_bounds, strict=True):
        assert lo <= v <= hi
    # the plain part is drawn first, from the same generator state, as the plain controller does
    plain = PlainGrnController(CFG, 3).init_genome(np.random.default_rng(0))
    for name, arr in plain.arrays().items():
        assert np.array_equal(getattr(g.base, name), arr), name


def test_save_load_round_trip_is_bit_identical(tmp_path):
    ctrl = NeuromodGrnController(CFG, 3)
    g = ctrl.init_genome(np.random.default_rng(1))
    path = tmp_path / "g.npz"
    g.save(path, {"controller": "neuromodulated"})
    h = ctrl.load_genome(path)
    assert list(h.arrays()) == NeuromodGrnGenome.names()
    for name, arr in g.arrays().items():
        loaded = h.arrays()[name]
        assert loaded.dtype == arr.dtype and np.array_equal(loaded, arr), name
    again = ctrl.genome_from_arrays(g.arrays())  # what checkpoints use
    assert all(np.array_equal(a, again.arrays()[k]) for k, a in g.arrays().items())
    with pytest.raises(CheckpointError, match="not a 'grn' genome"):
        PlainGrnController(CFG, 3).load_genome(path)
    small = replace(CFG, neuromod=replace(CFG.neuromod, hidden=4))
    with pytest.raises(CheckpointError, match="neuromod.hidden"):
        NeuromodGrnController(small, 3).load_genome(path)


def test_mutation_copies_and_changes_something():
    ctrl = NeuromodGrnController(CFG, 3)
    rng = np.random.default_rng(2)
    parent = ctrl.init_genome(rng)
    before = {k: v.copy() for k, v in parent.arrays().items()}
    children = [ctrl.mutate(parent, rng) for _ in range(30)]
    assert all(np.array_equal(parent.arrays()[k], v) for k, v in before.items())
    changed = {
        k for c in children for k, v in c.arrays().items() if not np.array_equal(v, before[k])
    }
    assert {"U1", "gamma", "W_s"} <= changed


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    sigma=st.floats(0.0, 5.0),
    p=st.floats(0.0, 1.0),
    bound=st.floats(0.0, 1.9),
)
def test_mutation_keeps_every_bound(seed, sigma, p, bound):
    cfg = replace(
        CFG,
        mutation=replace(CFG.mutation, sigma=sigma, p_param=p),
        neuromod=replace(
            CFG.neuromod,
            sigma=sigma,
            p_gamma=p,
            p_net=p,
            gamma_5ht_bounds=(-bound, bound),
            gamma_ne_bounds=(-bound / 2, bound),
        ),
    )
    ctrl = NeuromodGrnController(cfg, 2)
    rng = np.random.default_rng(seed)
    g: NeuromodGrnGenome = ctrl.init_genome(rng)
    for _ in range(5):
        g = ctrl.mutate(g, rng)
        for v, (lo, hi) in zip(g.gamma, cfg.neuromod.gamma_bounds, strict=True):
            assert lo <= v <= hi
        gi = cfg.genome
        assert gi.theta_bounds[0] <= g.base.theta.min() and g.base.theta.max() <= gi.theta_bounds[1]
        assert gi.delta_bounds[0] <= g.base.delta.min() and g.base.delta.max() <= gi.delta_bounds[1]
        assert gi.alpha_bounds[0] <= g.base.alpha.min() and g.base.alpha.max() <= gi.alpha_bounds[1]
        assert np.all(np.isfinite(g.U1))
