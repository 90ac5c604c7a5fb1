"""How the GRN evaluator talks to a Gymnasium environment (SPEC §2.2, §2.4, §2.6).

Making an env by id (``evodevo/`` ids and ``module:EnvName-v0`` ids import their module first),
reading a flat vector observation in place of the image, the proprioception of ``info``, the
controller's [-1, 1] actions mapped onto the env's Box, the keyword arguments the evaluator
makes its envs with, and the one simulator-side quantity the shaped *training* fitness reads
(:func:`grasp_distance`). The episode loop that uses them is
:func:`evodevo.grn.evaluator.run_episodes`.
"""

from __future__ import annotations

import importlib
from typing import Any

import gymnasium as gym
import numpy as np

from evodevo.errors import EvodevoError, env_module_error
from evodevo.grn.config import GrnConfig
from evodevo.safe_io import check_import

__all__ = [
    "make_env",
    "is_vector_observation",
    "scale_observation",
    "action_dims",
    "scale_actions",
    "proprio_of",
    "evaluator_env_kwargs",
    "grasp_distance",
    "policy_vector_range",
]


def make_env(env_id: str, kwargs: dict[str, Any] | None = None, **extra: Any) -> gym.Env[Any, Any]:
    """``gymnasium.make`` after importing ``evodevo.envs`` for ``evodevo/`` ids.

    ``test_objects=False`` is dropped (the Kuka env's default), so envs without held-out
    objects can be made by the same calls. An id ``"module:EnvName-v0"`` makes Gymnasium import
    ``module`` first (which registers the env; docs/extending.md); a module that cannot be
    imported is an :class:`EvodevoError` naming the id.
    """
    if extra.get("test_objects") is False:
        extra = {k: v for k, v in extra.items() if k != "test_objects"}
    if env_id.startswith("evodevo/"):
        try:
            importlib.import_module("evodevo.envs")
        except ImportError as exc:
            raise EvodevoError(
                f"environment {env_id!r} needs evodevo.envs, which failed to import ({exc}); "
                "install the kuka extra: pip install -e '.[kuka]'"
            ) from None
    check_import(env_id, "environment")
    try:
        return gym.make(env_id, **{**(kwargs or {}), **extra})
    except gym.error.Error as exc:
        raise EvodevoError(f"cannot make environment {env_id!r}: {exc}") from None
    except ImportError as exc:  # a "module:EnvName-v0" id whose module cannot be imported
        raise env_module_error(env_id, exc) from None
    except TypeError as exc:
        hint = (
            "; it has no held-out test objects: evaluate with --objects train"
            if extra.get("test_objects")
            else ""
        )
        raise EvodevoError(f"cannot make environment {env_id!r}: {exc}{hint}") from None


def is_vector_observation(space: gym.Space[Any]) -> bool:
    """True for a flat Box observation (fed to the GRN directly, without the encoder)."""
    return isinstance(space, gym.spaces.Box) and len(space.shape) == 1


def scale_observation(
    obs: np.ndarray, space: gym.spaces.Box, out_range: tuple[float, float]
) -> np.ndarray:
    """Map a vector observation's Box bounds linearly onto ``out_range``.

    Dimensions with infinite (or empty) bounds pass through unscaled.

    >>> box = gym.spaces.Box(np.array([-8.0, -np.inf]), np.array([8.0, np.inf]), dtype=np.float64)
    >>> scale_observation(np.array([4.0, 3.0]), box, (-1.0, 1.0)).tolist()
    [0.5, 3.0]
    """
    lo, hi = space.low.astype(np.float64), space.high.astype(np.float64)
    x = np.asarray(obs, dtype=np.float64).reshape(-1)
    finite = np.isfinite(lo) & np.isfinite(hi) & (hi > lo)
    a, b = out_range
    span = np.where(finite, hi - lo, 1.0)
    scaled = a + (x - np.where(finite, lo, 0.0)) * (b - a) / span
    return np.where(finite, scaled, x)


