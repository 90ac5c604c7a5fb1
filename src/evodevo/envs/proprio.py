"""The arm's proprioception in ``evodevo/KukaDiverseObject-v0`` (SPEC §2.2, §3): end-effector
x, y, z and the finger opening, normalised to about [−1, 1].
"""

from __future__ import annotations

import numpy as np

from evodevo.envs.kuka_arm import OPEN_FINGER_ANGLE, WORKSPACE_X, WORKSPACE_Y

__all__ = ["GRASP_HEIGHT", "START_HEIGHT", "PROPRIO_CENTRE", "PROPRIO_HALF_RANGE", "PROPRIO_CLIP"]

#: The automatic grasp starts when the end effector is at or below this height (m).
GRASP_HEIGHT = 0.1
#: Start height of the end-effector target (m): the top of the height hack's descent.
START_HEIGHT = 0.5

#: Proprioception ``(x, y, z, finger)`` is ``(raw - PROPRIO_CENTRE) / PROPRIO_HALF_RANGE``:
#: x and y over the workspace clamp of the end-effector target ([0.50, 0.65] and [−0.17, 0.22] m),
#: z over the height hack's descent from the start height 0.5 m to the grasp height 0.1 m, the
#: finger opening (rad) over [0, 0.3] (shut .. open). Each maps to [−1, 1]; the measured pose can
#: overshoot (z goes a little below −1 at the grasp, a large object can push the fingers open
#: beyond 0.3 rad, without the height hack z is free), so the result is clipped to
#: ±:data:`PROPRIO_CLIP`.
PROPRIO_CENTRE = np.array(
    [
        0.5 * (WORKSPACE_X[0] + WORKSPACE_X[1]),
        0.5 * (WORKSPACE_Y[0] + WORKSPACE_Y[1]),
        0.5 * (START_HEIGHT + GRASP_HEIGHT),
        0.5 * OPEN_FINGER_ANGLE,
    ],
    dtype=np.float64,
)
#: Bound of the normalised proprioception.
PROPRIO_CLIP = 1.5
PROPRIO_HALF_RANGE = np.array(
    [
        0.5 * (WORKSPACE_X[1] - WORKSPACE_X[0]),
        0.5 * (WORKSPACE_Y[1] - WORKSPACE_Y[0]),
        0.5 * (START_HEIGHT - GRASP_HEIGHT),
        0.5 * OPEN_FINGER_ANGLE,
    ],
    dtype=np.float64,
)
