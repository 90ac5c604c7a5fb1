"""The fused C++ gated-lateral kernel against the PyTorch operations, and the flat parameter
buffer against per-tensor Adam (SPEC §1.2-1.3, §1.6)."""

from __future__ import annotations

import shutil

import pytest
import torch

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.neuromod import kernels
from evodevo.neuromod.columns import ProgressiveNet, gated_laterals
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.flat_params import flatten, flatten_adam_state

pytestmark = pytest.mark.usefixtures("one_torch_thread")

#: laterals that matter from the first update (v2's): the kernels are compared on them, not on
#: the default's zero-initialised, 1e-4-scaled ones (tests/test_biarm_lateral_scale.py)
XAVIER = {"lateral_init": "xavier", "lateral_scale": 1.0}


def _cfg() -> BiarmConfig:
    """The kernels' test config: Xavier laterals at scale 1, Eq. 3.7 as written (v2)."""
    return from_dict(BiarmConfig, {"network": XAVIER, "modules": {"lr_relative": False}})


@pytest.fixture(scope="module")
def ext():
    mod = kernels.load()
    if mod is None:
        if shutil.which("g++"):
            pytest.fail(f"g++ is installed but the kernel did not build: {kernels._error}")
        pytest.skip("no C++ compiler: the fused kernel cannot be built here")
    return mod


def _inputs(gen: torch.Generator, k: int = 3, bsz: int = 5, h: int = 8, r: int = 3, a: int = 4):
    def mk(*shape: int) -> torch.Tensor:
        return torch.randn(*shape, generator=gen).requires_grad_(True)

    # the frozen features as ProgressiveNet.features lays them out: rows of a 2B batch
    feats = torch.randn(2 * k, 2 * bsz, h, generator=gen)[:, :bsz]
    return feats, mk(2 * k, h, 2 * r), mk(2 * k, 1, 2 * r), mk(k * r, h), mk(h), mk(k * r, a), mk(a)


@pytest.mark.parametrize("per_sample", [False, True])
def test_kernel_matches_torch_ops_forward_and_gradients(ext, per_sample):
    gen = torch.Generator().manual_seed(0)
    feats, w, b, u2, b2, uq, bq = _inputs(gen)
    bsz = feats.shape[1]
    states = torch.rand(*((bsz, 4) if per_sample else (4,)), generator=gen).requires_grad_(True)
    cw = torch.randn(4, generator=gen).requires_grad_(True)
    leaves = [w, b, states, cw, u2, b2, uq, bq]

    def loss(t2: torch.Tensor, tq: torch.Tensor) -> torch.Tensor:
        return t2.sin().sum() + (tq**2).sum()  # not linear, so every gradient term matters

    gate = torch.sigmoid(states @ cw)
    gate = gate.unsqueeze(1) if per_sample else gate
    want = gated_laterals(feats, w, b, gate, ((u2, b2), (uq, bq)))
    got = ext.gated_lateral(feats, w, b, states, cw, u2, b2, uq, bq)
    for g, wv in zip(got, want, strict=True):
        torch.testing.assert_close(g, wv, rtol=1e-5, atol=1e-5)
    g_want = torch.autograd.grad(loss(*want), leaves)
    g_got = torch.autograd.grad(loss(*got), leaves)
    for name, g, wv in zip(
        ["w", "b", "states", "ctx_w", "u2", "b2", "uq", "bq"], g_got, g_want, strict=True
    ):
        torch.testing.assert_close(g, wv, rtol=1e-4, atol=1e-5, msg=name)


def test_kernel_skips_gradients_nobody_asks_for(ext):
    gen = torch.Generator().manual_seed(1)
    feats, w, b, u2, b2, uq, bq = _inputs(gen)
    states, cw = torch.rand(4, generator=gen), torch.randn(4, generator=gen)  # no grad
    t2, tq = ext.gated_lateral(feats, w, b, states, cw, u2, b2, uq, bq)
    grads = torch.autograd.grad(t2.sum() + tq.sum(), [w, u2])
    assert all(g.abs().sum() > 0 for g in grads)
    with torch.no_grad():  # the target network's path: no graph at all
        t2n, _ = ext.gated_lateral(feats, w, b, states, cw, u2, b2, uq, bq)
    assert not t2n.requires_grad
    torch.testing.assert_close(t2n, t2.detach())