def action_dims(space: gym.Space[Any]) -> int:
    """Action dimensions of a flat Box space; anything else cannot be driven by a GRN."""
    if not isinstance(space, gym.spaces.Box) or len(space.shape) != 1:
        raise EvodevoError(
            f"the GRN drives a flat continuous Box action space; this environment has {space}. "
            "Use an environment with continuous actions (e.g. the Kuka env with its height hack)"
        )
    return int(space.shape[0])


def scale_actions(a: np.ndarray, space: gym.spaces.Box) -> np.ndarray:
    """Map actions in [-1, 1] to the Box bounds (identity for Box(-1, 1))."""
    lo, hi = space.low.astype(np.float64), space.high.astype(np.float64)
    if np.all(lo == -1.0) and np.all(hi == 1.0):
        return a.astype(space.dtype)
    return (lo + (a + 1.0) * 0.5 * (hi - lo)).astype(space.dtype)


def proprio_of(info: dict[str, Any], n: int) -> np.ndarray:
    p = info.get("proprio")
    if p is None:
        return np.zeros(n)
    p = np.asarray(p, dtype=np.float64).reshape(-1)
    if p.shape[0] != n:
        raise EvodevoError(f"info['proprio'] has {p.shape[0]} values; the controller expects {n}")
    return p


def evaluator_env_kwargs(config: GrnConfig) -> dict[str, Any]:
    """The keyword arguments the :class:`Evaluator` makes its environments with.

    ``config.env.kwargs``, plus ``skip_empty_lift=False`` for the Kuka port when the training
    fitness reads the gripper's end pose (``evaluation.distance_weight`` > 0 with
    ``evaluation.distance_at: end``) and the config does not choose: a skipped lift ends a
    failed grasp with the arm part of the way up, which moves :func:`grasp_distance` by
    centimetres (docs/kuka_env.md, "Skipped lift"). Outcomes are the same either way.
    """
    kwargs = dict(config.env.kwargs)
    evaluation = getattr(config, "evaluation", None)
    weight = float(getattr(evaluation, "distance_weight", 0.0) or 0.0)
    at_end = getattr(evaluation, "distance_at", "end") == "end"
    if config.env.id == "evodevo/KukaDiverseObject-v0" and weight > 0 and at_end:
        kwargs.setdefault("skip_empty_lift", False)
    return kwargs


def grasp_distance(
    env: gym.Env[Any, Any], at: str = "end", target: np.ndarray | None = None
) -> float:
    """Horizontal distance (m) from the gripper to the nearest object, or to ``target``.

    For the shaped *training* fitness only (SPEC §2.4, ``evaluation.distance_weight``). ``at``
    (``evaluation.distance_at``): ``"end"``, after the episode (the automatic grasp's lift
    included); ``"grasp"``, when the automatic grasp started (the reach itself, before the
    fingers and the lift move anything; an episode that ended without a grasp counts its end).
    Without ``target`` the distance is to the nearest object's base, read from the simulator
    (``evaluation.distance_to: nearest``); with it, to that table point (x, y) — the target the
    front-end saw (``distance_to: target``): only the robot's own pose is read. NaN when the env
    is not the Kuka port or the target has a NaN.
    """
    u: Any = env.unwrapped
    if target is not None:
        t = np.asarray(target, dtype=np.float64)
        xy = np.asarray(getattr(u, "gripper_xy_at_grasp", np.full(2, np.nan)), dtype=np.float64)
        if at != "grasp" or not np.all(np.isfinite(xy)):
            ee = getattr(u, "end_effector_xy", None)
            xy = np.full(2, np.nan) if ee is None else np.asarray(ee(), dtype=np.float64)
        return float(np.hypot(*(xy - t)))
    if at == "grasp":
        d = getattr(u, "distance_at_grasp", float("nan"))
        if np.isfinite(d):
            return float(d)
    nearest = getattr(u, "nearest_object_distance", None)
    return float("nan") if nearest is None else float(nearest())


def policy_vector_range(policy: Any) -> tuple[float, float]:
    sensors = getattr(getattr(policy, "config", None), "sensors", None)
    return tuple(sensors.vector_range) if sensors is not None else (-1.0, 1.0)  # type: ignore[return-value]
