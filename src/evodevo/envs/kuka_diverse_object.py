"""``evodevo/KukaDiverseObject-v0``: a Gymnasium port of PyBullet's KukaDiverseObjectEnv (SPEC §3).

Same physics (timestep 1/240 s, 150 solver iterations, gravity −10, 80 simulation steps per
action, 500 settle steps after dropping each object, 500 + 500 steps of automatic grasp and
lift), same objects, camera and reward as ``pybullet_envs.bullet.kuka_diverse_object_gym_env``
of ``pybullet`` 3.2.7, with these differences:

* the Gymnasium API: ``reset(seed=, options=) -> (obs, info)`` and
  ``step(a) -> (obs, reward, terminated, truncated, info)``; every random draw (camera jitter,
  object choice, placement) comes from ``self.np_random``, so a seed fixes the episode;
* every ``rebuild_every`` resets (default: every reset, like the original's
  ``resetSimulation``) the physics client is replaced by a fresh one with the plane, table, tray
  and arm: PyBullet keeps about 70 KB for every ``loadURDF`` even after ``removeBody`` and
  ``resetSimulation`` (a worker grew by ~400 MB over one thesis-protocol evolution) and only a
  disconnect gives it back, and a fresh world means no episode can depend on earlier ones;
  between rebuilds a reset removes the previous objects and puts the arm back in its initial
  state;
* each instance owns its own ``pybullet.DIRECT`` client;
* ``info["proprio"]``: end-effector x, y, z and finger opening, normalised (see
  :data:`PROPRIO_CENTRE`, :data:`PROPRIO_HALF_RANGE`); ``info["is_success"]``: reward == 1;
* ``terminated`` is True after the automatic grasp; reaching ``max_steps`` without a grasp sets
  ``truncated`` (the original returned a single ``done``);
* continuous actions are clipped to [−1, 1];
* ``scene_cache`` (default on): the settled scene of a drop is simulated once per process (or
  per cache folder) and then written into the bodies instead of simulated again
  (:mod:`evodevo.envs.scene_cache`; docs/kuka_env.md, "Settled-scene cache");
* ``skip_empty_lift`` (default on): the automatic grasp's lift stops once nothing is held and
  the arm is clear above every object, when the rest of it cannot change the outcome
  (:mod:`evodevo.envs.kuka_grasp`; docs/kuka_env.md, "Skipped lift");
* ``dark_after`` (default off): the camera goes dark after the first k observations, and
  ``lateral_dv`` (default off: 0.06 m) slows the sideways moves; with both, a task that needs
  memory (docs/grn.md, "A task that needs memory").

>>> import gymnasium as gym, evodevo.envs
>>> env = gym.make("evodevo/KukaDiverseObject-v0")
>>> obs, info = env.reset(seed=0)
>>> obs.shape, obs.dtype, info["proprio"].shape
((48, 48, 3), dtype('uint8'), (4,))
>>> env.close()
"""

from __future__ import annotations

import contextlib
import importlib.metadata
import math
import os
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
import pybullet_data
from gymnasium import spaces
from gymnasium.utils.seeding import np_random

from evodevo.envs import kuka_arm
from evodevo.envs.bullet import pybullet as p
from evodevo.envs.env_options import check_options, positive
from evodevo.envs.kuka_actions import DISCRETE_FREE, DISCRETE_HEIGHT_HACK, DV, parse_action
from evodevo.envs.kuka_arm import OPEN_FINGER_ANGLE, KukaArm
from evodevo.envs.kuka_grasp import GRASP_CLOSE_STEPS, GRASP_LIFT_STEPS, grasp
from evodevo.envs.objects import object_files
from evodevo.envs.proprio import (
    GRASP_HEIGHT,
    PROPRIO_CENTRE,
    PROPRIO_CLIP,
    PROPRIO_HALF_RANGE,
)
from evodevo.envs.scene_cache import (
    CACHE_DIR_ENV,
    DEFAULT_MAX_ENTRIES,
    SceneCache,
    SettledScene,
    scene_key,
    shared_cache,
)
from evodevo.envs.tray import DROP_HEIGHT, capture_scene, drop_objects, place_scene
from evodevo.errors import ConfigError, EvodevoError

__all__ = [
    "KukaDiverseObjectEnv",
    "PROPRIO_CENTRE",
    "PROPRIO_HALF_RANGE",
    "PROPRIO_CLIP",
    "TIME_STEP",
    "SETTLE_STEPS",
    "GRASP_HEIGHT",
    "GRASP_CLOSE_STEPS",
    "GRASP_LIFT_STEPS",
    "SUCCESS_HEIGHT",
    "RENDER_SIZE",
]

