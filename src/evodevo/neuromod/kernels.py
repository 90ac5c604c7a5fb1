"""BIARM's fused C++ kernels (SPEC §1.2-1.3), built on first use.

* ``csrc/gated_lateral.h`` computes Eq. 3.8-3.9 for a column's laterals *and* the context
  gate in one call, forward and backward (a C++ ``torch.autograd.Function``): the matrix
  products are ATen calls, the element-wise steps one loop each. At the default sizes BIARM's
  FLOPs are within 5 % of PNN's, so what made it slower than PNN was the dispatch cost of the
  ~12 small Python-level operations (and autograd nodes) this one call replaces.
* ``csrc/frozen_features.h`` computes the frozen columns' activations of a stack (PNN and
  BIARM alike) with the same ATen operations as
  :meth:`evodevo.neuromod.columns.ProgressiveNet.features` (bit for bit the same numbers),
  one Python call instead of 10-20.
* ``csrc/td_update.h`` is the whole DQN loss and its backward pass for the trainable column
  (PNN and BIARM alike, scalar context gate), written out, with the gradients written into
  the flat gradient buffer: one call instead of about 40 Python-level operations and an
  autograd graph. ``learned`` module mode (per-sample gates with gradients into the module
  networks) and the shared-body baselines keep the autograd path.
* ``csrc/module_step.h`` is the per-step update of the four neuromodulator states
  (Eq. 3.1-3.6) of :meth:`evodevo.neuromod.modules.Neuromodulators.step` in one call, on the
  same matrices as its NumPy path (about 20 NumPy calls, 9-35 µs per environment step).

:func:`load` compiles the extension with :func:`torch.utils.cpp_extension.load` (g++ and the
Python headers are needed; about 30-60 s once per machine, cached under
``$TORCH_EXTENSIONS_DIR`` or ``~/.cache/torch_extensions``; concurrent builds from worker
processes wait on torch's lock). :func:`resolve` turns the ``network.lateral_kernel`` setting
into the implementation a run uses, for both kernels:

* ``auto`` (default): the C++ kernels when they build, else the PyTorch operations of
  :func:`evodevo.neuromod.columns.gated_laterals` and the NumPy module update (one warning
  line);
* ``cpp``: the C++ kernel, or a clear error when it cannot be built;
* ``torch``: always the PyTorch operations (and the NumPy module update).

Both compute the same equations; they differ in the last bits of float rounding (the C++ code
evaluates the context gate as ``1 / (1 + exp(-x))`` and sums in another order), so a run's
numbers are reproducible for the kernel it used, which ``summary.json`` records
(``lateral_kernel``).
"""

from __future__ import annotations

import hashlib
import sys
import threading
import warnings
from pathlib import Path
from types import ModuleType

import torch

from evodevo.errors import ConfigError

__all__ = ["KERNELS", "NO_TENSOR", "load", "resolve", "SOURCE", "SOURCES"]

#: Accepted values of ``network.lateral_kernel``.
KERNELS = ("auto", "cpp", "torch")
#: The one translation unit (the kernels are header-only, so the build compiles torch's
#: headers once).
SOURCE = Path(__file__).with_name("csrc") / "bindings.cpp"
#: Every file the extension is built from; their contents are part of its name.
SOURCES = (SOURCE,) + tuple(
    SOURCE.with_name(n)
    for n in ("frozen_features.h", "gated_lateral.h", "module_step.h", "td_update.h")
)

_module: ModuleType | None = None
_error: str | None = None


def _build_name() -> str:
    """Extension name, one per Python environment, torch version, checkout and kernel source.

    Two virtualenvs or two checkouts (git worktrees) on one machine share torch's build cache:
    under one name, each would rebuild the extension for the other (the build file names the
    source's absolute path). Torch only watches ``sources`` for changes, not the headers they
    include, so their contents are part of the name too."""
    h = hashlib.sha1(f"{sys.prefix}|{torch.__version__}|{SOURCE.resolve()}".encode())
    for p in SOURCES:
        h.update(p.read_bytes())
    return f"evodevo_kernels_{h.hexdigest()[:10]}"


#: "No tensor" for an optional argument of the C++ calls (no module states, no trained weights).
NO_TENSOR = torch.empty(0)


def load() -> ModuleType | None:
    """The compiled extension, building it on first call; None (and the reason kept for
    :func:`resolve`) when it cannot be built."""
    global _module, _error
    if _module is not None or _error is not None:
        return _module
    # say so only when it takes long, i.e. when it compiles (loading a cached build is ~1 s)
    notice = threading.Timer(
        3.0,
        lambda: print(
            "evodevo: building the fused BIARM kernels (once per machine, ~30-60 s)",
            file=sys.stderr,
            flush=True,
        ),
    )
    notice.daemon = True
    notice.start()
    try:
        # optional dependency: setuptools (torch's extension builder imports it); without it the
        # kernels cannot be built and the PyTorch operations run, as without a compiler
        from torch.utils.cpp_extension import load as build

        _module = build(
            name=_build_name(),
            sources=[str(SOURCE)],
            extra_cflags=["-O3"],
            verbose=False,
        )
    except Exception as exc:  # a missing compiler or header surfaces as many exception types
        lines = str(exc).strip().splitlines()
        _error = f"{type(exc).__name__}: {lines[-1] if lines else ''}"
    finally:
        notice.cancel()
    return _module


def resolve(setting: str) -> str:
    """``network.lateral_kernel`` -> the kernel to use, ``"cpp"`` or ``"torch"``."""
    if setting not in KERNELS:
        raise ConfigError(f"network.lateral_kernel={setting!r} is not one of {', '.join(KERNELS)}")
    if setting == "torch":
        return "torch"
    if load() is not None:
        return "cpp"
    if setting == "cpp":
        raise ConfigError(
            "network.lateral_kernel='cpp' but the C++ kernels (csrc/*.cpp) did not build "
            f"({_error}); install g++ and the Python headers, or set network.lateral_kernel "
            "to auto or torch"
        )
    warnings.warn(
        f"the fused BIARM kernels did not build ({_error}); using the PyTorch and NumPy "
        "operations (same equations, slower)",
        RuntimeWarning,
        stacklevel=2,
    )
    return "torch"