def test_kernel_rejects_wrong_shapes(ext):
    gen = torch.Generator().manual_seed(2)
    feats, w, b, u2, b2, uq, bq = _inputs(gen)
    with pytest.raises(RuntimeError, match=r"states \(4,\) or \(B, 4\)"):
        ext.gated_lateral(feats, w, b, torch.zeros(3), torch.zeros(4), u2, b2, uq, bq)
    with pytest.raises(RuntimeError, match="even n"):
        ext.gated_lateral(feats[:3], w[:3], b[:3], torch.zeros(4), torch.zeros(4), u2, b2, uq, bq)


def _stack(kernel: str) -> ProgressiveNet:
    net = ProgressiveNet(obs_dim=5, hidden=16, gated=True, adapter_dim=4, seed=0,
                         lateral_kernel=kernel)  # fmt: skip
    for n in (2, 3, 4):
        net.add_column(n)
    return net


def test_column_with_cpp_kernel_equals_torch_kernel(ext):
    cpp, tch = _stack("cpp"), _stack("torch")
    assert cpp.kernel == "cpp" and tch.kernel == "torch"
    x = torch.randn(6, 5, generator=torch.Generator().manual_seed(3))
    states = torch.tensor([0.2, 0.9, 0.4, 0.6])
    qs = []
    for net in (cpp, tch):
        prev = net.features(x, 2, states)
        q = net.current(x, prev, states)
        q.square().sum().backward()
        qs.append(q.detach())
    torch.testing.assert_close(qs[0], qs[1], rtol=1e-5, atol=1e-5)
    for (name, pc), pt in zip(
        cpp.current.named_parameters(), tch.current.parameters(), strict=True
    ):
        torch.testing.assert_close(pc.grad, pt.grad, rtol=1e-4, atol=1e-6, msg=name)
    # the greedy NumPy path agrees with the kernel
    got = cpp.q_np(x[0].numpy(), 2, states.tolist())
    torch.testing.assert_close(torch.from_numpy(got), qs[0][0], rtol=1e-5, atol=1e-5)


def test_kernel_setting_is_validated():
    with pytest.raises(ConfigError, match="network.lateral_kernel='fast'"):
        kernels.resolve("fast")
    with pytest.raises(ConfigError, match="lateral_kernel='fast' is not one of auto, cpp, torch"):
        from_dict(BiarmConfig, {"network": {"lateral_kernel": "fast"}})
    assert kernels.resolve("torch") == "torch"
    pnn = ProgressiveNet(obs_dim=3, hidden=4, gated=False, adapter_dim=2, seed=0,
                         lateral_kernel="torch")  # fmt: skip
    assert pnn.kernel == "torch"


@pytest.mark.parametrize("gated", [False, True])
def test_cpp_frozen_features_are_bit_for_bit_the_torch_ones(ext, gated):
    """csrc/frozen_features.h runs the same ATen operations as ProgressiveNet.features, for
    every number of frozen columns, PNN and BIARM, after the caches were refreshed."""
    nets = {
        k: ProgressiveNet(
            obs_dim=5, hidden=16, gated=gated, adapter_dim=4, seed=1, lateral_kernel=k
        )  # fmt: skip
        for k in ("cpp", "torch")
    }
    for n in (2, 3, 2, 4):
        for net in nets.values():
            net.add_column(n)
    assert nets["cpp"].kernel == "cpp"
    x = torch.randn(12, 5, generator=torch.Generator().manual_seed(2))
    states = torch.tensor([0.2, 0.7, 0.4, 0.9])
    for upto in (1, 2, 3):
        got = nets["cpp"].features(x, upto, states)
        want = nets["torch"].features(x, upto, states)
        assert len(got) == len(want) == (1 if gated else 2)
        for g, w in zip(got, want, strict=True):
            assert g.shape == w.shape and torch.equal(g, w), (upto, gated)
        # and the Q-values of a column on top of them
        torch.testing.assert_close(
            nets["cpp"].q(x, upto, states), nets["torch"].q(x, upto, states), rtol=1e-5, atol=1e-5
        )