#: Simulation timestep (s), as in the original.
TIME_STEP = 1.0 / 240.0
#: Constraint-solver iterations, as in the original.
SOLVER_ITERATIONS = 150
#: Gravity along z (m/s²), as in the original.
GRAVITY = -10.0
#: Simulation steps after dropping each object, so that they fall one by one.
SETTLE_STEPS = 500
#: Reward 1 when an object's base is above this height (m) after a step.
SUCCESS_HEIGHT = 0.2
#: Side (pixels) of the square image returned by ``render()`` in ``"rgb_array"`` mode.
RENDER_SIZE = 256


def _action_space(is_discrete: bool, height_hack: bool) -> spaces.Space[Any]:
    """The original's actions: 7 or 9 discrete ones, or a Box of (dx, dy[, dz], d-angle)."""
    if is_discrete:
        return spaces.Discrete(len(DISCRETE_HEIGHT_HACK if height_hack else DISCRETE_FREE))
    return spaces.Box(-1.0, 1.0, (3 if height_hack else 4,), dtype=np.float32)


def _scene_cache(option: bool | SceneCache, folder: str | None, entries: int) -> SceneCache | None:
    """The settled-scene cache of the ``scene_cache`` option (``scene_cache_dir``, else
    ``$EVODEVO_SCENE_CACHE_DIR``, else memory only), or None without one."""
    if isinstance(option, SceneCache):
        return option
    if option:
        return shared_cache(int(entries), folder or os.environ.get(CACHE_DIR_ENV) or None)
    return None


