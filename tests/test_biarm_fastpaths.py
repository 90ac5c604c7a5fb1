"""The fast paths of the BIARM hot loop compute the same equations as the reference paths
(SPEC §1.2-1.4): NumPy acting (:meth:`ProgressiveNet.q_np`) against the torch forward, float
context gates against tensor gates, and the per-step module matrices against the parameters
after in-place edits and optimiser steps."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from evodevo.config import replace
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.columns import ProgressiveNet, gated_laterals
from evodevo.neuromod.config import BiarmConfig, ModuleConfig
from evodevo.neuromod.flat_params import adam_step, flatten
from evodevo.neuromod.modules import Neuromodulators
from evodevo.neuromod.replay import ReplayBuffer
from evodevo.neuromod.variants import get_variant

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _trained_looking_net(gated: bool) -> ProgressiveNet:
    """Four columns with non-zero biases and perturbed weights (so every term matters)."""
    net = ProgressiveNet(obs_dim=5, hidden=16, gated=gated, adapter_dim=4, seed=0)
    for a in (2, 3, 4, 3):
        net.add_column(a)
    gen = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for p in net.parameters():
            p.add_(0.2 * torch.randn(p.shape, generator=gen))
    net.refresh_frozen()
    return net


@pytest.mark.parametrize("gated", [False, True])
def test_numpy_acting_equals_the_torch_forward(gated):
    net = _trained_looking_net(gated)
    states = torch.tensor([0.2, 0.9, 0.4, 0.6])
    x = torch.randn(40, 5, generator=torch.Generator().manual_seed(2))
    for col in range(net.n_columns):
        with torch.no_grad():
            want = net.q(x, col, states)
        got = np.stack([net.q_np(x[i].numpy(), col, states.tolist()) for i in range(len(x))])
        torch.testing.assert_close(torch.from_numpy(got), want, rtol=1e-5, atol=1e-5)
        assert (got.argmax(1) == want.argmax(1).numpy()).all()


def test_numpy_acting_sees_optimiser_steps_of_the_current_column():
    net = _trained_looking_net(True)
    states = [0.5, 0.5, 0.5, 0.5]
    x = np.linspace(-1, 1, 5, dtype=np.float32)
    before = net.q_np(x, 3, states).copy()
    with torch.no_grad():
        net.current.bq.add_(1.0)  # in place, as Adam does
        net.current.ctx_w.mul_(2.0)
    after = net.q_np(x, 3, states)
    with torch.no_grad():
        want = net.q(torch.from_numpy(x)[None], 3, torch.tensor(states))[0]
    torch.testing.assert_close(torch.from_numpy(after), want, rtol=1e-5, atol=1e-5)
    assert not np.allclose(before, after)


def test_float_gate_equals_tensor_gate():
    gen = torch.Generator().manual_seed(3)
    feats = torch.randn(4, 6, 8, generator=gen)
    w, b = torch.randn(4, 8, 6, generator=gen), torch.randn(4, 1, 6, generator=gen)
    heads = ((torch.randn(6, 5, generator=gen), torch.randn(5, generator=gen)),) * 2
    g = 0.37
    for a, t in zip(
        gated_laterals(feats, w, b, g, heads),
        gated_laterals(feats, w, b, torch.tensor(g), heads),
        strict=True,
    ):
        torch.testing.assert_close(a, t)


def _reference_step(mods: Neuromodulators, obs: np.ndarray, reward: float) -> np.ndarray:
    """Eq. 3.1-3.6 straight from the parameters (internal layout DA, NE, 5HT, ACh)."""
    d, h = mods.obs_dim, mods.hidden
    w1, b1 = mods.w1.detach().double().numpy(), mods.b1.detach().double().numpy()
    w2, b2 = mods.w2.detach().double().numpy(), mods.b2.detach().double().numpy()
    s = mods.state_array.astype(np.float64).copy()
    tau = np.array(mods.taus_internal)

    def target(m: int, extra: float) -> float:
        x = np.concatenate([obs, [extra]])
        z = np.maximum(x @ w1[:, m * h : (m + 1) * h] + b1[m * h : (m + 1) * h], 0)
        return 1.0 / (1.0 + np.exp(-(z @ w2[m] + b2[m])))

    s[0] += tau[0] * (target(0, reward) - s[0])
    s[1] += tau[1] * (target(1, mods.n_task) - s[1])
    s[2] += tau[2] * (target(2, s[0]) - s[2])
    s[3] += tau[3] * (target(3, s[1]) - s[3])
    assert d == len(obs)
    return s


def test_module_step_follows_in_place_parameter_edits():
    mods = Neuromodulators(ModuleConfig(), obs_dim=3, seed=0)
    obs = np.array([0.3, -1.2, 0.7], np.float32)
    with torch.no_grad():
        mods.b1.uniform_(-0.5, 0.5)
        mods.b2.uniform_(-0.5, 0.5)
        mods.w1.mul_(1.5)
    want = _reference_step(mods, obs, 2.0)
    mods.step(obs, 2.0)
    np.testing.assert_allclose(mods.state_array, want, rtol=1e-5)


def test_learned_modules_step_with_the_trained_weights():
    cfg = replace(BiarmConfig(), modules=ModuleConfig(learning="learned"))
    agent = BiarmAgent(cfg, get_variant("biarm"), obs_dim=4, seed=0)
    agent.begin_task(2)
    agent.begin_task(3)  # the module networks train from task 2 on
    rng = np.random.default_rng(0)
    buf = ReplayBuffer(100, 4)
    for _ in range(80):
        o = rng.standard_normal(4).astype(np.float32)
        buf.add(o, int(rng.integers(3)), float(rng.standard_normal()), o, False, 0.9)
    mods = agent.modules
    assert mods is not None
    w_before = mods.w1.detach().clone()
    for _ in range(3):
        agent.update(buf.sample(rng, 16))
    assert not torch.equal(w_before, mods.w1)  # Adam changed them (fused: no version bump)
    obs = rng.standard_normal(4).astype(np.float32)
    want = _reference_step(mods, obs, 0.5)
    agent.observe(obs, 0.5)
    np.testing.assert_allclose(mods.state_array, want, rtol=1e-5)


def test_direct_adam_step_equals_optimizer_step_bit_for_bit():
    """``adam_step`` (one call of the fused kernel) = ``Adam(fused=True).step()``: parameters
    and state after several steps at changing learning rates, and a state_dict round trip."""
    gen = torch.Generator().manual_seed(0)
    flats = [flatten([torch.nn.Parameter(torch.randn(7, 5, generator=gen))]) for _ in range(2)]
    flats[1].param.data.copy_(flats[0].param.data)
    ref = torch.optim.Adam([flats[0].param], lr=1e-3, fused=True)
    ours = torch.optim.Adam([flats[1].param], lr=1e-3, fused=True)
    for k, lr in enumerate((1e-3, 4e-4, 2.5e-3, 1e-3)):
        g = torch.randn(35, generator=gen)
        for f in flats:
            f.grad.copy_(g)
        ref.param_groups[0]["lr"] = lr
        ref.step()
        adam_step(ours, lr)
        assert torch.equal(flats[0].param, flats[1].param), k
        if k == 1:  # continue from a reloaded state, as a resumed run does
            ours.load_state_dict(ours.state_dict())
    a, b = ref.state_dict()["state"][0], ours.state_dict()["state"][0]
    assert set(a) == set(b)
    for key in a:
        assert torch.equal(a[key], b[key]) and a[key].dtype == b[key].dtype, key
