"""Objects in the tray of ``evodevo/KukaDiverseObject-v0`` (SPEC §3): dropping them one by one,
reading a settled scene, and writing it back (what the settled-scene cache stores,
:mod:`evodevo.envs.scene_cache`).
"""

from __future__ import annotations

import numpy as np

from evodevo.envs.bullet import pybullet as p
from evodevo.envs.scene_cache import SettledScene

__all__ = ["DROP_HEIGHT", "drop_objects", "capture_scene", "place_scene"]

#: Drop height of the objects (m).
DROP_HEIGHT = 0.15


def drop_objects(
    cid: int, files: list[str], poses: list[tuple[float, float, float]], settle_steps: int
) -> list[int]:
    """Load the objects at their drop poses, one by one, each followed by ``settle_steps`` steps."""
    uids = []
    for path, (x, y, angle) in zip(files, poses, strict=True):
        orn = p.getQuaternionFromEuler([0, 0, angle])
        uid = p.loadURDF(
            path, basePosition=[x, y, DROP_HEIGHT], baseOrientation=orn, physicsClientId=cid
        )
        uids.append(uid)
        for _ in range(settle_steps):
            p.stepSimulation(physicsClientId=cid)
    return uids


def capture_scene(
    cid: int,
    uids: list[int],
    arm_uid: int,
    files: tuple[str, ...],
    poses: list[tuple[float, float, float]],
    seed: int | None,
) -> SettledScene:
    """Read the settled state of every object and arm joint (see :class:`SettledScene`)."""
    objects = np.empty((len(uids), 13), dtype=np.float64)
    for i, uid in enumerate(uids):
        pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=cid)
        lin, ang = p.getBaseVelocity(uid, physicsClientId=cid)
        objects[i] = (*pos, *orn, *lin, *ang)
    n = p.getNumJoints(arm_uid, physicsClientId=cid)
    states = p.getJointStates(arm_uid, list(range(n)), physicsClientId=cid)
    return SettledScene(
        files=files,
        poses=np.asarray(poses, dtype=np.float64),
        objects=objects,
        arm_q=np.array([s[0] for s in states], dtype=np.float64),
        arm_qd=np.array([s[1] for s in states], dtype=np.float64),
        seed=seed,
    )


def place_scene(cid: int, uids: list[int], arm_uid: int, scene: SettledScene) -> None:
    """Write a settled scene's state into freshly dropped objects and the arm."""
    for uid, row in zip(uids, scene.objects, strict=True):
        vals = row.tolist()
        p.resetBasePositionAndOrientation(uid, vals[0:3], vals[3:7], physicsClientId=cid)
        p.resetBaseVelocity(uid, vals[7:10], vals[10:13], physicsClientId=cid)
    for j, (q, qd) in enumerate(zip(scene.arm_q.tolist(), scene.arm_qd.tolist(), strict=True)):
        p.resetJointState(arm_uid, j, q, targetVelocity=qd, physicsClientId=cid)