class KukaDiverseObjectEnv(gym.Env[np.ndarray, np.ndarray]):
    """Grasp one of several random objects from a tray with a Kuka arm (SPEC §2.6, §3).

    Args:
        height_hack: The arm moves down by ``dv`` on every step and the action is
            (dx, dy, d-angle); without it the action is (dx, dy, dz, d-angle).
        test_objects: Use the held-out tenth of the objects (``isTest`` in the original).
        num_objects: Objects dropped into the tray per episode (drawn with replacement).
        max_steps: Actions per episode before truncation (the benchmark's default 8).
        camera_random: In [0, 1]; jitter of the camera pitch, yaw (±3°) and fov (±2°).
        render_mode: ``None`` or ``"rgb_array"`` (``render()`` returns a ``RENDER_SIZE`` image).
        action_repeat: Simulation steps per action.
        block_random: In [0, 1]; spread of the objects' drop positions and angles.
        width: Observation width (pixels).
        height: Observation height (pixels).
        is_discrete: Discrete actions (7 with the height hack, 9 without), as in the original.
        urdf_root: Folder of ``pybullet_data``; the installed one by default.
        deterministic_pairs: Sort the broadphase's overlapping pairs, so that an episode does
            not depend on earlier episodes of the same instance (a seed gives the same episode).
            ``False`` is the original's setting: the first episode of an instance then matches
            the original bit for bit, later ones depend on the instance's history.
        rebuild_every: Replace the physics client by a freshly built world every this many
            resets (0 = never). PyBullet's memory stays bounded (module docstring), and with
            the default 1 every episode runs in a fresh world, as the original's
            ``resetSimulation`` gives, so no episode can depend on what ran before (about 40 ms
            per reset; docs/kuka_env.md, "Memory").
        scene_cache: Keep the settled scene of every seeded reset in a per-process LRU and write
            it into the bodies when the same drop comes again, instead of simulating it
            (docs/kuka_env.md, "Settled-scene cache"). ``True`` (default) uses the process-wide
            cache of ``scene_cache_dir``; a :class:`~evodevo.envs.scene_cache.SceneCache` uses
            that one; ``False`` is the port without it: the objects settle in the episode's own
            world (bit for bit the original's physics with ``deterministic_pairs=False`` and
            ``skip_empty_lift=False``), whose contact caches an episode then inherits, so its
            episodes differ from the cached ones in the last bits (and, the grasp being
            chaotic, some outcomes; same rates).
        scene_cache_dir: Folder of on-disk scenes shared by runs and sessions (created if
            missing); ``None`` reads ``$EVODEVO_SCENE_CACHE_DIR``, unset means memory only.
        scene_cache_entries: Scenes kept in memory per process (about 2 KB each).
        skip_empty_lift: Stop the automatic grasp's 500-step lift early once no object
            touches the arm, the arm's lowest point is clear above every object and no object
            can reach the success height by itself (:mod:`evodevo.envs.kuka_grasp`;
            docs/kuka_env.md, "Skipped lift"): the rest of the lift cannot change the outcome,
            so reward, ``terminated`` and ``is_success`` are unchanged, but the terminal
            observation and ``info["proprio"]`` of such a failed grasp show the arm part of the
            way up instead of at the top of the lift. ``False`` always lifts fully, as the
            original; the GRN evaluator keeps it off when the training fitness reads the
            gripper's end pose (``evaluation.distance_weight`` > 0). ``grasps``,
            ``lifts_skipped`` and ``lift_steps_skipped`` count this instance's grasps, the lifts
            stopped early and the simulation steps saved.
        lateral_dv: ``None`` (default): dx and dy move the end effector by ``dv`` = 0.06 m per
            unit action, as in the original. A number: by that many metres instead, while the
            descent (0.06 m per step under the height hack) and the turn (0.25 rad) keep theirs,
            so an episode lasts as long but reaching a seen object takes more steps (with
            ``dark_after``, a task that needs memory).
        dark_after: ``None`` (default): every observation is the camera image. An integer k:
            the first k observations of an episode (the reset's and those of the first k − 1
            steps) are the camera image, every later one is all zeros, so whatever the robot
            needs from the image after that it has to remember (0: dark from the start).
            Physics, reward and ``info`` are unchanged; ``render()`` still films the scene.

    Raises:
        ConfigError: An option is out of range.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        height_hack: bool = True,
        test_objects: bool = False,
        num_objects: int = 5,
        max_steps: int = 8,
        camera_random: float = 0.0,
        render_mode: str | None = None,
        action_repeat: int = 80,
        block_random: float = 0.3,
        width: int = 48,
        height: int = 48,
        is_discrete: bool = False,
        urdf_root: str | None = None,
        deterministic_pairs: bool = True,
        rebuild_every: int = 1,
        scene_cache: bool | SceneCache = True,
        scene_cache_dir: str | None = None,
        scene_cache_entries: int = DEFAULT_MAX_ENTRIES,
        skip_empty_lift: bool = True,
        lateral_dv: float | None = None,
        dark_after: int | None = None,
    ) -> None:
        check_options(
            num_objects=num_objects,
            max_steps=max_steps,
            action_repeat=action_repeat,
            width=width,
            height=height,
            rebuild_every=rebuild_every,
            scene_cache_entries=scene_cache_entries,
            dark_after=dark_after,
            scene_cache=scene_cache,
            skip_empty_lift=skip_empty_lift,
            camera_random=camera_random,
            block_random=block_random,
            render_mode=render_mode,
        )
        self.height_hack = bool(height_hack)
        self.test_objects = bool(test_objects)
        self.num_objects = int(num_objects)
        self.max_steps = int(max_steps)
        self.camera_random = float(camera_random)
        self.render_mode = render_mode
        self.action_repeat = int(action_repeat)
        self.block_random = float(block_random)
        self.width = int(width)
        self.height = int(height)
        self.is_discrete = bool(is_discrete)
        self.urdf_root = urdf_root if urdf_root is not None else pybullet_data.getDataPath()
        self._files = object_files(self.test_objects, self.urdf_root)
        if not self._files:
            raise ConfigError(f"no object URDFs found under {self.urdf_root!r}/random_urdfs")

        self.observation_space = spaces.Box(0, 255, (self.height, self.width, 3), dtype=np.uint8)
        self.action_space: spaces.Space[Any] = _action_space(self.is_discrete, self.height_hack)

        self.deterministic_pairs = bool(deterministic_pairs)
        self.rebuild_every = int(rebuild_every)
        self.skip_empty_lift = bool(skip_empty_lift)
        self.dark_after = None if dark_after is None else int(dark_after)
        self.lateral_dv = DV if lateral_dv is None else positive("lateral_dv", lateral_dv)
        self.grasps = 0
        self.lifts_skipped = 0
        self.lift_steps_skipped = 0
        self.scene_cache = _scene_cache(scene_cache, scene_cache_dir, scene_cache_entries)
        self._scene_settings = self._drop_settings()
        self._connected = False
        self._cid: int = -1
        self.worlds_built = 0
        self._build_world()
        self._init_episode_state()

    def _init_episode_state(self) -> None:
        """Before the first reset: no episode, no grasp, no camera."""
        self._ready = False
        self._attempted_grasp = False
        self._env_step = 0
        self.distance_at_grasp = float("nan")
        """Horizontal gripper-to-nearest-object distance (m) when the automatic grasp started
        (NaN before it): for a shaped *training* fitness only (``evaluation.distance_at``)."""
        self.gripper_xy_at_grasp = np.full(2, np.nan)
        """The end effector's table (x, y) (m) when the automatic grasp started (NaN before it):
        the robot's own pose, for the shaped training fitness' reach to a seen target."""
        self._view_matrix: Any = None
        self._proj_matrix: Any = None

    def _build_world(self) -> None:
        """Replace this instance's client by a fresh world: plane, table, arm and tray."""
        if self._connected and p.isConnected(self._cid):
            p.disconnect(self._cid)
        self._cid, self._arm = self._new_world()
        self._connected = True
        self._object_uids: list[int] = []
        self._fresh = True
        self._resets_in_world = 0
        self.worlds_built += 1

    def _new_world(self) -> tuple[int, KukaArm]:
        """Connect a new DIRECT client and load the plane, table, arm and tray, in the original's order."""
        cid = p.connect(p.DIRECT)
        p.setPhysicsEngineParameter(
            numSolverIterations=SOLVER_ITERATIONS,
            deterministicOverlappingPairs=int(self.deterministic_pairs),
            physicsClientId=cid,
        )
        p.setTimeStep(TIME_STEP, physicsClientId=cid)
        p.loadURDF(
            os.path.join(self.urdf_root, "plane.urdf"), basePosition=[0, 0, -1], physicsClientId=cid
        )
        p.loadURDF(
            os.path.join(self.urdf_root, "table/table.urdf"),
            basePosition=[0.5, 0.0, -0.82],
            baseOrientation=[0.0, 0.0, 0.0, 1.0],
            physicsClientId=cid,
        )
        p.setGravity(0, 0, GRAVITY, physicsClientId=cid)
        arm = KukaArm(cid, self.urdf_root)
        arm.load()
        return cid, arm

    def _drop_settings(self) -> dict[str, Any]:
        """Everything besides the objects and their poses that changes a settled scene."""
        try:
            version = importlib.metadata.version("pybullet")
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover - a source build
            version = f"api-{p.getAPIVersion()}"
        settings: dict[str, Any] = {
            "pybullet": version,
            "time_step": TIME_STEP,
            "solver_iterations": SOLVER_ITERATIONS,
            "gravity": GRAVITY,
            "settle_steps": SETTLE_STEPS,
            "drop_height": DROP_HEIGHT,
            "deterministic_pairs": self.deterministic_pairs,
            "arm": [
                list(kuka_arm.INITIAL_JOINT_POSITIONS),
                list(kuka_arm._BASE_POSITION),
                list(kuka_arm._BASE_ORIENTATION),
                list(kuka_arm._TRAY_POSITION),
                list(kuka_arm._TRAY_ORIENTATION),
                kuka_arm._MAX_FORCE,
            ],
        }
        if os.path.abspath(self.urdf_root) != os.path.abspath(pybullet_data.getDataPath()):
            settings["urdf_root"] = os.path.abspath(self.urdf_root)
        return settings

    # ------------------------------------------------------------------ Gymnasium API

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode: new camera jitter, new objects dropped one by one into the tray.

        Args:
            seed: Seeds ``self.np_random`` (Gymnasium convention).
            options: Not used; must be ``None`` or empty.

        Returns:
            The first image and ``{"proprio", "is_success": False}``.
        """
        super().reset(seed=seed)
        if options:
            raise EvodevoError(
                f"reset options {sorted(options)} are not supported; pass settings to the constructor"
            )
        self._require_open()
        pitch, yaw, fov, files, poses = self._draw(self.np_random)
        scene = None if self.scene_cache is None else self._settled_scene(files, poses, seed)

        if self.rebuild_every and self._resets_in_world >= self.rebuild_every:
            self._build_world()
        self._resets_in_world += 1
        cid = self._cid
        self._view_matrix = p.computeViewMatrixFromYawPitchRoll(
            [0.23, 0.2, 0.54], 1.0, yaw, pitch, 0, 2, physicsClientId=cid
        )
        self._proj_matrix = p.computeProjectionMatrixFOV(
            fov, self.width / self.height, 0.01, 10, physicsClientId=cid
        )
        self._attempted_grasp = False
        self._env_step = 0
        self.distance_at_grasp = float("nan")
        self.gripper_xy_at_grasp = np.full(2, np.nan)

        # Newest first: PyBullet reuses freed body ids last-in first-out, so the next objects get
        # the same ids (and the same solver order) as in a freshly built world.
        for uid in reversed(self._object_uids):
            p.removeBody(uid, physicsClientId=cid)
        self._object_uids = []
        if not self._fresh:
            self._arm.reset_state()
        self._fresh = False
        p.stepSimulation(physicsClientId=cid)
        settle = 0 if scene is not None else SETTLE_STEPS
        self._object_uids = drop_objects(cid, files, poses, settle)
        if scene is not None:
            place_scene(cid, self._object_uids, self._arm.uid, scene)
        self._ready = True
        return self._observation(), {"proprio": self._proprio(), "is_success": False}

    def scene_key(self, seed: int) -> dict[str, Any]:
        """The settled-scene cache key of ``reset(seed=seed)`` (no simulation, no state change)."""
        _, _, _, files, poses = self._draw(np_random(seed)[0])
        return self._key(files, poses)

    def _draw(
        self, rng: np.random.Generator
    ) -> tuple[float, float, float, list[str], list[tuple[float, float, float]]]:
        """Every draw of an episode, in the original's order: camera, object indices, poses."""
        cr = self.camera_random
        pitch = -56 + cr * rng.uniform(-3, 3)
        yaw = 245 + cr * rng.uniform(-3, 3)
        fov = 20.0 + cr * rng.uniform(-2, 2)
        chosen = rng.choice(len(self._files), self.num_objects)
        br = self.block_random
        poses = []
        for _ in chosen:
            x = 0.4 + br * rng.random()
            y = br * (rng.random() - 0.5)
            angle = math.pi / 2 + br * math.pi * rng.random()
            poses.append((x, y, angle))
        return pitch, yaw, fov, [self._files[int(i)] for i in chosen], poses

    def _key(self, files: list[str], poses: list[tuple[float, float, float]]) -> dict[str, Any]:
        rel = [os.path.relpath(f, self.urdf_root) for f in files]
        return scene_key(rel, np.asarray(poses, dtype=np.float64), self._scene_settings)

    def _settled_scene(
        self, files: list[str], poses: list[tuple[float, float, float]], seed: int | None
    ) -> SettledScene:
        """The settled scene of this drop: from the cache, or simulated in a scratch world.

        A miss drops and settles the objects exactly as a reset of a fresh world without the
        cache does, in a separate client (so this instance's world and its ``rebuild_every``
        bookkeeping are untouched), and keeps the result. Only seeded resets are stored: an
        unseeded drop is (almost surely) never seen again.
        """
        assert self.scene_cache is not None
        key = self._key(files, poses)
        if seed is not None:
            found = self.scene_cache.get(key)
            if found is not None:
                return found
        cid, arm = self._new_world()
        try:
            p.stepSimulation(physicsClientId=cid)
            uids = drop_objects(cid, files, poses, SETTLE_STEPS)
            rel = tuple(obj[0] for obj in key["objects"])
            scene = capture_scene(cid, uids, arm.uid, rel, poses, seed)
        finally:
            p.disconnect(cid)
        if seed is not None:
            self.scene_cache.put(key, scene)
        return scene

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Move the gripper; grasp automatically once it is low enough.

        Args:
            action: (dx, dy, d-angle) with the height hack, else (dx, dy, dz, d-angle), each in
                [−1, 1] (scaled by 0.06 m and 0.25 rad); an integer if ``is_discrete``.

        Returns:
            ``(obs, reward, terminated, truncated, info)``; reward 1.0 when an object is above
            0.2 m, ``terminated`` after the grasp, ``truncated`` at ``max_steps`` without one.

        Raises:
            EvodevoError: The action has the wrong shape, is not finite, or no episode is running.
        """
        self._require_open()
        if not self._ready:
            raise EvodevoError("step() called before reset(); call env.reset(seed=...) first")
        dx, dy, dz, da = self._parse_action(action)
        cid = self._cid
        arm = self._arm
        self._env_step += 1
        arm.apply_action(dx, dy, dz, da, OPEN_FINGER_ANGLE)
        last = self._env_step >= self.max_steps
        for _ in range(self.action_repeat):
            p.stepSimulation(physicsClientId=cid)
            # The original checks termination inside the loop: on the last step it stops at once.
            if last:
                break
        if arm.end_effector_position()[2] <= GRASP_HEIGHT:
            self._grasp()
        reward = self._reward()
        terminated = self._attempted_grasp
        truncated = (not terminated) and self._env_step >= self.max_steps
        info = {"proprio": self._proprio(), "is_success": reward == 1.0}
        return self._observation(), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """A ``RENDER_SIZE`` square RGB image from the observation camera (``"rgb_array"``)."""
        if self.render_mode != "rgb_array":
            return None
        self._require_open()
        if self._view_matrix is None:
            raise EvodevoError("render() called before reset(); call env.reset(seed=...) first")
        proj = p.computeProjectionMatrixFOV(20.0, 1.0, 0.01, 10, physicsClientId=self._cid)
        return self._camera(RENDER_SIZE, RENDER_SIZE, proj)

    def close(self) -> None:
        """Disconnect this instance's physics client (idempotent)."""
        if getattr(self, "_connected", False):
            self._connected = False
            if p.isConnected(self._cid):
                p.disconnect(self._cid)

    # ------------------------------------------------------------------ internals

    def _require_open(self) -> None:
        if not self._connected:
            raise EvodevoError("this KukaDiverseObjectEnv is closed; make a new one")

    def _parse_action(self, action: Any) -> tuple[float, float, float, float]:
        return parse_action(
            action, self.action_space, self.is_discrete, self.height_hack, self.lateral_dv
        )

    def _grasp(self) -> None:
        """Close the fingers for 500 steps, then lift for 500 (:func:`kuka_grasp.grasp`)."""
        self.distance_at_grasp = self.nearest_object_distance()
        self.gripper_xy_at_grasp = self.end_effector_xy()
        res = grasp(
            self._cid,
            self._arm,
            self._object_uids,
            skip_empty_lift=self.skip_empty_lift,
            success_height=SUCCESS_HEIGHT,
            gravity=GRAVITY,
        )
        self.grasps += 1
        self.lifts_skipped += int(res.skipped > 0)
        self.lift_steps_skipped += res.skipped
        self._attempted_grasp = True

    def end_effector_xy(self) -> np.ndarray:
        """The end effector's table (x, y) (m): the robot's own pose (forward kinematics)."""
        return np.asarray(self._arm.end_effector_position()[:2], dtype=np.float64)

    def nearest_object_distance(self) -> float:
        """Horizontal distance (m) from the end effector to the nearest object's base, read from
        the simulator: for a shaped *training* fitness only, never an observation."""
        ee = np.asarray(self._arm.end_effector_position()[:2])
        pos = [
            p.getBasePositionAndOrientation(u, physicsClientId=self._cid)[0]
            for u in self._object_uids
        ]
        return float(min(np.hypot(*(np.asarray(q[:2]) - ee)) for q in pos)) if pos else float("nan")

    def _reward(self) -> float:
        for uid in self._object_uids:
            pos, _ = p.getBasePositionAndOrientation(uid, physicsClientId=self._cid)
            if pos[2] > SUCCESS_HEIGHT:
                return 1.0
        return 0.0

    def _proprio(self) -> np.ndarray:
        x, y, z = self._arm.end_effector_position()
        raw = np.array([x, y, z, self._arm.finger_opening()], dtype=np.float64)
        scaled = (raw - PROPRIO_CENTRE) / PROPRIO_HALF_RANGE
        return np.clip(scaled, -PROPRIO_CLIP, PROPRIO_CLIP).astype(np.float32)

    def _observation(self) -> np.ndarray:
        if self.dark_after is not None and self._env_step >= self.dark_after:
            return np.zeros((self.height, self.width, 3), dtype=np.uint8)
        return self._camera(self.width, self.height, self._proj_matrix)

    def _camera(self, width: int, height: int, proj: Any) -> np.ndarray:
        img = p.getCameraImage(
            width=width,
            height=height,
            viewMatrix=self._view_matrix,
            projectionMatrix=proj,
            physicsClientId=self._cid,
        )[2]
        rgba = np.reshape(np.asarray(img, dtype=np.uint8), (height, width, 4))
        return np.ascontiguousarray(rgba[:, :, :3])

    def __del__(self) -> None:
        # At interpreter shutdown pybullet may already be torn down.
        with contextlib.suppress(Exception):
            self.close()
