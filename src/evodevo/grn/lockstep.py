"""Episodes run in lockstep (SPEC §2.1–2.2): one encoder forward and one controller call per env
step for a whole batch of (genome, episode) pairs, each pair on its own environment.

:func:`run_episodes` is what every evaluation of a GRN (or any controller kind, or a reference
policy) comes down to; :class:`~evodevo.grn.evaluator.Evaluator` hands it batches, in this
process or in its workers. An episode is fully described by its env seed, its noisy flag and its
noise seed (:class:`Episode`), so its outcome is a pure function of (genome, episode), whatever
the batch it runs in.

>>> Episode(seed=3, noisy=False).noise_seed == Episode(seed=3, noisy=True).noise_seed
True
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

import gymnasium as gym
import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.env_interface import (
    grasp_distance,
    is_vector_observation,
    policy_vector_range,
    proprio_of,
    scale_actions,
    scale_observation,
)
from evodevo.grn.frontends import encode
from evodevo.seeding import derive

__all__ = ["Episode", "EpisodeResults", "run_episodes", "NOISE_KEY"]

NOISE_KEY = 7
"""Key of an episode's controller-noise stream under its env seed."""


@dataclass(frozen=True)
class Episode:
    """One episode: env reset seed, whether the visual features get noise, which objects."""

    seed: int
    noisy: bool = False
    test_objects: bool = False

    @property
    def noise_seed(self) -> int:
        """Seed of the controller's noise generator (the same for every genome: common numbers)."""
        return derive(self.seed, NOISE_KEY)


@dataclass
class EpisodeResults:
    """Per-episode outcomes, arrays of shape (genomes, episodes)."""

    reward: np.ndarray
    success: np.ndarray
    steps: np.ndarray
    wall_s: float = 0.0
    distance: np.ndarray | None = None
    """Gripper-to-nearest-object distance (m) at the end, when measured (training shaping)."""
    episodes_saved: int = 0
    """Episodes not run because their genome's identical twin ran them (``evaluation.dedupe``)."""

    @property
    def success_rate(self) -> np.ndarray:
        """Success rate per genome."""
        return np.asarray(self.success.mean(axis=1), dtype=float)

    @property
    def env_steps(self) -> int:
        return int(self.steps.sum())


@dataclass
class _Sensors:
    """The sensor vector of an observation: ``info["proprio"]``, or for a vector observation
    (``space`` given) the observation itself, its Box bounds mapped onto ``vrange``."""

    n_proprio: int
    space: gym.spaces.Box | None
    vrange: tuple[float, float]

    def __call__(self, o: Any, info: dict[str, Any]) -> np.ndarray:
        if self.space is None:
            return proprio_of(info, self.n_proprio)
        v = scale_observation(o, self.space, self.vrange)
        if v.shape[0] != self.n_proprio:
            raise EvodevoError(
                f"the observation has {v.shape[0]} values; the controller expects "
                f"{self.n_proprio} (set sensors.n_visual: 0 and sensors.n_proprio: {v.shape[0]})"
            )
        return v


@dataclass
class _Lockstep:
    """B episodes stepped together: the last observations and sensors, and the outcomes."""

    obs: np.ndarray
    prop: np.ndarray
    reward: np.ndarray
    success: np.ndarray
    steps: np.ndarray
    active: np.ndarray
    distance: np.ndarray

    @classmethod
    def reset(
        cls, envs: Sequence[gym.Env[Any, Any]], episodes: Sequence[Episode], sensors: _Sensors
    ) -> _Lockstep:
        """Reset ``envs[b]`` with episode b's seed, in slot order."""
        obs, prop = [], []
        for b, ep in enumerate(episodes):
            o, info = envs[b].reset(seed=int(ep.seed))
            obs.append(o)
            prop.append(sensors(o, info))
        n = len(episodes)
        return cls(
            np.stack(obs),
            np.stack(prop),
            reward=np.zeros(n),
            success=np.zeros(n, dtype=bool),
            steps=np.zeros(n, dtype=int),
            active=np.ones(n, dtype=bool),
            distance=np.full(n, np.nan),
        )


@dataclass
class _Frontend:
    """The visual front-end in one :func:`run_episodes` call."""

    encoder: Any
    feeds: bool
    """Its features reach the policy."""
    runs: bool
    """It runs: its features are read, or its target is (``distance_to: target``)."""
    to_target: bool
    state: Any
    """Its per-episode state (e.g. the blob localiser's first frame), or None."""

    @classmethod
    def start(cls, encoder: Any, policy: Any, vector: bool, n_b: int, to_target: bool) -> _Frontend:
        feeds = policy.uses_encoder and encoder is not None and not vector
        if to_target and not hasattr(encoder, "seen_target"):
            raise EvodevoError(
                "evaluation.distance_to=target needs a front-end that localises a target "
                f"(sensors.encoder: blob); this run's front-end is {type(encoder).__name__}"
            )
        runs = (feeds or to_target) and encoder is not None and not vector
        state = encoder.reset(n_b) if runs and hasattr(encoder, "reset") else None
        return cls(encoder, feeds, runs, to_target, state)

    def features(self, policy: Any, batch: _Lockstep, idx: np.ndarray) -> Any:
        """What the policy reads besides the sensors for the active slots ``idx``."""
        feats = None
        if self.runs:
            feats = encode(self.encoder, batch.obs[idx], batch.prop[idx], self.state, idx)
        if not self.feeds:
            feats = None
        if getattr(policy, "uses_image", False):  # e.g. an SB3 CNN policy: the raw observations
            feats = batch.obs[idx]
        return feats

    def distance(self, env: gym.Env[Any, Any], slot: int, at: str) -> float:
        """Gripper-to-object distance of the episode in ``slot``, just ended (training shaping)."""
        target = self.encoder.seen_target(self.state, slot) if self.to_target else None
        return grasp_distance(env, at, target)


