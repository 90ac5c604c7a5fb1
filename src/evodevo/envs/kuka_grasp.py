"""The automatic grasp of ``evodevo/KukaDiverseObject-v0`` (SPEC §3).

Once the end effector is low enough the original closes the fingers for
:data:`GRASP_CLOSE_STEPS` simulation steps and then lifts for :data:`GRASP_LIFT_STEPS` steps; the
episode succeeds if an object's base is above the success height after that. :func:`grasp` does
the same, step for step. With ``skip_empty_lift`` it stops the lift early once the rest of it
cannot change the outcome, which :func:`lift_is_empty` checks every :data:`CHECK_EVERY` lift
steps:

* no object touches the arm (no contact point between the arm body, fingers included, and any
  object), so nothing is held;
* the lowest point of the arm (the bounding boxes of all its links) is more than
  :data:`CLEARANCE` plus the objects' energy height above the top of every object's bounding
  box, and the end effector moves up: the lift only raises the arm further, so no object can
  touch it again;
* every object's base is below the success height by more than the energy height, so none gets
  there without the arm. The energy height is the objects' total kinetic energy (rotation
  bounded by the largest principal moment) over the lightest object's weight: the most any
  object can rise by itself.

Not touching the arm right after the fingers closed is *not* enough: the fingertips often rest
on the tray floor with the fingers held open by it, and close on an object only when the lift
frees them (in 78 grasps of three policies, 32 had no object contact after closing and 15 of
those succeeded). The arm clears every object about 230 of the 500 lift steps in, so a failed
grasp saves about 260 steps. What changes is only the terminal state of a failed grasp: the arm
ends part of the way up instead of at the top of the lift (docs/kuka_env.md, "Skipped lift").

>>> from evodevo.envs import KukaDiverseObjectEnv
>>> env = KukaDiverseObjectEnv(num_objects=1)
>>> _ = env.reset(seed=0)
>>> touches_arm(env._cid, env._arm.uid, env._object_uids)
False
>>> env.close()
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from evodevo.envs.bullet import pybullet as p
from evodevo.envs.kuka_arm import END_EFFECTOR_INDEX, OPEN_FINGER_ANGLE, KukaArm

__all__ = [
    "CHECK_EVERY",
    "CLEARANCE",
    "GRASP_CLOSE_STEPS",
    "GRASP_LIFT_STEPS",
    "GraspResult",
    "grasp",
    "lift_is_empty",
    "touches_arm",
]

#: Simulation steps of closing the fingers, then of lifting, in the automatic grasp.
GRASP_CLOSE_STEPS = 500
GRASP_LIFT_STEPS = 500
#: End-effector rise (m) commanded per simulation step of the lift, as in the original.
LIFT_DZ = 0.001
#: Lift steps between two checks of :func:`lift_is_empty` (a check costs ~15 µs, a step ~200 µs).
CHECK_EVERY = 5
#: Margin (m) between the arm's lowest point and the highest object top before the lift may stop.
CLEARANCE = 0.02


@dataclass(frozen=True)
class GraspResult:
    """What one automatic grasp did.

    Attributes:
        lift_steps: Simulation steps of the lift that ran (:data:`GRASP_LIFT_STEPS` unless the
            rest of the lift was skipped).
    """

    lift_steps: int

    @property
    def skipped(self) -> int:
        """Lift steps left out (0 when the whole lift ran)."""
        return GRASP_LIFT_STEPS - self.lift_steps


def touches_arm(cid: int, arm_uid: int, object_uids: Sequence[int]) -> bool:
    """Whether any object has a contact point with the arm body (a read-only query).

    The contact points are those of the last ``stepSimulation``; they include the points of a
    contact manifold that are still within the contact-breaking distance.
    """
    return any(
        p.getContactPoints(bodyA=arm_uid, bodyB=uid, physicsClientId=cid) for uid in object_uids
    )


def lift_is_empty(
    cid: int, arm: KukaArm, object_uids: Sequence[int], success_height: float, gravity: float
) -> bool:
    """Whether the rest of the lift cannot change the outcome (module docstring; read-only).

    Args:
        cid: Physics client of the episode.
        arm: The episode's arm.
        object_uids: The objects in the tray.
        success_height: An object's base above this height (m) is a success.
        gravity: Magnitude of the gravity (m/s²).
    """
    if not object_uids:
        return True
    arm_low = min(
        p.getAABB(arm.uid, j, physicsClientId=cid)[0][2] for j in range(-1, arm.num_joints)
    )
    top = max(p.getAABB(uid, -1, physicsClientId=cid)[1][2] for uid in object_uids)
    if arm_low <= top + CLEARANCE:  # the cheap test first: it fails for the first ~200 steps
        return False
    if touches_arm(cid, arm.uid, object_uids):
        return False
    energy, lightest, highest = 0.0, float("inf"), -float("inf")
    for uid in object_uids:
        info = p.getDynamicsInfo(uid, -1, physicsClientId=cid)
        mass, inertia = info[0], info[2]
        (vx, vy, vz), (wx, wy, wz) = p.getBaseVelocity(uid, physicsClientId=cid)
        energy += 0.5 * mass * (vx * vx + vy * vy + vz * vz)
        energy += 0.5 * max(inertia) * (wx * wx + wy * wy + wz * wz)
        lightest = min(lightest, mass)
        highest = max(highest, p.getBasePositionAndOrientation(uid, physicsClientId=cid)[0][2])
    if lightest <= 0.0:  # a static object: no energy bound
        return False
    rise = energy / (lightest * abs(gravity))
    if arm_low <= top + CLEARANCE + rise or highest + rise >= success_height:
        return False
    ee_vz = p.getLinkState(arm.uid, END_EFFECTOR_INDEX, computeLinkVelocity=1, physicsClientId=cid)[
        6
    ][2]
    return bool(ee_vz > 0.0)


def grasp(
    cid: int,
    arm: KukaArm,
    object_uids: Sequence[int],
    *,
    skip_empty_lift: bool,
    success_height: float,
    gravity: float,
) -> GraspResult:
    """Close the fingers for 500 steps, then lift for 500 steps, as the original does.

    Args:
        cid: Physics client of the episode.
        arm: The episode's arm.
        object_uids: The objects in the tray.
        skip_empty_lift: Stop the lift once :func:`lift_is_empty` (checked every
            :data:`CHECK_EVERY` steps); the outcome is the same, the arm is not fully lifted.
        success_height: An object's base above this height (m) is a success.
        gravity: Magnitude of the gravity (m/s²).

    Returns:
        How many lift steps ran.
    """
    finger_angle = OPEN_FINGER_ANGLE
    for _ in range(GRASP_CLOSE_STEPS):
        arm.apply_action(0.0, 0.0, 0.0, 0.0, finger_angle)
        p.stepSimulation(physicsClientId=cid)
        finger_angle -= OPEN_FINGER_ANGLE / 100.0
        if finger_angle < 0:
            finger_angle = 0.0
    for k in range(GRASP_LIFT_STEPS):
        if (
            skip_empty_lift
            and k % CHECK_EVERY == 0
            and lift_is_empty(cid, arm, object_uids, success_height, gravity)
        ):
            return GraspResult(lift_steps=k)
        arm.apply_action(0.0, 0.0, LIFT_DZ, 0.0, finger_angle)
        p.stepSimulation(physicsClientId=cid)
        finger_angle -= OPEN_FINGER_ANGLE / 100.0
        if finger_angle < 0:
            finger_angle = 0.0
    return GraspResult(lift_steps=GRASP_LIFT_STEPS)
