// Fused gated laterals of a BIARM column (SPEC §1.2-1.3, Eq. 3.8-3.9), forward and backward.
//
// One call replaces the ~12 Python-dispatched tensor operations (and their autograd nodes) of
// evodevo.neuromod.columns.gated_laterals plus the context gate. At these layer sizes BIARM's
// FLOPs are within 5 % of PNN's; what made it slower was per-operation dispatch (several
// microseconds each on a 2-core machine). Here the matrix products are ATen calls (MKL) and
// the element-wise steps (glu, gate, and their derivatives) are one loop each over the data.
//
//   g   = sigmoid(states . ctx_w)                   scalar, or one per sample for (B, 4) states
//   o   = b + feats @ w                             (n, B, 2r): [V h_k | W_alpha h_k] per block
//   zc  = g * o[..., :r] * sigmoid(o[..., r:])      (B, n*r), block k in columns k*r..k*r+r-1
//   t2  = b2 + zc[:, :n*r/2] @ u2                   lateral into layer 2 (Eq. 3.9)
//   tq  = bq + zc[:, n*r/2:] @ uq                   lateral into the head
//
// The backward pass computes only the gradients autograd asks for (needs_input_grad).
#pragma once

#include <torch/extension.h>

#include <cmath>
#include <vector>

namespace evodevo {

using torch::Tensor;
using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

namespace detail {

inline float sigm(float x) { return 1.0f / (1.0f + std::exp(-x)); }  // the context gate

// Context gate logit(s): one per sample (B) for (B, 4) states, else one.
inline std::vector<float> gate_values(const Tensor& states, const Tensor& ctx_w, int64_t bsz) {
  const float* w = ctx_w.data_ptr<float>();
  const float* s = states.data_ptr<float>();
  const int64_t rows = states.dim() == 1 ? 1 : bsz;
  std::vector<float> g(rows);
  for (int64_t i = 0; i < rows; ++i) {
    float acc = 0.0f;
    for (int64_t m = 0; m < 4; ++m) acc += s[i * 4 + m] * w[m];
    g[i] = sigm(acc);
  }
  return g;
}

// zc (B, n*r) = o[k, i, :r] * sg[k, i] * g_i, block k in columns k*r .. k*r+r-1 (Eq. 3.8:
// alpha * V h with the glu's sigmoid half `sg`); g holds one gate per sample, or one for all.
inline void gated_glu_forward(const Tensor& o, const Tensor& sg, const std::vector<float>& g,
                              Tensor& zc) {
  const int64_t n = o.size(0), bsz = o.size(1), r = o.size(2) / 2, width = n * r;
  const bool per_sample = g.size() > 1;
  const float* po = o.data_ptr<float>();
  const float* ps = sg.data_ptr<float>();
  float* pz = zc.data_ptr<float>();
  for (int64_t k = 0; k < n; ++k) {
    for (int64_t i = 0; i < bsz; ++i) {
      const float* a = po + (k * bsz + i) * 2 * r;
      const float* sgi = ps + (k * bsz + i) * r;
      float* out = pz + i * width + k * r;
      const float gi = g[per_sample ? i : 0];
      for (int64_t j = 0; j < r; ++j) out[j] = (a[j] * sgi[j]) * gi;
    }
  }
}

// The backward of gated_glu_forward: dout (n, B, 2r) = d loss / d o from d loss / d zc, given
// as the two heads' (B, n*r/2) blocks dm2 (into layer 2) and dmq (into the head); adds
// d loss / d g_i into dg (one entry per gate).
inline void gated_glu_backward(const Tensor& o, const Tensor& sg, const std::vector<float>& g,
                               const Tensor& dm2, const Tensor& dmq, Tensor& dout,
                               std::vector<double>& dg) {
  const int64_t n = o.size(0), bsz = o.size(1), r = o.size(2) / 2;
  const int64_t half = (n / 2) * r, per = n / 2;
  const bool per_sample = g.size() > 1;
  const float* pdm[2] = {dm2.data_ptr<float>(), dmq.data_ptr<float>()};
  const float* po = o.data_ptr<float>();
  const float* ps = sg.data_ptr<float>();
  float* pd = dout.data_ptr<float>();
  for (int64_t k = 0; k < n; ++k) {
    const float* src = pdm[k / per];
    const int64_t col0 = (k % per) * r;
    for (int64_t i = 0; i < bsz; ++i) {
      const float* a = po + (k * bsz + i) * 2 * r;
      const float* sgi = ps + (k * bsz + i) * r;
      float* da = pd + (k * bsz + i) * 2 * r;
      float* dq = da + r;
      const float* d = src + i * half + col0;
      const int64_t gi = per_sample ? i : 0;
      const float gv = g[gi];
      float acc = 0.0f;
      for (int64_t j = 0; j < r; ++j) acc += d[j] * (a[j] * sgi[j]);
      for (int64_t j = 0; j < r; ++j) {
        const float dz = d[j] * gv;
        da[j] = dz * sgi[j];
        dq[j] = da[j] * a[j] * (1.0f - sgi[j]);
      }
      dg[gi] += acc;
    }
  }
}

class GatedLateral : public torch::autograd::Function<GatedLateral> {
 public:
  static variable_list forward(AutogradContext* ctx, Tensor feats, Tensor w, Tensor b,
                               Tensor states, Tensor ctx_w, Tensor u2, Tensor b2, Tensor uq,
                               Tensor bq) {
    const int64_t n = feats.size(0), bsz = feats.size(1), r = w.size(2) / 2;
    const int64_t half = (n / 2) * r, width = n * r;
    Tensor o;
    {
      at::NoGradGuard no_grad;
      o = at::baddbmm(b, feats, w);  // (n, B, 2r), contiguous
    }
    const std::vector<float> g = gate_values(states, ctx_w, bsz);
    Tensor sg = at::sigmoid(o.narrow(2, r, r));  // (n, B, r), vectorised
    Tensor zc = at::empty({bsz, width}, o.options());
    gated_glu_forward(o, sg, g, zc);
    Tensor t2, tq;
    {
      at::NoGradGuard no_grad;
      t2 = at::addmm(b2, zc.narrow(1, 0, half), u2);
      tq = at::addmm(bq, zc.narrow(1, half, half), uq);
    }
    ctx->save_for_backward({feats, o, sg, zc, states, ctx_w, u2, uq});
    ctx->saved_data["g"] = c10::List<double>(std::vector<double>(g.begin(), g.end()));
    return {t2, tq};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    auto s = ctx->get_saved_variables();
    const Tensor &feats = s[0], &o = s[1], &sg = s[2], &zc = s[3], &states = s[4];
    const Tensor &ctx_w = s[5], &u2 = s[6], &uq = s[7];
    const auto gl = ctx->saved_data["g"].toDoubleList();
    const int64_t n = feats.size(0), bsz = feats.size(1), r = o.size(2) / 2;
    const int64_t half = (n / 2) * r;
    Tensor dt2 = grads[0].defined() ? grads[0].contiguous() : at::zeros({bsz, u2.size(1)}, u2.options());
    Tensor dtq = grads[1].defined() ? grads[1].contiguous() : at::zeros({bsz, uq.size(1)}, uq.options());
    Tensor dw, db, dstates, dctx, du2, db2, duq, dbq;
    if (ctx->needs_input_grad(5)) du2 = at::mm(zc.narrow(1, 0, half).t(), dt2);
    if (ctx->needs_input_grad(6)) db2 = dt2.sum(0);
    if (ctx->needs_input_grad(7)) duq = at::mm(zc.narrow(1, half, half).t(), dtq);
    if (ctx->needs_input_grad(8)) dbq = dtq.sum(0);
    const bool need_adapters = ctx->needs_input_grad(1) || ctx->needs_input_grad(2);
    const bool need_gate = ctx->needs_input_grad(3) || ctx->needs_input_grad(4);
    if (!(need_adapters || need_gate)) return {Tensor(), dw, db, dstates, dctx, du2, db2, duq, dbq};
    // d loss / d zc, one (B, half) block per head
    const Tensor dm[2] = {at::mm(dt2, u2.t()), at::mm(dtq, uq.t())};
    Tensor dout = at::empty_like(o);  // d loss / d o, (n, B, 2r)
    std::vector<double> dg(gl.size(), 0.0);  // d loss / d g
    gated_glu_backward(o, sg, std::vector<float>(gl.begin(), gl.end()), dm[0], dm[1], dout, dg);
    if (need_adapters) {
      at::NoGradGuard no_grad;
      if (ctx->needs_input_grad(1)) dw = at::bmm(feats.transpose(1, 2), dout);
      if (ctx->needs_input_grad(2)) db = dout.sum(1, true);
    }
    if (need_gate) {
      // d loss / d logit = dg * g * (1 - g); the logit is states . ctx_w
      const int64_t rows = static_cast<int64_t>(gl.size());
      Tensor dlogit = at::empty({rows}, o.options());
      float* pl = dlogit.data_ptr<float>();
      for (int64_t i = 0; i < rows; ++i) pl[i] = static_cast<float>(dg[i] * gl[i] * (1.0 - gl[i]));
      at::NoGradGuard no_grad;
      if (states.dim() == 1) {
        if (ctx->needs_input_grad(4)) dctx = states * dlogit;
        if (ctx->needs_input_grad(3)) dstates = ctx_w * dlogit;
      } else {
        if (ctx->needs_input_grad(4)) dctx = at::mv(states.t(), dlogit);
        if (ctx->needs_input_grad(3)) dstates = at::outer(dlogit, ctx_w);
      }
    }
    return {Tensor(), dw, db, dstates, dctx, du2, db2, duq, dbq};
  }
};

}  // namespace detail

inline std::vector<Tensor> gated_lateral(Tensor feats, Tensor w, Tensor b, Tensor states,
                                         Tensor ctx_w, Tensor u2, Tensor b2, Tensor uq,
                                         Tensor bq) {
  TORCH_CHECK(feats.dim() == 3 && w.dim() == 3 && feats.size(0) == w.size(0) &&
                  feats.size(0) % 2 == 0 && w.size(2) % 2 == 0,
              "gated_lateral: feats (n, B, hidden) and w (n, hidden, 2r) with even n");
  TORCH_CHECK(feats.scalar_type() == at::kFloat && w.scalar_type() == at::kFloat,
              "gated_lateral: float32 tensors only");
  TORCH_CHECK(ctx_w.numel() == 4 && (states.dim() == 1 ? states.numel() == 4
                                     : states.dim() == 2 && states.size(0) == feats.size(1) &&
                                           states.size(1) == 4),
              "gated_lateral: states (4,) or (B, 4) and ctx_w (4,)");
  auto out = detail::GatedLateral::apply(feats, w.contiguous(), b.contiguous(),
                                 states.contiguous(), ctx_w.contiguous(), u2, b2, uq, bq);
  return {out[0], out[1]};
}

}  // namespace evodevo
