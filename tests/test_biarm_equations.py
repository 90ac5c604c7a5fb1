"""BIARM equations against hand-worked cases (SPEC §1.1-1.5)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from evodevo.errors import EvodevoError
from evodevo.neuromod.config import MODULE_NAMES, ModuleConfig
from evodevo.neuromod.evaluation import improvement, retention
from evodevo.neuromod.lr_modulation import effective_lr
from evodevo.neuromod.modules import Neuromodulators, ema_update, novelty_decay
from evodevo.neuromod.padding import check_fits, phi, phi_into

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _sig(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-x))


def test_eq_3_1_ema_hand_case():
    # s = 0.5, target 0.9, tau 0.1 -> 0.5 + 0.1 * 0.4 = 0.54
    assert ema_update(0.5, 0.9, 0.1) == pytest.approx(0.54)
    assert ema_update(0.2, 0.0, 0.5) == pytest.approx(0.1)


def test_eq_3_5_novelty_hand_case():
    n = 1.0
    for _ in range(3):
        n = novelty_decay(n, 0.995)
    assert n == pytest.approx(0.995**3)


def test_eq_3_7_lr_hand_case():
    # 1e-3 * (0.3*1 + 0.2*0 + 0.3*0.5 + 0.2*0.25) = 1e-3 * 0.5
    assert effective_lr(1e-3, [1.0, 0.0, 0.5, 0.25], [0.3, 0.2, 0.3, 0.2]) == pytest.approx(5e-4)


def test_eq_3_7_is_the_rate_the_agent_trains_with():
    """BiarmAgent.lr() is Eq. 3.7 of the module states (v1: as written, eta_base/2 at rest)."""
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig
    from evodevo.neuromod.variants import get_variant

    cfg = BiarmConfig()
    cfg.modules.lr_relative = False
    agent = BiarmAgent(cfg, get_variant("biarm"), obs_dim=4, seed=0)
    # the weights are held as float32 internally
    assert agent.lr() == pytest.approx(effective_lr(1e-3, [0.5] * 4, [0.3, 0.2, 0.3, 0.2]))
    assert agent.lr() == pytest.approx(5e-4)
    assert BiarmAgent(cfg, get_variant("pnn"), obs_dim=4, seed=0).lr() == 1e-3


def test_eq_3_10_padding():
    out = phi(np.array([1.0, -2.0]), 4)
    assert out.dtype == np.float32 and out.tolist() == [1.0, -2.0, 0.0, 0.0]
    row = np.zeros(4, np.float32)
    phi_into(row, np.array([3.0, 4.0, 5.0], np.float32))
    assert row.tolist() == [3.0, 4.0, 5.0, 0.0]
    with pytest.raises(EvodevoError, match="exceeds d_max=2"):
        check_fits(3, 2, "X-v0")
    with pytest.raises(EvodevoError, match="exceeds d_max"):
        phi(np.ones(5), 4)


def _module_targets(mods: Neuromodulators, obs: np.ndarray, extra: dict[str, float]) -> dict:
    """Reference: each module's target from its own slice of the stacked weights."""
    from evodevo.neuromod.modules import LAYOUT

    _d, h = mods.obs_dim, mods.hidden
    w1 = mods.w1.detach().numpy()
    out = {}
    for j, m in enumerate(LAYOUT):
        x = np.concatenate([obs, [extra[m]]]).astype(np.float64)
        hid = np.maximum(
            x @ w1[:, j * h : (j + 1) * h] + mods.b1.detach().numpy()[j * h : (j + 1) * h], 0
        )
        out[m] = _sig(float(hid @ mods.w2.detach().numpy()[j] + mods.b2.detach().numpy()[j]))
    return out


def test_module_step_matches_reference_with_dependency_order():
    cfg = ModuleConfig()
    mods = Neuromodulators(cfg, obs_dim=3, seed=1)
    with torch.no_grad():  # non-zero biases so the hand case uses them
        mods.b1.uniform_(-0.5, 0.5)
        mods.b2.uniform_(-0.5, 0.5)
    obs = np.array([0.3, -1.2, 0.7], np.float32)
    s0 = dict(zip(MODULE_NAMES, mods.states.tolist(), strict=True))
    mods.step(obs, reward=2.0)
    # DA and NE first (reward, novelty 1.0), then 5HT / ACh read the *updated* DA / NE.
    t = _module_targets(mods, obs, {"DA": 2.0, "NE": 1.0, "5HT": 0.0, "ACh": 0.0})
    da = s0["DA"] + 0.1 * (t["DA"] - s0["DA"])
    ne = s0["NE"] + 0.05 * (t["NE"] - s0["NE"])
    t2 = _module_targets(mods, obs, {"DA": 0, "NE": 0, "5HT": da, "ACh": ne})
    ht = s0["5HT"] + 0.5 * (t2["5HT"] - s0["5HT"])
    ach = s0["ACh"] + 0.3 * (t2["ACh"] - s0["ACh"])
    got = dict(zip(MODULE_NAMES, mods.states.tolist(), strict=True))
    assert got["DA"] == pytest.approx(da, rel=1e-5)
    assert got["NE"] == pytest.approx(ne, rel=1e-5)
    assert got["5HT"] == pytest.approx(ht, rel=1e-5)
    assert got["ACh"] == pytest.approx(ach, rel=1e-5)
    # the stale-state version (5HT reading the old DA) differs: the order matters
    t_old = _module_targets(mods, obs, {"DA": 0, "NE": 0, "5HT": s0["DA"], "ACh": s0["NE"]})
    assert t_old["5HT"] != pytest.approx(t2["5HT"], rel=1e-7)
    assert mods.n_task == pytest.approx(0.995)
    mods.start_task()
    assert mods.n_task == 1.0


