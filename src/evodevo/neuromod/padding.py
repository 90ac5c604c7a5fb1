"""Input standardisation phi (Eq. 3.10, SPEC §1.1): zero-pad observations to ``d_max``.

>>> import numpy as np
>>> phi(np.array([1.0, 2.0]), 4)
array([1., 2., 0., 0.], dtype=float32)
"""

from __future__ import annotations

import numpy as np

from evodevo.errors import EvodevoError

__all__ = ["phi", "phi_into", "check_fits"]


def check_fits(obs_dim: int, d_max: int, env_id: str = "") -> None:
    """Raise :class:`EvodevoError` when an observation of ``obs_dim`` values exceeds ``d_max``."""
    if obs_dim > d_max:
        where = f" of {env_id}" if env_id else ""
        raise EvodevoError(
            f"observation size {obs_dim}{where} exceeds d_max={d_max}; "
            "raise network.d_max or leave it null to use the largest observation"
        )


def phi(x: np.ndarray, d_max: int) -> np.ndarray:
    """``[x; 0]`` of length ``d_max`` as float32 (Eq. 3.10)."""
    flat = np.asarray(x, dtype=np.float32).reshape(-1)
    check_fits(flat.size, d_max)
    out = np.zeros(d_max, dtype=np.float32)
    out[: flat.size] = flat
    return out


def phi_into(out: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Write ``phi(x)`` into a preallocated float32 row (the tail stays zero); hot-path version.

    ``out`` must be zero beyond ``x.size`` already (it is written only up to ``x.size``).
    """
    out[: x.shape[0]] = x
    return out
