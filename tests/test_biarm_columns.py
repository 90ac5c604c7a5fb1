"""Progressive columns and lateral connections (SPEC §1.2, Eq. 3.8-3.9)."""

from __future__ import annotations

import pytest
import torch

from evodevo.neuromod.columns import ProgressiveNet

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _net(gated: bool, hidden: int = 16, r: int = 4) -> ProgressiveNet:
    net = ProgressiveNet(obs_dim=5, hidden=hidden, gated=gated, adapter_dim=r, seed=0)
    for a in (2, 3, 4):
        net.add_column(a)
    return net


def _manual(net: ProgressiveNet, x: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
    """Loop-per-column reference of Eq. 3.9 with the Rusu l-1 laterals."""
    h1s, h2s = [], []
    q = None
    for i, col in enumerate(net.columns):
        h1 = torch.relu(x @ col.w1 + col.b1)
        pre2 = h1 @ col.w2 + col.b2
        preq_lat = 0.0
        if i:
            r = col.r
            if net.gated:
                ctx = torch.sigmoid(torch.dot(states, col.ctx_w))
            for k in range(i):
                if net.gated:
                    w2, b2 = col.ad_w[k], col.ad_b[k, 0]
                    o = h1s[k] @ w2 + b2
                    z2 = o[:, :r] * torch.sigmoid(o[:, r:]) * ctx  # U (alpha * V h)
                    pre2 = pre2 + z2 @ col.u2[k * r : (k + 1) * r]
                    wq, bq = col.ad_w[i + k], col.ad_b[i + k, 0]
                    oq = h2s[k] @ wq + bq
                    zq = oq[:, :r] * torch.sigmoid(oq[:, r:]) * ctx
                    preq_lat = preq_lat + zq @ col.uq[k * r : (k + 1) * r]
                else:
                    h = col.hidden
                    pre2 = pre2 + h1s[k] @ col.u2[k * h : (k + 1) * h]  # U h_k
                    preq_lat = preq_lat + h2s[k] @ col.uq[k * h : (k + 1) * h]
        h2 = torch.relu(pre2)
        q = h2 @ col.wq + col.bq + preq_lat
        h1s.append(h1)
        h2s.append(h2)
    assert q is not None
    return q


def test_pnn_and_gated_laterals_match_loop_reference():
    x = torch.randn(7, 5)
    states = torch.tensor([0.2, 0.9, 0.4, 0.6])
    for gated in (False, True):
        net = _net(gated)
        with torch.no_grad():
            got = net.q(x, 2, states)
            want = _manual(net, x, states)
        assert got.shape == (7, 4)
        torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5)


def test_gated_shapes_and_gradient_only_into_current_column():
    net = _net(True)
    cur = net.current
    assert cur.ad_w.shape == (4, 16, 8)  # 2k blocks of [V | W_alpha], d -> r each
    assert cur.u2.shape == (2 * 4, 16) and cur.uq.shape == (2 * 4, 4)
    x = torch.randn(6, 5)
    states = torch.full((4,), 0.5)
    prev = net.features(x, 2, states)
    assert prev[0].shape == (4, 6, 16)  # blocks h1_1, h1_2, h2_1, h2_2 of the frozen columns
    q = cur(x, prev, states)
    q.sum().backward()
    for col in list(net.columns)[:-1]:
        for p in col.parameters():
            assert not p.requires_grad and p.grad is None
    for name, p in cur.named_parameters():
        assert p.grad is not None and p.grad.abs().sum() > 0, name


def test_context_gate_scales_laterals():
    net = _net(True)
    x = torch.randn(3, 5)
    s_lo = torch.zeros(4)
    s_hi = torch.ones(4)
    col = net.current
    with torch.no_grad():
        col.ctx_w.copy_(torch.tensor([5.0, 5.0, 5.0, 5.0]))
        # gate ~ sigmoid(0)=0.5 vs sigmoid(20)=1: laterals differ, so Q differs
        assert not torch.allclose(net.q(x, 2, s_lo), net.q(x, 2, s_hi))
        # per-sample states (B, 4) equal to the scalar states give the same Q
        prev = net.features(x, 2, s_hi)
        torch.testing.assert_close(col(x, prev, s_hi), col(x, prev, s_hi.expand(3, 4)))


def test_column_init_xavier_zero_bias_and_seeded():
    a, b = _net(False), _net(False)
    for pa, pb in zip(a.parameters(), b.parameters(), strict=True):
        assert torch.equal(pa, pb)
    col = a.columns[0]
    assert torch.count_nonzero(col.b1) == 0 and torch.count_nonzero(col.bq) == 0
    bound = (6.0 / (5 + 16)) ** 0.5
    assert col.w1.abs().max() <= bound
    c = ProgressiveNet(obs_dim=5, hidden=16, gated=False, adapter_dim=4, seed=1)
    c.add_column(2)
    assert not torch.equal(c.columns[0].w1, col.w1)
