// One DQN loss and its gradient for the trainable column of a progressive stack (SPEC §1.2,
// §1.6, Eq. 3.8-3.9), PNN and BIARM alike, with the backward pass written out.
//
// Column i (online weights theta, target weights theta'), frozen activations P of the earlier
// columns k < i for the mini-batch states (rows 0..B-1) and next states (rows B..2B-1):
//
//   h1 = relu(x W1 + b1)
//   h2 = relu(h1 W2 + b2 + L2)          L2, Lq: the laterals into layer 2 and the head
//   q  = h2 Wq + bq + Lq
//   PNN:   L2 = P1 U2, Lq = P2 Uq        (P1, P2: the earlier h1, h2 side by side)
//   BIARM: L2 = Z1 U2, Lq = Z2 Uq,  Z = g * [glu(h_k [V|W_alpha]_k + b_k)]_k,
//          g = sigmoid(states . ctx_w)  (scalar context gate, Eq. 3.8)
//
//   y = r + gamma (1 - terminated) max_a q'(x_next)     (target column, no gradient)
//   double Q (van Hasselt et al. 2016): y = r + gamma (1 - terminated) q'(x_next)[argmax_a q(x_next)]
//   loss = mean_i huber(q(x_i)[a_i] - y_i; delta)
//
// The gradients of every trainable tensor of the column are written into `grads` (the views of
// the agent's flat gradient buffer), in the parameter order of evodevo.neuromod.columns.Column:
// w1, b1, w2, b2, wq, bq, then PNN: u2, uq; BIARM: ad_w, ad_b, u2, uq, ctx_w (ctx_w's entry is
// an empty tensor when the context weights are not trained). The same equations as the
// autograd path (Column.forward, huber, loss.backward()); the gradients agree with it to float
// rounding (tests/test_biarm_kernel.py). One call replaces about 40 Python-level operations
// and the autograd graph, for both variants.
#pragma once

#include <torch/extension.h>

#include "gated_lateral.h"

#include <cmath>
#include <vector>