def run_episodes(
    envs: Sequence[gym.Env[Any, Any]],
    encoder: Any,
    policy: Any,
    genomes: Sequence[Any],
    episodes: Sequence[Episode],
    n_proprio: int = 4,
    record: bool = False,
    vector_range: tuple[float, float] | None = None,
    measure_distance: bool = False,
    distance_at: str = "end",
    distance_to: str = "nearest",
) -> dict[str, Any]:
    """Run ``len(episodes)`` episodes in lockstep, slot b driving ``envs[b]`` with ``genomes[b]``.

    Args:
        vector_range: for vector-observation envs, the range the observation is scaled to
            (default: the policy's ``config.sensors.vector_range``, else [-1, 1]).
        measure_distance: also return ``distance``, the gripper-to-nearest-object distance at
            each episode's end (:func:`grasp_distance`; training shaping only).
        distance_at: when that distance is read (:func:`grasp_distance`'s ``at``).
        distance_to: ``"nearest"`` object, or the ``"target"`` the front-end localised (its
            ``seen_target``; the front-end then runs even for a policy that does not read it,
            e.g. the blind control, so both are trained on the same signal).

    Returns:
        ``{"reward", "success", "steps"}`` arrays of length B, and with ``record`` the per-step
        expression ``x`` (list of (B, n) arrays, when the policy has one), modulator states
        ``m`` (when the policy has them), ``actions`` and ``frames`` (observations) for figures.
    """
    n_b = len(episodes)
    if len(envs) < n_b or len(genomes) != n_b:
        raise ValueError("run_episodes needs one env and one genome per episode")
    space = getattr(envs[0], "observation_space", None)  # proxies (recording) may lack it
    vector = space is not None and is_vector_observation(space)
    vrange = vector_range if vector_range is not None else policy_vector_range(policy)
    sensors = _Sensors(n_proprio, cast(gym.spaces.Box, space) if vector else None, vrange)
    observe = getattr(policy, "observe_reward", None)
    batch = _Lockstep.reset(envs, episodes, sensors)
    rngs = [np.random.default_rng(ep.noise_seed) for ep in episodes]
    noisy = np.array([ep.noisy for ep in episodes])
    state = policy.reset_state(list(genomes))
    to_target = measure_distance and distance_to == "target"
    frontend = _Frontend.start(encoder, policy, vector, n_b, to_target)
    trace: dict[str, list[Any]] = {"x": [], "m": [], "actions": [], "frames": []}
    if record:
        trace["frames"].append(batch.obs.copy())
    while batch.active.any():
        idx = np.flatnonzero(batch.active)
        feats = frontend.features(policy, batch, idx)
        actions = policy.step(
            state, idx, feats, batch.prop[idx], [rngs[i] for i in idx], noisy[idx]
        )
        if not np.all(np.isfinite(actions)):
            raise EvodevoError("the controller produced non-finite actions")
        at = distance_at if measure_distance else None
        step_r = _step_envs(envs, batch, idx, actions, sensors, frontend, at)
        if observe is not None:
            observe(state, idx, step_r)
        if record:
            _record_step(trace, state, actions, batch.obs)
    out: dict[str, Any] = {"reward": batch.reward, "success": batch.success, "steps": batch.steps}
    if measure_distance:
        out["distance"] = batch.distance
    if record:
        out.update(trace)
    return out


def _step_envs(
    envs: Sequence[gym.Env[Any, Any]],
    batch: _Lockstep,
    idx: np.ndarray,
    actions: np.ndarray,
    sensors: _Sensors,
    frontend: _Frontend,
    distance_at: str | None,
) -> np.ndarray:
    """Step the active slots ``idx`` with their actions, in slot order; returns their rewards.

    An episode that ends is marked inactive, with its success and, unless ``distance_at`` is
    None, its gripper-to-object distance.
    """
    step_r = np.zeros(len(idx))
    for j, slot in enumerate(idx.tolist()):
        env = envs[slot]
        box = cast(gym.spaces.Box, env.action_space)
        o, r, term, trunc, info = env.step(scale_actions(actions[j], box))
        batch.obs[slot] = o
        batch.prop[slot] = sensors(o, info)
        step_r[j] = float(r)
        batch.reward[slot] += float(r)
        batch.steps[slot] += 1
        if term or trunc:
            batch.active[slot] = False
            batch.success[slot] = bool(info.get("is_success", float(r) > 0))
            if distance_at is not None:
                batch.distance[slot] = frontend.distance(env, slot, distance_at)
    return step_r


def _record_step(
    trace: dict[str, list[Any]], state: Any, actions: np.ndarray, obs: np.ndarray
) -> None:
    """Append one step to the figures' trace: expression, modulators, actions, frames."""
    for key in ("x", "m"):
        if hasattr(state, key):
            trace[key].append(np.array(getattr(state, key), copy=True))
    trace["actions"].append(np.array(actions, copy=True))
    trace["frames"].append(obs.copy())
