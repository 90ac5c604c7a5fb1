// Python module of evodevo's C++ kernels: the one translation unit that
// evodevo.neuromod.kernels builds (the kernels are header-only, so they compile once).
#include <torch/extension.h>

#include "frozen_features.h"
#include "gated_lateral.h"
#include "module_step.h"
#include "td_update.h"

PYBIND11_MODULE(TORCH_EXTENSION_NAME, m) {
  m.def("gated_lateral", &evodevo::gated_lateral, "BIARM gated laterals, Eq. 3.8-3.9 (fused)");
  m.def("frozen_features_pnn", &evodevo::frozen_features_pnn,
        "frozen columns' activations of a PNN stack (SPEC 1.2)");
  m.def("frozen_features_gated", &evodevo::frozen_features_gated,
        "frozen columns' activations of a BIARM stack (Eq. 3.8-3.9)");
  m.def("td_update", &evodevo::td_update,
        "DQN loss and gradients of a progressive column, PNN and BIARM (SPEC 1.6)");
  m.def("module_step", &evodevo::module_step,
        "one update of the four neuromodulator states, Eq. 3.1-3.6 (fused)");
  m.def("module_step_obs", &evodevo::module_step_obs,
        "module_step reading the observation from a tensor");
}