# ------------------------------------------------------------------------- flat parameters
def _params(seed: int) -> list[torch.nn.Parameter]:
    gen = torch.Generator().manual_seed(seed)
    return [torch.nn.Parameter(torch.randn(*s, generator=gen)) for s in ((3, 4), (4,), (2, 1, 3))]


def _loss(ps: list[torch.nn.Parameter], t: int) -> torch.Tensor:
    return sum(((p - 0.1 * t) ** 2 * (i + 1)).sum() for i, p in enumerate(ps))  # type: ignore[return-value]


def test_flat_buffer_keeps_values_and_collects_gradients():
    ps = _params(0)
    before = [p.detach().clone() for p in ps]
    flat = flatten(ps)
    assert flat.param.numel() == sum(p.numel() for p in ps) == sum(flat.sizes)
    for p, b in zip(ps, before, strict=True):
        assert torch.equal(p, b) and p.data_ptr() >= flat.param.data_ptr()
    for _ in range(2):  # zero_grad, then backward accumulates into the flat gradient
        flat.zero_grad()
        _loss(ps, 1).backward()
    want = torch.cat([(2 * (i + 1) * (b - 0.1)).reshape(-1) for i, b in enumerate(before)])
    torch.testing.assert_close(flat.grad, want)
    with torch.no_grad():
        flat.param.add_(1.0)  # what the optimiser does: every parameter sees it
    assert all(torch.equal(p, b + 1.0) for p, b in zip(ps, before, strict=True))


def test_adam_on_the_flat_buffer_equals_adam_per_tensor_and_resumes_old_state():
    ref, new = _params(1), _params(1)
    opt_ref = torch.optim.Adam(ref, lr=0.05)
    flat = flatten(new)
    opt_new = torch.optim.Adam([flat.param], lr=0.05)
    for t in range(3):
        opt_ref.zero_grad()
        _loss(ref, t).backward()
        opt_ref.step()
        flat.zero_grad()
        _loss(new, t).backward()
        opt_new.step()
    for a, b in zip(ref, new, strict=True):
        torch.testing.assert_close(a, b)
    # a per-tensor Adam state (checkpoints written before the flat buffer) continues exactly
    resumed = _params(9)
    with torch.no_grad():
        for a, b in zip(resumed, ref, strict=True):
            a.copy_(b)
    flat_r = flatten(resumed)
    opt_r = torch.optim.Adam([flat_r.param], lr=0.05)
    opt_r.load_state_dict(flatten_adam_state(opt_ref.state_dict(), flat_r.sizes))
    for opt, ps, fl in ((opt_ref, ref, None), (opt_r, resumed, flat_r)):
        opt.zero_grad() if fl is None else fl.zero_grad()
        _loss(ps, 5).backward()
        opt.step()
    for a, b in zip(ref, resumed, strict=True):
        torch.testing.assert_close(a, b)


def test_agent_records_its_kernel_in_the_summary(tmp_path, ext):
    from evodevo.neuromod.trainer import train
    from tests.test_biarm_train import tiny

    cfg = tiny()
    summary = train(cfg, "biarm", seed=0, out=tmp_path / "b")
    assert summary["lateral_kernel"] == "cpp"
    assert train(cfg, "pnn", seed=0, out=tmp_path / "p")["lateral_kernel"] == "cpp"


def test_update_trains_every_parameter_at_the_eq_3_7_rate():
    """Through the flat buffer, one update moves every trainable tensor of the column, at
    the modulated learning rate, and leaves the frozen columns alone."""
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.variants import get_variant

    agent = BiarmAgent(_cfg(), get_variant("biarm"), obs_dim=4, seed=0)
    agent.begin_task(2)
    agent.begin_task(3)
    frozen = [p.detach().clone() for p in agent.net.columns[0].parameters()]
    before = {n: p.detach().clone() for n, p in agent.net.current.named_parameters()}
    gen = torch.Generator().manual_seed(0)
    batch = (
        torch.randn(8, 4, generator=gen),
        torch.randn(8, 4, generator=gen),
        torch.randint(0, 3, (8,), generator=gen),
        torch.randn(8, generator=gen),
        torch.zeros(8),
        torch.ones(8),
    )
    agent.update(batch)
    assert agent.optimizer is not None
    assert agent.optimizer.param_groups[0]["lr"] == pytest.approx(agent.lr())
    assert agent.lr() != pytest.approx(agent.cfg.dqn.lr)
    for n, p in agent.net.current.named_parameters():
        assert not torch.equal(p, before[n]), n
    for p, f in zip(agent.net.columns[0].parameters(), frozen, strict=True):
        assert torch.equal(p, f)


