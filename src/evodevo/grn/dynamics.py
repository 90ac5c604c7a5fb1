"""Gene-expression dynamics, Eq. 4.1–4.4, vectorised over a batch (SPEC §2.1).

For a batch of B (genome, episode) pairs, one call advances every expression vector:

* ``u = s W_s + (x ⊙ alpha) W_r``                    (Eq. 4.1–4.2, alpha indexed by the source gene)
* ``f = H(u, theta) = u² / (theta² + u²) · sign(u)``  (Eq. 4.3)
* ``x ← clip(x + dt (f − delta ⊙ x + eta), 0, 1)``    (Eq. 4.4, eta ~ N(0, noise_std²))
* ``a = tanh(x W_m)``                                (motor output, from the updated x)

The per-gene loop of Algorithm 2 exists only as the reference in the tests.

>>> import numpy as np
>>> float(hill(np.array(0.5), np.array(0.5)))
0.5
"""

from __future__ import annotations

import numpy as np

from evodevo.errors import EvodevoError

__all__ = ["hill", "regulatory_input", "expression_step", "motor_output"]


def hill(u: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Signed Hill activation ``H(u, theta) = u² / (theta² + u²) · sign(u)`` (Eq. 4.3)."""
    u2 = u * u
    return u2 / (theta * theta + u2) * np.sign(u)


def regulatory_input(
    s: np.ndarray, x: np.ndarray, W_s: np.ndarray, W_r: np.ndarray, alpha: np.ndarray
) -> np.ndarray:
    """``u[b, i] = sum_j W_s[b, j, i] s[b, j] + sum_k W_r[b, k, i] x[b, k] alpha[b, k]``.

    Args:
        s: sensors (B, n_s). x: expression (B, n). W_s: (B, n_s, n). W_r: (B, n, n).
        alpha: (B, n).
    """
    return np.einsum("bj,bji->bi", s, W_s) + np.einsum("bk,bki->bi", x * alpha, W_r)


def expression_step(
    x: np.ndarray,
    s: np.ndarray,
    W_s: np.ndarray,
    W_r: np.ndarray,
    theta: np.ndarray,
    delta: np.ndarray,
    alpha: np.ndarray,
    dt: float,
    eta: np.ndarray,
) -> np.ndarray:
    """One Euler step of Eq. 4.4 for a batch; returns the new expression (B, n).

    Args:
        x: expression (B, n) in [0, 1].
        s: sensor vectors (B, n_s).
        W_s: batched genome array (leading axis B).
        W_r: batched genome array (leading axis B).
        theta: batched genome array (leading axis B).
        delta: batched genome array (leading axis B).
        alpha: batched genome array (leading axis B).
        dt: time step.
        eta: expression noise (B, n), already drawn (zeros for no noise).

    Raises:
        EvodevoError: if any input to the update is non-finite (NaN/inf sensors or weights).
    """
    u = regulatory_input(s, x, W_s, W_r, alpha)
    if not np.all(np.isfinite(u)):
        bad = np.argwhere(~np.isfinite(u))[0]
        raise EvodevoError(
            f"GRN regulatory input is non-finite (batch item {bad[0]}, gene {bad[1]}); "
            "check the sensor values and the genome for NaN/inf"
        )
    f = hill(u, theta)
    x_new = np.clip(x + dt * (f - delta * x + eta), 0.0, 1.0)
    if not np.all(np.isfinite(x_new)):
        raise EvodevoError("GRN expression became non-finite; check theta, delta and the noise")
    return x_new


def motor_output(x: np.ndarray, W_m: np.ndarray) -> np.ndarray:
    """``a[b] = tanh(x[b] W_m[b])`` (B, A)."""
    return np.tanh(np.einsum("bi,bia->ba", x, W_m))
