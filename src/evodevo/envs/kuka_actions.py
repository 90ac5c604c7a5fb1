"""Actions of ``evodevo/KukaDiverseObject-v0`` (SPEC §2.6, §3): end-effector displacements, as
in the original: with the height hack (dx, dy, d-angle) and the arm always descending, without
it (dx, dy, dz, d-angle); the discrete tables of the original; one clear error for a malformed
action.

>>> from gymnasium import spaces
>>> box = spaces.Box(-1, 1, (3,))
>>> dx, dy, dz, da = parse_action(np.array([1.0, 0.0, -1.0]), box, False, True, 0.06)
>>> float(dx), float(dy), dz, float(da)
(0.06, 0.0, -0.06, -0.25)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from evodevo.errors import EvodevoError

__all__ = ["DV", "DA", "DISCRETE_HEIGHT_HACK", "DISCRETE_FREE", "parse_action"]

#: End-effector displacement (m) per unit action; the gripper turns 0.25 rad per unit action.
DV = 0.06
DA = 0.25

# Discrete actions of the original: (dx, dy, dz, da) per index, dv and 0.25 rad units.
DISCRETE_HEIGHT_HACK = (
    (0, 0, -1, 0),
    (-1, 0, -1, 0),
    (1, 0, -1, 0),
    (0, -1, -1, 0),
    (0, 1, -1, 0),
    (0, 0, -1, -1),
    (0, 0, -1, 1),
)
DISCRETE_FREE = (
    (0, 0, 0, 0),
    (-1, 0, 0, 0),
    (1, 0, 0, 0),
    (0, -1, 0, 0),
    (0, 1, 0, 0),
    (0, 0, -1, 0),
    (0, 0, 1, 0),
    (0, 0, 0, -1),
    (0, 0, 0, 1),
)


def parse_action(
    action: Any, space: Any, is_discrete: bool, height_hack: bool, lateral_dv: float
) -> tuple[float, float, float, float]:
    """``(dx, dy, dz, d-angle)`` of ``action`` in metres and radians; sideways moves are
    ``lateral_dv`` per unit (the benchmark's :data:`DV` unless the env says otherwise)."""
    if is_discrete:
        if isinstance(action, np.ndarray) and action.shape == ():
            action = action.item()
        n = int(space.n)  # type: ignore[attr-defined]
        if not isinstance(action, (int, np.integer)) or not 0 <= int(action) < n:
            raise EvodevoError(f"discrete action must be an integer in [0, {n}), got {action!r}")
        table = DISCRETE_HEIGHT_HACK if height_hack else DISCRETE_FREE
        ux, uy, uz, ua = table[int(action)]
        return lateral_dv * ux, lateral_dv * uy, DV * uz, DA * ua
    shape = space.shape
    try:
        a = np.asarray(action)
        if a.dtype not in (np.float32, np.float64):
            a = a.astype(np.float64)
    except (TypeError, ValueError) as exc:
        raise EvodevoError(f"action must be numeric with shape {shape}, got {action!r}") from exc
    if a.shape != shape:
        raise EvodevoError(
            f"action has shape {a.shape}, expected {shape} "
            f"({'dx, dy, d-angle' if height_hack else 'dx, dy, dz, d-angle'})"
        )
    if not np.all(np.isfinite(a)):
        raise EvodevoError(f"action must be finite, got {a.tolist()}")
    # NumPy scalars in the action's own precision, as in the original (NumPy 2 keeps float32
    # for ``0.06 * float32`` and for the arm's target after adding it), so that float32
    # actions give the same numbers as there.
    a = np.clip(a, -1.0, 1.0)
    if height_hack:
        return lateral_dv * a[0], lateral_dv * a[1], -DV, DA * a[2]
    return lateral_dv * a[0], lateral_dv * a[1], DV * a[2], DA * a[3]