namespace evodevo {

namespace detail {

struct ColumnOut {
  torch::Tensor h1, h2, q;
  torch::Tensor o, sg, zc;  // BIARM: adapter pre-activations, their sigmoid half, gated glu
  double g = 0.0;           // BIARM: context gate
};

// Forward of one column on `rows` of the frozen activations (no autograd anywhere).
inline ColumnOut column_forward(const torch::Tensor& x, const std::vector<torch::Tensor>& p,
                                const std::vector<torch::Tensor>& prev, int64_t row0,
                                int64_t bsz, const torch::Tensor& states, bool gated,
                                bool keep) {
  ColumnOut c;
  c.h1 = at::relu(at::addmm(p[1], x, p[0]));
  torch::Tensor t2 = p[3], tq = p[5];
  if (!prev.empty()) {
    if (!gated) {
      t2 = at::addmm(p[3], prev[0].narrow(0, row0, bsz), p[6]);
      tq = at::addmm(p[5], prev[1].narrow(0, row0, bsz), p[7]);
    } else {
      const torch::Tensor& adw = p[6];
      const int64_t n = adw.size(0), r = adw.size(2) / 2, half = (n / 2) * r;
      const float* w = p[10].data_ptr<float>();
      const float* s = states.data_ptr<float>();
      double logit = 0.0;
      for (int m = 0; m < 4; ++m) logit += static_cast<double>(s[m]) * w[m];
      c.g = 1.0 / (1.0 + std::exp(-logit));
      const float g = static_cast<float>(c.g);
      torch::Tensor feats = prev[0].narrow(1, row0, bsz);
      torch::Tensor o = at::baddbmm(p[7], feats, adw);  // (n, B, 2r)
      torch::Tensor sg = at::sigmoid(o.narrow(2, r, r));
      torch::Tensor zc = at::empty({bsz, n * r}, o.options());
      gated_glu_forward(o, sg, {g}, zc);
      t2 = at::addmm(p[3], zc.narrow(1, 0, half), p[8]);
      tq = at::addmm(p[5], zc.narrow(1, half, half), p[9]);
      if (keep) {
        c.o = o;
        c.sg = sg;
        c.zc = zc;
      }
    }
  }
  c.h2 = at::relu(at::addmm(t2, c.h1, p[2]));
  c.q = at::addmm(tq, c.h2, p[4]);
  return c;
}

}  // namespace detail

inline torch::Tensor td_update(torch::Tensor x, torch::Tensor nx, torch::Tensor act,
                               torch::Tensor rew, torch::Tensor term,
                               std::vector<torch::Tensor> prev, torch::Tensor states,
                               std::vector<torch::Tensor> online,
                               std::vector<torch::Tensor> target,
                               std::vector<torch::Tensor> grads, bool gated, double gamma,
                               double delta, bool double_q) {
  const size_t n_par = prev.empty() ? 6 : (gated ? 11 : 8);
  TORCH_CHECK(online.size() == n_par && target.size() == n_par && grads.size() == n_par,
              "td_update: ", n_par, " parameter, target and gradient tensors expected");
  TORCH_CHECK(prev.empty() || (gated ? prev.size() == 1 : prev.size() == 2),
              "td_update: frozen activations as ProgressiveNet.features returns them");
  TORCH_CHECK(!gated || prev.empty() || (states.numel() == 4 && states.dim() == 1),
              "td_update: the four scalar module states (4,) for the context gate");
  at::NoGradGuard no_grad;
  const int64_t bsz = x.size(0);
  const detail::ColumnOut on = detail::column_forward(x, online, prev, 0, bsz, states, gated, true);
  const detail::ColumnOut tg =
      detail::column_forward(nx, target, prev, bsz, bsz, states, gated, false);
  // TD target and the Huber loss on the taken actions; dq is its gradient w.r.t. q
  torch::Tensor q_next;
  if (double_q) {  // the online column picks the next action, the target column values it
    const detail::ColumnOut sel =
        detail::column_forward(nx, online, prev, bsz, bsz, states, gated, false);
    q_next = tg.q.gather(1, std::get<1>(sel.q.max(1)).unsqueeze(1)).squeeze(1);
  } else {
    q_next = std::get<0>(tg.q.max(1));
  }
  torch::Tensor y = rew + gamma * (1.0 - term) * q_next;
  torch::Tensor a = act.to(at::kLong).unsqueeze(1);
  torch::Tensor diff = on.q.gather(1, a).squeeze(1) - y;
  torch::Tensor loss = at::huber_loss(diff, at::zeros_like(diff), at::Reduction::Mean, delta);
  torch::Tensor dq = at::zeros_like(on.q);
  dq.scatter_(1, a, (at::clamp(diff, -delta, delta) / static_cast<double>(bsz)).unsqueeze(1));
  // backward through the head, layer 2 and layer 1
  at::mm_out(grads[4], on.h2.t(), dq);
  at::sum_out(grads[5], dq, {0});
  torch::Tensor da2 = at::mm(dq, online[4].t()) * (on.h2 > 0);
  at::mm_out(grads[2], on.h1.t(), da2);
  at::sum_out(grads[3], da2, {0});
  torch::Tensor da1 = at::mm(da2, online[2].t()) * (on.h1 > 0);
  at::mm_out(grads[0], x.t(), da1);
  at::sum_out(grads[1], da1, {0});
  if (prev.empty()) return loss;
  if (!gated) {
    at::mm_out(grads[6], prev[0].narrow(0, 0, bsz).t(), da2);
    at::mm_out(grads[7], prev[1].narrow(0, 0, bsz).t(), dq);
    return loss;
  }
  // BIARM laterals: U2, Uq, then through the gated glu into [V|W_alpha], its bias and the gate
  const torch::Tensor &o = on.o, &sg = on.sg, &zc = on.zc;
  const int64_t n = o.size(0), r = o.size(2) / 2, half = (n / 2) * r;
  at::mm_out(grads[8], zc.narrow(1, 0, half).t(), da2);
  at::mm_out(grads[9], zc.narrow(1, half, half).t(), dq);
  const torch::Tensor dm[2] = {at::mm(da2, online[8].t()), at::mm(dq, online[9].t())};
  torch::Tensor dout = at::empty_like(o);
  std::vector<double> dgv(1, 0.0);
  detail::gated_glu_backward(o, sg, {static_cast<float>(on.g)}, dm[0], dm[1], dout, dgv);
  const double dg = dgv[0];
  at::bmm_out(grads[6], prev[0].narrow(1, 0, bsz).transpose(1, 2), dout);
  at::sum_out(grads[7], dout, {1}, true);
  if (grads[10].numel() == 4) {  // d loss / d ctx_w = dg g (1 - g) states
    const double dlogit = dg * on.g * (1.0 - on.g);
    grads[10].copy_(states * dlogit);
  }
  return loss;
}

}  // namespace evodevo
