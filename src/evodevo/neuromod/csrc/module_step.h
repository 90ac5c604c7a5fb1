// The per-step update of the four neuromodulator states (SPEC §1.3, Eq. 3.1-3.6) in one call.
//
// The same computation as the NumPy path of evodevo.neuromod.modules.Neuromodulators.step, on
// the same numbers, all in one float32 buffer shared with NumPy (one argument to convert):
//
//   pack = [x (n_in) | s (4) | tau (4) | b2 (4) | A_0, A_1 (n_in, width) | B_0, B_1 (width, 2)]
//
//   stage g in {0: (DA, NE), 1: (5HT, ACh)}:  z = relu(x A_g),  l = z B_g + b2_g
//   x = [phi(s), 1, e_first, e_second]; stage 0 reads (reward, n_task), stage 1 the DA and NE
//   states just updated by stage 0 (the dependency order of SPEC §1.3);
//   s_m <- s_m + tau_m (logistic(l_m) - s_m)   (Eq. 3.1; tau_m = 0 holds an ablated module)
//
// The products accumulate in float32 like NumPy's, the state update is in double like the
// Python floats of the NumPy path; only the summation order differs (last-bit rounding).
#pragma once

#include <torch/extension.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace evodevo {

namespace detail {

inline double logistic(double x) {
  return 1.0 / (1.0 + std::exp(-std::max(-60.0, std::min(60.0, x))));
}

// z = relu(x A) for A (n_in, width), then the two logits z B for B (width, 2).
inline void module_stage(const float* x, const float* a, const float* bo, int64_t n_in,
                         int64_t width, float* z, double* logits) {
  std::fill(z, z + width, 0.0f);
  for (int64_t i = 0; i < n_in; ++i) {
    const float xi = x[i];
    if (xi == 0.0f) continue;  // padded inputs
    const float* row = a + i * width;
    for (int64_t j = 0; j < width; ++j) z[j] += xi * row[j];
  }
  float l0 = 0.0f, l1 = 0.0f;
  for (int64_t j = 0; j < width; ++j) {
    const float zj = z[j] > 0.0f ? z[j] : 0.0f;
    l0 += zj * bo[2 * j];
    l1 += zj * bo[2 * j + 1];
  }
  logits[0] = l0;
  logits[1] = l1;
}

}  // namespace detail

inline void module_step(torch::Tensor pack, int64_t n_in, int64_t width, double reward,
                        double n_task) {
  TORCH_CHECK(pack.dim() == 1 && pack.is_contiguous() && pack.scalar_type() == at::kFloat &&
                  pack.numel() == n_in + 12 + 2 * n_in * width + 4 * width && n_in > 3,
              "module_step: one contiguous float32 buffer [x | s | tau | b2 | A | B]");
  float* x = pack.data_ptr<float>();
  float* s = x + n_in;  // internal layout (DA, NE, 5HT, ACh)
  const float* tau = s + 4;
  const float* b2 = tau + 4;
  const float* a = b2 + 4;
  const float* bo = a + 2 * n_in * width;
  const int64_t d = n_in - 3;
  std::vector<float> z(width);
  double l[2];
  x[d + 1] = static_cast<float>(reward);
  x[d + 2] = static_cast<float>(n_task);
  detail::module_stage(x, a, bo, n_in, width, z.data(), l);
  for (int m = 0; m < 2; ++m) {
    const double sm = s[m];
    s[m] = static_cast<float>(sm + tau[m] * (detail::logistic(l[m] + b2[m]) - sm));
  }
  x[d + 1] = s[0];
  x[d + 2] = s[1];
  detail::module_stage(x, a + n_in * width, bo + 2 * width, n_in, width, z.data(), l);
  for (int m = 2; m < 4; ++m) {
    const double sm = s[m];
    s[m] = static_cast<float>(sm + tau[m] * (detail::logistic(l[m - 2] + b2[m]) - sm));
  }
}

// The same, with phi(s) copied into the buffer from `obs` (a float32 tensor of >= n_in - 3
// entries, e.g. the agent's observation row) instead of being written by the caller.
inline void module_step_obs(torch::Tensor pack, torch::Tensor obs, int64_t n_in, int64_t width,
                            double reward, double n_task) {
  TORCH_CHECK(obs.scalar_type() == at::kFloat && obs.is_contiguous() && obs.numel() >= n_in - 3,
              "module_step_obs: a contiguous float32 observation of at least d_max entries");
  TORCH_CHECK(pack.dim() == 1 && pack.scalar_type() == at::kFloat && pack.numel() > n_in,
              "module_step_obs: the module buffer");
  std::copy_n(obs.data_ptr<float>(), n_in - 3, pack.data_ptr<float>());
  module_step(pack, n_in, width, reward, n_task);
}

}  // namespace evodevo