@pytest.mark.parametrize("ablated", MODULE_NAMES)
def test_ablation_holds_half_and_feeds_half_downstream(ablated):
    cfg = ModuleConfig()
    mods = Neuromodulators(cfg, obs_dim=2, seed=3, ablated=(ablated,))
    full = Neuromodulators(cfg, obs_dim=2, seed=3)
    obs = np.array([0.5, -0.5], np.float32)
    for _ in range(20):
        mods.step(obs, 1.0)
        full.step(obs, 1.0)
    st = dict(zip(MODULE_NAMES, mods.states.tolist(), strict=True))
    assert st[ablated] == 0.5
    others = [m for m in MODULE_NAMES if m != ablated]
    assert all(st[m] != 0.5 for m in others)
    # a downstream module of an ablated one equals a reference fed 0.5
    down = {"DA": "5HT", "NE": "ACh"}.get(ablated)
    if down is not None:
        ref = Neuromodulators(cfg, obs_dim=2, seed=3)
        s = 0.5
        for _ in range(20):
            t = _module_targets(ref, obs, {"DA": 0, "NE": 0, "5HT": 0.5, "ACh": 0.5})[down]
            s = s + dict(zip(MODULE_NAMES, cfg.taus, strict=True))[down] * (t - s)
        assert st[down] == pytest.approx(s, rel=1e-5)


def test_batch_targets_match_per_step_networks():
    cfg = ModuleConfig(learning="learned")
    mods = Neuromodulators(cfg, obs_dim=3, seed=0)
    obs = torch.tensor([[0.1, 0.2, 0.3], [-1.0, 0.0, 2.0]])
    out = mods.batch_targets(obs, torch.tensor([1.0, -1.0]), torch.tensor([0.9, 0.5]))
    for b in range(2):
        t = _module_targets(
            mods, obs[b].numpy(), {"DA": [1.0, -1.0][b], "NE": [0.9, 0.5][b], "5HT": 0, "ACh": 0}
        )
        t2 = _module_targets(
            mods, obs[b].numpy(), {"DA": 0, "NE": 0, "5HT": t["DA"], "ACh": t["NE"]}
        )
        assert out[b].tolist() == pytest.approx([t["DA"], t["NE"], t2["5HT"], t2["ACh"]], rel=1e-5)
    out.sum().backward()
    assert mods.w1.grad is not None and mods.w1.grad.abs().sum() > 0


def test_retention_and_improvement_cases():
    assert retention(500.0, 500.0) == 1.0
    assert retention(400.0, 300.0) == pytest.approx(0.75)
    assert retention(-88.20, -93.50) == pytest.approx(0.9433, abs=1e-4)  # thesis' 94.3 %
    assert math.isnan(retention(-10.0, 5.0))
    assert improvement(233.37, -417.17) == pytest.approx(155.94, abs=0.01)
    assert improvement(500.0, 491.0) == pytest.approx(1.83, abs=0.01)


@settings(max_examples=30, deadline=None)
@given(
    obs=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
    rewards=st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=20),
)
def test_states_stay_in_unit_interval(obs, rewards):
    mods = Neuromodulators(ModuleConfig(), obs_dim=3, seed=0)
    x = np.asarray(obs, np.float32)
    for r in rewards:
        mods.step(x, r)
        s = mods.states
        assert np.all((s >= 0) & (s <= 1))
    assert 0 < mods.n_task <= 1


@given(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4))
def test_retention_bounds(initial, final):
    r = retention(initial, final)
    if initial == final:
        assert r == 1.0
    elif initial > 0 and final >= 0:
        assert r >= 0
    elif initial < 0 and final < 0:
        # >= 0, not > 0: a denormal over a normal number underflows to 0 (-5e-324 / -2)
        assert r >= 0 and (r <= 1) == (final <= initial)


def test_eq_3_7_relative_to_rest_gives_eta_base_at_rest():
    """``modules.lr_relative``: Eq. 3.7 divided by its resting value: eta_base when
    every module rests at ``initial_state``, scaled by the same state-dependent factor as Eq.
    3.7 otherwise; Eq. 3.7 as written gives eta_base / 2 at rest. PNN ignores both."""
    from evodevo.config import from_dict
    from evodevo.errors import ConfigError
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import BiarmConfig
    from evodevo.neuromod.variants import get_variant

    plain_cfg = from_dict(BiarmConfig, {"modules": {"lr_relative": False}})
    plain = BiarmAgent(plain_cfg, get_variant("biarm"), obs_dim=4, seed=0)
    rel_cfg = BiarmConfig()  # the default since 2026-12-05
    assert rel_cfg.modules.lr_relative
    rel = BiarmAgent(rel_cfg, get_variant("biarm"), obs_dim=4, seed=0)
    assert plain.lr() == pytest.approx(0.0005)
    assert rel.lr() == pytest.approx(0.001)
    for agent in (plain, rel):
        agent.modules.set_states([0.9, 0.7, 0.1, 0.3])  # DA, 5HT, NE, ACh
    assert rel.lr() == pytest.approx(plain.lr() / 0.5)
    pnn = BiarmAgent(rel_cfg, get_variant("pnn"), obs_dim=4, seed=0)
    assert pnn.lr() == 0.001
    with pytest.raises(ConfigError, match="lr_relative"):
        from_dict(BiarmConfig, {"modules": {"lr_relative": True, "initial_state": 0.0}})
