// Hidden activations of the frozen columns of a progressive stack (SPEC §1.2), PNN and BIARM.
//
// The same ATen operations, in the same order and on the same cached tensors, as
// evodevo.neuromod.columns.ProgressiveNet.features (so the results are bit for bit the same),
// called from C++: one Python call instead of 10-20 Python-dispatched operations per update.
// No autograd: frozen columns are never trained.
//
// PNN:   h1 = relu(x W1f + b1f) (B, upto*h), column j: h2_j = relu(h1_j W2_j + b2_j
//        + [h1_0 .. h1_{j-1}] U2_j); returns (h1, [h2_0 .. h2_{upto-1}]).
// BIARM: out (2*upto, B, h) = blocks h1_0 .. h1_{upto-1}, h2_0 .. h2_{upto-1}, where column j's
//        lateral is g_j [glu(h1_k [V|W_alpha]_(j,k) + b_(j,k))]_{k<j} U2_j (Eq. 3.8-3.9), with
//        the context gates g_j computed here from the states.
#pragma once

#include <torch/extension.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace evodevo {

inline std::vector<torch::Tensor> frozen_features_pnn(torch::Tensor x, torch::Tensor w1f,
                                                      torch::Tensor b1f,
                                                      std::vector<torch::Tensor> w2,
                                                      std::vector<torch::Tensor> b2,
                                                      std::vector<torch::Tensor> u2,
                                                      int64_t upto) {
  TORCH_CHECK(upto >= 1 && static_cast<int64_t>(w2.size()) >= upto &&
                  static_cast<int64_t>(b2.size()) >= upto &&
                  static_cast<int64_t>(u2.size()) >= upto,
              "frozen_features_pnn: one (W2, b2, U2) per frozen column");
  at::NoGradGuard no_grad;
  const int64_t h = w2[0].size(0);
  torch::Tensor h1 =
      at::relu(at::addmm(b1f.narrow(0, 0, upto * h), x, w1f.narrow(1, 0, upto * h)));
  std::vector<torch::Tensor> parts;
  parts.reserve(upto);
  for (int64_t j = 0; j < upto; ++j) {
    torch::Tensor t2 = j ? at::addmm(b2[j], h1.narrow(1, 0, j * h), u2[j]) : b2[j];
    parts.push_back(at::relu(at::addmm(t2, h1.narrow(1, j * h, h), w2[j])));
  }
  return {h1, upto == 1 ? parts[0] : at::cat(parts, 1)};
}

inline torch::Tensor frozen_features_gated(torch::Tensor x, torch::Tensor w1f, torch::Tensor b1f,
                                           torch::Tensor adwf, torch::Tensor adbf,
                                           torch::Tensor src, std::vector<torch::Tensor> w2,
                                           std::vector<torch::Tensor> b2,
                                           std::vector<torch::Tensor> u2, torch::Tensor ctx_w,
                                           torch::Tensor states, int64_t upto) {
  TORCH_CHECK(upto >= 1 && static_cast<int64_t>(w2.size()) >= upto &&
                  static_cast<int64_t>(b2.size()) >= upto &&
                  static_cast<int64_t>(u2.size()) >= upto,
              "frozen_features_gated: one (W2, b2, U2) per frozen column");
  TORCH_CHECK(upto == 1 || (ctx_w.dim() == 2 && ctx_w.size(0) >= upto && ctx_w.size(1) == 4 &&
                            ctx_w.is_contiguous() && states.numel() == 4 &&
                            src.scalar_type() == at::kLong),
              "frozen_features_gated: context weights (columns, 4), states (4,), block sources");
  at::NoGradGuard no_grad;
  const int64_t h = w2[0].size(0), bsz = x.size(0);
  torch::Tensor pre = at::addmm(b1f.narrow(0, 0, upto * h), x, w1f.narrow(1, 0, upto * h));
  torch::Tensor out = at::empty({2 * upto, bsz, h}, x.options());
  torch::Tensor h1 = out.narrow(0, 0, upto);
  at::clamp_min_out(h1, pre.view({bsz, upto, h}).transpose(0, 1), 0.0);
  torch::Tensor zc;
  std::vector<double> gates(upto, 0.0);
  if (upto > 1) {
    // every frozen adapter block (j, k) reads h1_k: one product per block straight from `out`
    // (the same numbers as one batched product of the gathered blocks, without the gather)
    const int64_t nb = upto * (upto - 1) / 2;
    const int64_t* ps = src.data_ptr<int64_t>();
    torch::Tensor o = at::empty({nb, bsz, adwf.size(2)}, x.options());
    for (int64_t blk = 0; blk < nb; ++blk) {
      torch::Tensor ob = o[blk];
      at::addmm_out(ob, adbf[blk], out[ps[blk]], adwf[blk]);
    }
    zc = at::glu(o, 2);
    // context gates sigmoid(w_j . s) of the frozen columns (Eq. 3.8), as the Python floats
    // of ProgressiveNet.frozen_context
    const float* w = ctx_w.data_ptr<float>();
    const float* s = states.data_ptr<float>();
    for (int64_t j = 1; j < upto; ++j) {
      double acc = 0.0;
      for (int m = 0; m < 4; ++m) acc += static_cast<double>(w[j * 4 + m]) * s[m];
      gates[j] = 1.0 / (1.0 + std::exp(-std::max(-60.0, std::min(60.0, acc))));
    }
  }
  for (int64_t j = 0; j < upto; ++j) {
    torch::Tensor t2;
    if (j == 0) {  // column 0 has no laterals, hence no gate
      t2 = b2[0];
    } else {
      const int64_t s0 = j * (j - 1) / 2;
      torch::Tensor m =
          j == 1 ? zc[s0] : zc.narrow(0, s0, j).transpose(0, 1).reshape({bsz, -1});
      t2 = at::addmm(b2[j], m, u2[j], 1.0, gates[j]);
    }
    torch::Tensor h2 = out[upto + j];
    at::clamp_min_out(h2, at::addmm(t2, out[j], w2[j]), 0.0);
  }
  return out;
}

}  // namespace evodevo