@pytest.mark.parametrize("ablated", [(), ("DA",), ("NE",), ("5HT", "ACh")])
def test_module_step_kernel_equals_the_numpy_step(ext, ablated):
    """csrc/module_step.h against the NumPy path of Neuromodulators.step (Eq. 3.1-3.6), over
    many steps with zero-padded observations, ablations held at 0.5, and a change of the
    weights in place (the version check must rebuild the buffer the C++ step reads)."""
    import numpy as np

    from evodevo.neuromod.config import ModuleConfig
    from evodevo.neuromod.modules import Neuromodulators

    ref = Neuromodulators(ModuleConfig(), obs_dim=8, seed=3, ablated=ablated)
    fast = Neuromodulators(ModuleConfig(), obs_dim=8, seed=3, ablated=ablated)
    fast.use_kernel(ext)
    rng = np.random.default_rng(0)
    for i in range(600):
        if i == 300:
            for m in (ref, fast):
                with torch.no_grad():
                    m.w1.mul_(1.5)
                    m.b2.add_(0.25)
        obs = (3 * rng.standard_normal(8)).astype(np.float32)
        obs[6:] = 0.0
        reward = float(10 * rng.standard_normal())
        ref.step(obs, reward)
        fast.step(obs, reward)
        np.testing.assert_allclose(fast.states, ref.states, rtol=0, atol=1e-6)
        assert fast.n_task == ref.n_task
    assert not np.allclose(ref.states, 0.5)  # the states moved
    for name in ablated:
        assert fast.states[list(("DA", "5HT", "NE", "ACh")).index(name)] == 0.5
    # the state tensor the agent reads is the memory the C++ step writes
    assert torch.equal(fast.state_t, torch.from_numpy(fast.state_array))


def test_module_step_kernel_rejects_a_wrong_buffer(ext):
    with pytest.raises(RuntimeError, match="module_step"):
        ext.module_step(torch.zeros(10), 11, 128, 0.0, 1.0)


def test_agent_runs_the_modules_through_the_kernel_it_resolved(ext):
    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import NetworkConfig
    from evodevo.neuromod.variants import get_variant

    cfg = _cfg()
    fast = BiarmAgent(cfg, get_variant("biarm"), obs_dim=4, seed=0)
    slow_cfg = replace(cfg, network=NetworkConfig(**XAVIER, lateral_kernel="torch"))
    slow = BiarmAgent(slow_cfg, get_variant("biarm"), obs_dim=4, seed=0)
    assert fast.modules is not None and fast.modules.uses_kernel
    assert slow.modules is not None and not slow.modules.uses_kernel


def _td_agents(variant: str, ncol: int, learn_context: bool = True):
    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import ModuleConfig, NetworkConfig
    from evodevo.neuromod.variants import get_variant

    out = {}
    for k in ("cpp", "torch"):
        cfg = replace(
            _cfg(),
            network=NetworkConfig(**XAVIER, lateral_kernel=k),
            modules=ModuleConfig(learn_context_weights=learn_context),
        )
        agent = BiarmAgent(cfg, get_variant(variant), obs_dim=6, seed=0)
        for n in (2, 3, 3, 4)[:ncol]:
            agent.begin_task(n)
        with torch.no_grad():  # a target network that differs from the online column
            for p in agent.target.parameters():
                p.mul_(0.9)
        if agent.modules is not None:  # states away from 0.5, so the gate is not symmetric
            agent.modules.set_states([0.3, 0.8, 0.6, 0.1])
        out[k] = agent
    return out


