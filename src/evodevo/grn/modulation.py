"""Neuromodulation of the GRN parameters, thesis Eq. 5.2–5.4, and the modulator dynamics (SPEC §5).

Four modulator states ``m = [m_DA, m_5HT, m_NE, m_ACh] ∈ [0, 1]^4`` per batch item, always in
this order (:data:`MODULATORS`). All functions are vectorised over a leading batch axis B.

* decay, Eq. 5.2 (exponential form): ``delta_i = delta_i^base · exp(gamma_DA (m_DA − 0.5))``
* thresholds, Eq. 5.3: ``theta_i = theta_i^base · (1 + gamma_5HT (m_5HT − 0.5))``
* regulation, Eq. 5.4: ``w_ki = w_ki^base · (1 + gamma_NE (m_NE − 0.5) + gamma_ACh (m_ACh − 0.5))``
* states, Eq. 3.1: ``m ← m + tau (target − m)``; novelty, Eq. 3.5: ``n ← 0.995 n``
* targets: one 2-layer MLP per modulator, ``sigmoid(relu(v U1 + c1) U2 + c2)``

With every gamma = 0 each modulated parameter equals its base value exactly (the factors are
exactly 1.0 in floating point), so the neuromodulated GRN reduces to the plain GRN bit for bit.

>>> import numpy as np
>>> float(modulated_decay(np.array([[0.2]]), np.array([1.0]), np.array([2.0]))[0, 0])
0.5436563656918091
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MODULATORS",
    "DA",
    "SHT",
    "NE",
    "ACH",
    "modulated_decay",
    "modulated_threshold",
    "regulatory_gain",
    "modulated_regulation",
    "modulator_update",
    "target_network",
]

MODULATORS = ("DA", "5HT", "NE", "ACh")
"""Modulator names in the order of every array of this module."""
DA, SHT, NE, ACH = range(4)
"""Indices of the modulators."""
BASELINE = 0.5
"""The modulator level at which every parameter keeps its base value (Eq. 5.2–5.4)."""


def modulated_decay(delta: np.ndarray, m_da: np.ndarray, gamma_da: np.ndarray) -> np.ndarray:
    """Eq. 5.2: ``delta^base · exp(gamma_DA (m_DA − 0.5))``; stays positive for any gamma.

    Args:
        delta: base decay rates (B, n).
        m_da: dopamine state (B,).
        gamma_da: modulation strength (B,).
    """
    return delta * np.exp(gamma_da * (m_da - BASELINE))[:, None]


def modulated_threshold(theta: np.ndarray, m_5ht: np.ndarray, gamma_5ht: np.ndarray) -> np.ndarray:
    """Eq. 5.3: ``theta^base · (1 + gamma_5HT (m_5HT − 0.5))``.

    Positive for |gamma_5HT| < 2 (the config bounds enforce it), since |m − 0.5| ≤ 0.5.

    Args:
        theta: base thresholds (B, n).
        m_5ht: serotonin state (B,).
        gamma_5ht: modulation strength (B,).
    """
    return theta * (1.0 + gamma_5ht * (m_5ht - BASELINE))[:, None]


def regulatory_gain(
    m_ne: np.ndarray, m_ach: np.ndarray, gamma_ne: np.ndarray, gamma_ach: np.ndarray
) -> np.ndarray:
    """The common factor of Eq. 5.4, ``1 + gamma_NE (m_NE − 0.5) + gamma_ACh (m_ACh − 0.5)`` (B,)."""
    return 1.0 + gamma_ne * (m_ne - BASELINE) + gamma_ach * (m_ach - BASELINE)


def modulated_regulation(
    W_r: np.ndarray,
    m_ne: np.ndarray,
    m_ach: np.ndarray,
    gamma_ne: np.ndarray,
    gamma_ach: np.ndarray,
) -> np.ndarray:
    """Eq. 5.4: every regulatory weight of a batch item times its :func:`regulatory_gain`.

    Absent connections (0) stay absent, so modulation never changes the network's structure.

    Args:
        W_r: base regulatory weights (B, n, n).
        m_ne: norepinephrine states (B,).
        m_ach: acetylcholine states (B,).
        gamma_ne: norepinephrine modulation strengths (B,).
        gamma_ach: acetylcholine modulation strengths (B,).
    """
    return W_r * regulatory_gain(m_ne, m_ach, gamma_ne, gamma_ach)[:, None, None]


def modulator_update(m: np.ndarray, target: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Eq. 3.1: ``m + tau (target − m)`` (any broadcastable shapes)."""
    return m + tau * (target - m)


def target_network(
    v: np.ndarray, U1: np.ndarray, c1: np.ndarray, U2: np.ndarray, c2: np.ndarray
) -> np.ndarray:
    """Targets of k modulators for a batch: ``sigmoid(relu(v U1 + c1) · U2 + c2)``.

    Args:
        v: inputs (B, k, d) — the sensor vector and the modulator's task signal.
        U1: (B, k, d, H). c1: (B, k, H). U2: (B, k, H). c2: (B, k).

    Returns:
        Targets in (0, 1), shape (B, k).
    """
    h = np.maximum(np.einsum("bkd,bkdh->bkh", v, U1) + c1, 0.0)
    z = np.einsum("bkh,bkh->bk", h, U2) + c2
    return 0.5 * (1.0 + np.tanh(0.5 * z))  # sigmoid without overflow for large |z|
