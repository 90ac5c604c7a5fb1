"""``network.lateral_scale`` (SPEC §1.2): a column's laterals read ``s h_k``.

A column built with scale ``s`` computes what a scale-1 column computes with its lateral
weights (PNN: ``U``; BIARM: the adapters' ``[V | W_alpha]``) multiplied by ``s``, in every path
(PyTorch, NumPy acting, C++ kernels, frozen columns), and a checkpoint restores each column's
own scale."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.neuromod import kernels
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.columns import Column, ProgressiveNet
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.protocols import protocol_config
from evodevo.neuromod.variants import get_variant

pytestmark = pytest.mark.usefixtures("one_torch_thread")

SCALES = (1.0, 0.1, 0.5, 0.02)  # one per column


def _pair(gated: bool, kernel: str) -> tuple[ProgressiveNet, ProgressiveNet]:
    """Four columns with per-column scales, and the same stack at scale 1 with the scales
    folded into the lateral weights."""
    scaled = ProgressiveNet(obs_dim=5, hidden=16, gated=gated, adapter_dim=4, seed=0,
                            lateral_kernel=kernel)  # fmt: skip
    plain = ProgressiveNet(obs_dim=5, hidden=16, gated=gated, adapter_dim=4, seed=0,
                           lateral_kernel=kernel)  # fmt: skip
    for a, s in zip((2, 3, 4, 3), SCALES, strict=True):
        scaled.add_column(a, s)
        plain.add_column(a)
    gen = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for p in scaled.parameters():
            p.add_(0.2 * torch.randn(p.shape, generator=gen))
        plain.load_state_dict(scaled.state_dict())
        for c, s in zip(plain.columns, SCALES, strict=True):
            assert isinstance(c, Column)
            if not c.n_prev:
                continue
            if gated:
                c.ad_w.mul_(s)
            else:
                c.u2.mul_(s)
                c.uq.mul_(s)
    scaled.refresh_frozen()
    plain.refresh_frozen()
    return scaled, plain


@pytest.mark.parametrize("gated", [False, True])
@pytest.mark.parametrize("kernel", ["torch", "cpp"])
def test_scale_equals_scaled_lateral_weights_in_every_path(gated, kernel):
    if kernel == "cpp" and kernels.resolve("auto") != "cpp":
        pytest.skip("C++ kernels unavailable")
    scaled, plain = _pair(gated, kernel)
    assert scaled.lateral_scales() == list(SCALES)
    states = torch.tensor([0.2, 0.9, 0.4, 0.6])
    x = torch.randn(30, 5, generator=torch.Generator().manual_seed(2))
    for col in range(4):
        with torch.no_grad():
            got, want = scaled.q(x, col, states), plain.q(x, col, states)
        torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5)
        acted = np.stack([scaled.q_np(x[i].numpy(), col, states.tolist()) for i in range(5)])
        torch.testing.assert_close(torch.from_numpy(acted), want[:5], rtol=1e-5, atol=1e-5)


def test_scale_changes_the_q_values_and_scale_one_is_the_old_net():
    base = ProgressiveNet(obs_dim=5, hidden=16, gated=False, adapter_dim=4, seed=0)
    small = ProgressiveNet(obs_dim=5, hidden=16, gated=False, adapter_dim=4, seed=0,
                           lateral_scale=0.1)  # fmt: skip
    for net in (base, small):
        net.add_column(2)
        net.add_column(3)
    x = torch.randn(8, 5, generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        assert torch.equal(base.q(x, 0, None), small.q(x, 0, None))  # no laterals
        assert not torch.allclose(base.q(x, 1, None), small.q(x, 1, None))
        # the earlier activations themselves are unchanged; only what column 1 reads is scaled
        for f, g in zip(base.features(x, 1, None), small.features(x, 1, None), strict=True):
            assert torch.equal(f, g)
        for f, g in zip(base.features(x, 1, None), small.lateral_inputs(x, 1, None), strict=True):
            torch.testing.assert_close(f * 0.1, g)


@pytest.mark.parametrize("variant", ["pnn", "biarm"])
def test_checkpoint_restores_each_columns_scale(variant):
    def cfg(scale: float) -> BiarmConfig:
        net = {"hidden": 8, "adapter_dim": 2, "lateral_scale": scale}
        return from_dict(BiarmConfig, {"network": net})

    a = BiarmAgent(cfg(1.0), get_variant(variant), 6, 0)
    a.begin_task(2)
    b_cfg = cfg(0.05)
    a.begin_task(3, 0.05)
    a.begin_task(2, 0.05)
    state = a.state()
    assert state["net_config"]["lateral_scales"] == [1.0, 0.05, 0.05]
    b = BiarmAgent(b_cfg, get_variant(variant), 6, 0)
    b.load_state(state)
    assert b.net.lateral_scales() == [1.0, 0.05, 0.05]  # type: ignore[union-attr]
    x = torch.randn(4, 6, generator=torch.Generator().manual_seed(0))
    for col in range(3):
        torch.testing.assert_close(b.greedy_q(x, col), a.greedy_q(x, col))
    # a checkpoint written before the key existed restores scale 1 everywhere
    del state["net_config"]["lateral_scales"]
    c = BiarmAgent(b_cfg, get_variant(variant), 6, 0)
    c.load_state(state)
    assert c.net.lateral_scales() == [1.0, 1.0, 1.0]  # type: ignore[union-attr]


@pytest.mark.parametrize("bad", [0.0, -0.5, float("nan"), float("inf")])
def test_bad_scale_is_one_clear_error(bad):
    with pytest.raises(ConfigError, match="network.lateral_scale="):
        from_dict(BiarmConfig, {"network": {"lateral_scale": bad}})


def test_v1_protocol_keeps_scale_one():
    assert protocol_config("v1").network.lateral_scale == 1.0