def _td_batch(n_actions: int, bsz: int = 16, d: int = 6):
    gen = torch.Generator().manual_seed(1)
    rows = torch.randn(bsz, 2 * d + 4, generator=gen)  # strided columns, as the replay gives
    return (
        rows[:, :d],
        rows[:, d : 2 * d],
        torch.randint(0, n_actions, (bsz,), generator=gen),
        3 * rows[:, 2 * d + 1],
        (rows[:, 2 * d + 2] > 0.5).float(),
        torch.rand(bsz, generator=gen),
    )


@pytest.mark.parametrize(
    ("variant", "ncol", "learn_context"),
    [("pnn", 1, True), ("pnn", 2, True), ("pnn", 4, True), ("biarm", 1, True),
     ("biarm", 2, True), ("biarm", 4, True), ("biarm", 3, False), ("no-ach", 3, True)],
)  # fmt: skip
def test_cpp_td_update_equals_autograd(ext, variant, ncol, learn_context):
    """csrc/td_update.h: the TD loss and every gradient of the column (the flat buffer,
    including the context weights when trained) against autograd, then one whole update."""
    agents = _td_agents(variant, ncol, learn_context)
    fast, ref = agents["cpp"], agents["torch"]
    assert fast.fused_update and not ref.fused_update
    batch = _td_batch((2, 3, 3, 4)[ncol - 1])
    loss_fast = fast.td_loss(batch)
    loss_ref = ref.td_loss(batch)
    ref.flat.zero_grad()
    loss_ref.backward()
    torch.testing.assert_close(loss_fast, loss_ref.detach(), rtol=1e-6, atol=1e-7)
    assert ref.flat.grad.abs().max() > 1e-3  # a gradient worth comparing
    torch.testing.assert_close(fast.flat.grad, ref.flat.grad, rtol=1e-5, atol=1e-7)
    if variant != "pnn" and ncol > 1:
        ctx = fast.net.current.ctx_w
        assert ctx.requires_grad is learn_context
        if learn_context:
            assert ctx.grad is not None and ctx.grad.abs().sum() > 0
    for agent in (fast, ref):
        agent.update(batch)
    for p, q in zip(fast.net.current.parameters(), ref.net.current.parameters(), strict=True):
        torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)


def test_td_update_kernel_is_not_used_where_autograd_is_needed(ext):
    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import ModuleConfig
    from evodevo.neuromod.variants import get_variant

    learned = replace(_cfg(), modules=ModuleConfig(learning="learned"))
    for cfg, variant, uses in (
        (_cfg(), "biarm", True),
        (_cfg(), "pnn", True),
        (learned, "biarm", False),  # per-sample gates, gradients into the module networks
        (_cfg(), "ewc", False),
        (_cfg(), "finetune", False),
    ):
        agent = BiarmAgent(cfg, get_variant(variant), obs_dim=4, seed=0)
        agent.begin_task(2)
        agent.begin_task(3)
        assert agent.fused_update is uses, variant


def test_agent_observe_through_the_kernel_equals_the_numpy_step(ext):
    """The trainer's per-step call (agent.observe on the agent's own observation row) takes the
    C++ closure; another array, and a weight changed in place, take Neuromodulators.step."""
    import numpy as np

    from evodevo.config import replace
    from evodevo.neuromod.agent import BiarmAgent
    from evodevo.neuromod.config import NetworkConfig
    from evodevo.neuromod.variants import get_variant

    cfg = _cfg()
    fast = BiarmAgent(cfg, get_variant("biarm"), obs_dim=6, seed=2)
    ref_cfg = replace(cfg, network=NetworkConfig(**XAVIER, lateral_kernel="torch"))
    ref = BiarmAgent(ref_cfg, get_variant("biarm"), obs_dim=6, seed=2)
    assert fast.modules is not None and ref.modules is not None
    rng = np.random.default_rng(0)
    for i in range(400):
        obs = (2 * rng.standard_normal(6)).astype(np.float32)
        r = float(rng.standard_normal())
        if i == 200:
            for a in (fast, ref):
                with torch.no_grad():
                    a.modules.w2.mul_(-1.0)
        for a in (fast, ref):
            a.obs_np[:] = obs
            a.observe(a.obs_np if i % 3 else obs.copy(), r)  # own row, or another array
        np.testing.assert_allclose(fast.modules.states, ref.modules.states, rtol=0, atol=1e-6)
        assert fast.modules.n_task == ref.modules.n_task
