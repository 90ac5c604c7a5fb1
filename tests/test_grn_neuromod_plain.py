"""gamma = 0 makes the neuromodulated GRN the plain GRN, bit for bit (SPEC §5), on the same seeds."""

from __future__ import annotations

import numpy as np
import pytest
from test_grn_fakeenv import FAKE_ID

from evodevo.config import replace
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import PlainGrnController, make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import Episode, Evaluator, make_env, run_episodes
from evodevo.grn.neuromodulated import NeuromodGrnController


def _config() -> GrnConfig:
    cfg = GrnConfig(controller="neuromodulated")
    return replace(cfg, env=replace(cfg.env, id=FAKE_ID, kwargs={}))


EPISODES = [Episode(11), Episode(12, noisy=True), Episode(13, noisy=True), Episode(14)]


def _run(ctrl, genomes, encoder):
    envs = [make_env(FAKE_ID) for _ in EPISODES]
    try:
        return run_episodes(envs, encoder, ctrl, genomes, EPISODES, record=True)
    finally:
        for env in envs:
            env.close()


def test_gamma_zero_reproduces_the_plain_grn_exactly():
    cfg = _config()
    neuro, plain = NeuromodGrnController(cfg, 3), PlainGrnController(cfg, 3)
    rng = np.random.default_rng(5)
    bases = [neuro.init_genome(rng).base for _ in EPISODES]  # four different plain genomes
    zero = [neuro.attach(b, rng, gamma=np.zeros(4)) for b in bases]
    enc = Encoder.from_seed(3)
    a, b = _run(neuro, zero, enc), _run(plain, bases, enc)
    assert len(a["x"]) == len(b["x"]) > 1
    for xa, xb in zip(a["x"], b["x"], strict=True):
        assert np.array_equal(xa, xb)
    for ua, ub in zip(a["actions"], b["actions"], strict=True):
        assert np.array_equal(ua, ub)
    assert np.array_equal(a["reward"], b["reward"]) and np.array_equal(a["steps"], b["steps"])
    assert len(a["m"]) == len(a["x"]) and a["m"][0].shape == (len(EPISODES), 4)
    # the modulators still move (they are computed), they just have no effect
    assert not np.allclose(a["m"][-1], 0.5)
    # ... and with gamma != 0 they do have one
    modulated = [neuro.attach(g, rng, gamma=np.array([2.0, 1.5, 1.0, -1.0])) for g in bases]
    c = _run(neuro, modulated, enc)
    assert any(not np.array_equal(xc, xb) for xc, xb in zip(c["x"], b["x"], strict=False))


def test_gamma_zero_through_the_evaluator_on_the_same_seeds():
    cfg = _config()
    plain_cfg = replace(cfg, controller="plain")
    enc = Encoder.from_seed(0)
    neuro = make_controller(cfg, 3)
    rng = np.random.default_rng(1)
    bases = [neuro.init_genome(rng).base for _ in range(3)]
    with Evaluator(cfg, enc) as ev:
        r_n = ev.evaluate([neuro.attach(g, rng, np.zeros(4)) for g in bases], EPISODES)
        r_p = ev.evaluate(bases, EPISODES, config=plain_cfg)
    assert np.array_equal(r_n.reward, r_p.reward)
    assert np.array_equal(r_n.success, r_p.success)
    assert np.array_equal(r_n.steps, r_p.steps)


def test_plain_genome_is_refused_with_a_hint():
    cfg = _config()
    neuro = NeuromodGrnController(cfg, 3)
    plain = PlainGrnController(cfg, 3).init_genome(np.random.default_rng(0))
    with pytest.raises(Exception, match="attach"):
        neuro.reset_state([plain])
