"""The Kuka iiwa arm with a WSG50 gripper, driven by end-effector displacements (SPEC §2.6, §3).

The logic (joint layout, initial pose, inverse-kinematics settings, motor gains, workspace clamps)
is copied from ``pybullet_envs/bullet/kuka.py`` of the ``pybullet`` 3.2.7 package
(Copyright (c) Erwin Coumans and the Bullet contributors, zlib licence). Two changes, neither of
which alters the physics:

* every call carries ``physicsClientId``, so several arms live in one process;
* the arm (and its tray) is loaded once by :meth:`KukaArm.load` and put back in its initial
  state by :meth:`KukaArm.reset_state`, instead of being re-loaded after ``resetSimulation``.

>>> import pybullet as p, pybullet_data
>>> cid = p.connect(p.DIRECT)
>>> arm = KukaArm(cid, pybullet_data.getDataPath())
>>> arm.load(); arm.reset_state()
>>> arm.end_effector_target
[0.537, 0.0, 0.5]
>>> p.disconnect(cid)
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

from evodevo.envs.bullet import pybullet as p

__all__ = [
    "KukaArm",
    "INITIAL_JOINT_POSITIONS",
    "END_EFFECTOR_INDEX",
    "FINGER_A_JOINT",
    "FINGER_B_JOINT",
    "WORKSPACE_X",
    "WORKSPACE_Y",
    "OPEN_FINGER_ANGLE",
]

#: Joint positions the original writes into the freshly loaded arm (one per joint, 14 joints).
INITIAL_JOINT_POSITIONS: tuple[float, ...] = (
    0.006418,
    0.413184,
    -0.011401,
    -1.589317,
    0.005379,
    1.137684,
    -0.006539,
    0.000048,
    -0.299912,
    0.000000,
    -0.000043,
    0.299960,
    0.000000,
    -0.000200,
)
#: Link whose pose the inverse kinematics targets (``kukaEndEffectorIndex``).
END_EFFECTOR_INDEX = 6
#: Joint that rotates the gripper about the vertical (``endEffectorAngle``).
GRIPPER_ROTATION_JOINT = 7
#: Left finger joint; its target is ``-finger_angle``.
FINGER_A_JOINT = 8
#: Right finger joint; its target is ``+finger_angle``.
FINGER_B_JOINT = 11
#: Finger tip joints, held at 0.
FINGER_TIP_JOINTS = (10, 13)
#: Clamp of the end-effector target's x (metres), as in the original ``applyAction``.
WORKSPACE_X = (0.50, 0.65)
#: Clamp of the end-effector target's y (metres), as in the original ``applyAction``.
WORKSPACE_Y = (-0.17, 0.22)
#: Initial end-effector target (x, y, z) in metres.
INITIAL_END_EFFECTOR_TARGET = (0.537, 0.0, 0.5)
#: Finger angle of an open gripper (the env always commands 0.3 outside the grasp).
OPEN_FINGER_ANGLE = 0.3

_BASE_POSITION = (-0.1, 0.0, 0.07)
_BASE_ORIENTATION = (0.0, 0.0, 0.0, 1.0)
_TRAY_POSITION = (0.64, 0.075, -0.19)
_TRAY_ORIENTATION = (0.0, 0.0, 1.0, 0.0)
_MAX_VELOCITY = 0.35
_MAX_FORCE = 200.0
_FINGER_A_FORCE = 2.0
_FINGER_B_FORCE = 2.5
_FINGER_TIP_FORCE = 2.0
# Motor arguments of the arm joints 0..6 and of the hand joints (gripper rotation, fingers A and
# B, finger tips), as in the original; 0.1 and 1.0 are setJointMotorControl2's default gains.
_ARM_JOINTS = list(range(END_EFFECTOR_INDEX + 1))
_ARM_ZEROS = [0.0] * len(_ARM_JOINTS)
_ARM_FORCES = [_MAX_FORCE] * len(_ARM_JOINTS)
_ARM_KP = [0.3] * len(_ARM_JOINTS)
_ARM_KD = [1.0] * len(_ARM_JOINTS)
_HAND_JOINTS = [GRIPPER_ROTATION_JOINT, FINGER_A_JOINT, FINGER_B_JOINT, *FINGER_TIP_JOINTS]
_HAND_FORCES = [_MAX_FORCE, _FINGER_A_FORCE, _FINGER_B_FORCE, _FINGER_TIP_FORCE, _FINGER_TIP_FORCE]
_HAND_KP = [0.1] * len(_HAND_JOINTS)
_HAND_KD = [1.0] * len(_HAND_JOINTS)
# The original sets ``useNullSpace = 21``, so its ``useNullSpace == 1`` test fails and the
# inverse kinematics runs with joint damping only (its null-space limits are never used).
_JOINT_DAMPING = [0.00001] * 14


class KukaArm:
    """Kuka iiwa + WSG50 gripper in one PyBullet physics client (SPEC §2.6).

    Args:
        client: PyBullet physics client id (from ``pybullet.connect``).
        urdf_root: Folder of ``pybullet_data``.
    """

    def __init__(self, client: int, urdf_root: str) -> None:
        self._cid = client
        self._root = urdf_root
        self.uid = -1
        self.tray_uid = -1
        self.num_joints = 0
        self.end_effector_target: list[float] = list(INITIAL_END_EFFECTOR_TARGET)
        self.end_effector_angle = 0.0
        self._max_velocity_pending = True
        # The gripper orientation never changes: it points down.
        self._down = p.getQuaternionFromEuler([0.0, -math.pi, 0.0])

    def load(self) -> None:
        """Load the arm and the tray (once per physics client), in the original's order."""
        cid = self._cid
        self.uid = p.loadSDF(
            os.path.join(self._root, "kuka_iiwa/kuka_with_gripper2.sdf"), physicsClientId=cid
        )[0]
        self.num_joints = p.getNumJoints(self.uid, physicsClientId=cid)
        self._reset_joints()
        self.tray_uid = p.loadURDF(
            os.path.join(self._root, "tray/tray.urdf"),
            basePosition=_TRAY_POSITION,
            baseOrientation=_TRAY_ORIENTATION,
            physicsClientId=cid,
        )

    def reset_state(self) -> None:
        """Put the loaded arm back exactly where the original's freshly loaded arm starts."""
        cid = self._cid
        p.resetBasePositionAndOrientation(
            self.tray_uid, _TRAY_POSITION, _TRAY_ORIENTATION, physicsClientId=cid
        )
        self._reset_joints()

    def _reset_joints(self) -> None:
        cid = self._cid
        p.resetBasePositionAndOrientation(
            self.uid, _BASE_POSITION, _BASE_ORIENTATION, physicsClientId=cid
        )
        for j in range(self.num_joints):
            q = INITIAL_JOINT_POSITIONS[j]
            p.resetJointState(self.uid, j, q, targetVelocity=0.0, physicsClientId=cid)
            p.setJointMotorControl2(
                self.uid,
                j,
                p.POSITION_CONTROL,
                targetPosition=q,
                force=_MAX_FORCE,
                physicsClientId=cid,
            )
        self.end_effector_target = list(INITIAL_END_EFFECTOR_TARGET)
        self.end_effector_angle = 0.0
        self._max_velocity_pending = True

    def apply_action(self, dx: float, dy: float, dz: float, da: float, finger_angle: float) -> None:
        """Move the end-effector target by (dx, dy, dz), turn the gripper by da, set the fingers.

        Same inverse kinematics (damped, fixed downward orientation) and motor gains as the
        original ``Kuka.applyAction``; x and y of the target are clamped to the workspace.
        """
        cid = self._cid
        # The original reads the end-effector state here (unused); kept for identical numerics.
        p.getLinkState(self.uid, END_EFFECTOR_INDEX, physicsClientId=cid)
        t = self.end_effector_target
        t[0] = min(max(t[0] + dx, WORKSPACE_X[0]), WORKSPACE_X[1])
        t[1] = min(max(t[1] + dy, WORKSPACE_Y[0]), WORKSPACE_Y[1])
        t[2] = t[2] + dz
        self.end_effector_angle += da
        joint_poses = p.calculateInverseKinematics(
            self.uid,
            END_EFFECTOR_INDEX,
            t,
            self._down,
            jointDamping=_JOINT_DAMPING,
            physicsClientId=cid,
        )
        if self._max_velocity_pending:
            # setJointMotorControlArray cannot set maxVelocity, but a motor keeps it once set.
            for i in range(END_EFFECTOR_INDEX + 1):
                p.setJointMotorControl2(
                    bodyUniqueId=self.uid,
                    jointIndex=i,
                    controlMode=p.POSITION_CONTROL,
                    targetPosition=joint_poses[i],
                    targetVelocity=0,
                    force=_MAX_FORCE,
                    maxVelocity=_MAX_VELOCITY,
                    positionGain=0.3,
                    velocityGain=1,
                    physicsClientId=cid,
                )
            self._max_velocity_pending = False
        else:
            p.setJointMotorControlArray(
                self.uid,
                _ARM_JOINTS,
                p.POSITION_CONTROL,
                targetPositions=joint_poses[: END_EFFECTOR_INDEX + 1],
                targetVelocities=_ARM_ZEROS,
                forces=_ARM_FORCES,
                positionGains=_ARM_KP,
                velocityGains=_ARM_KD,
                physicsClientId=cid,
            )
        a = self.end_effector_angle
        p.setJointMotorControlArray(
            self.uid,
            _HAND_JOINTS,
            p.POSITION_CONTROL,
            targetPositions=[a, -finger_angle, finger_angle, 0.0, 0.0],
            forces=_HAND_FORCES,
            positionGains=_HAND_KP,
            velocityGains=_HAND_KD,
            physicsClientId=cid,
        )

    def end_effector_position(self) -> Sequence[float]:
        """Measured world position (x, y, z) of the end-effector link, in metres."""
        return p.getLinkState(self.uid, END_EFFECTOR_INDEX, physicsClientId=self._cid)[0]

    def finger_opening(self) -> float:
        """Measured finger opening angle (rad): mean of the two finger joints, ~0.3 open, 0 shut."""
        a, b = p.getJointStates(
            self.uid, [FINGER_A_JOINT, FINGER_B_JOINT], physicsClientId=self._cid
        )
        return 0.5 * (b[0] - a[0])
