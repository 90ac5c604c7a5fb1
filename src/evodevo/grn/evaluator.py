"""The evaluator (the *problem*, separate from the optimiser): genomes × episodes → rewards.

:meth:`Evaluator.evaluate` runs every (genome, episode) pair and returns per-episode reward,
success and step count. With ``workers == 1`` everything runs in this process; with more, over
an :class:`evodevo.parallel.WorkerPool` whose initializer builds each worker's encoder once; a
worker keeps its environments and reuses them for every task. Inside a task the worker steps up
to ``evaluation.lockstep`` episodes together: one encoder forward and one controller call per
env step for all of them.

Results never depend on the number of workers or on the lockstep grouping: every episode is
fully described by its env seed, its noisy flag and its noise seed (the controller's noise
generator for that (genome, episode) pair, seeded from the episode alone and made afresh for
every pair), all derived from the run seed by the caller. An episode's outcome is therefore a
pure function of (genome, episode), and identical genomes of one :meth:`Evaluator.evaluate` call
(an elite and its unmutated child) are run once, their results copied to the twins
(``evaluation.dedupe``, :func:`genome_key`); ``EpisodeResults.episodes_saved`` counts the copies.

Any Gymnasium env with a flat Box action space can be driven. With an image observation the
encoder turns it into features and ``info["proprio"]`` supplies the proprioceptive values
(SPEC §2.2); with a flat Box observation (e.g. ``Pendulum-v1``) the encoder is skipped and the
observation itself, its Box bounds mapped onto ``sensors.vector_range``, takes the place of the
proprioceptive values (configure ``sensors.n_visual: 0`` and ``sensors.n_proprio`` = its size).
A policy that defines ``observe_reward(state, idx, rewards)`` is told each step's rewards after
the env steps (the neuromodulated GRN's reward-so-far signal, SPEC §5).

>>> Episode(seed=3, noisy=False).noise_seed == Episode(seed=3, noisy=True).noise_seed
True
"""

from __future__ import annotations

import hashlib
import itertools
import time
import uuid
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import gymnasium as gym
import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import Factory, policy_factory
from evodevo.grn.encoder import Encoder
from evodevo.grn.env_interface import (
    action_dims,
    evaluator_env_kwargs,
    grasp_distance,
    is_vector_observation,
    make_env,
    policy_vector_range,
    proprio_of,
    scale_actions,
    scale_observation,
)
from evodevo.grn.frontends import encode, frontend_name
from evodevo.parallel import make_pool
from evodevo.seeding import derive

__all__ = [
    "Episode",
    "EpisodeResults",
    "Evaluator",
    "make_env",
    "evaluator_env_kwargs",
    "genome_key",
    "action_dims",
    "is_vector_observation",
    "scale_observation",
    "run_episodes",
    "NOISE_KEY",
]

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


@dataclass
class _WorkerContext:
    env_id: str
    env_kwargs: dict[str, Any]
    encoder: Any
    envs: dict[bool, list[gym.Env[Any, Any]]] = field(default_factory=dict)
    policies: dict[str, Any] = field(default_factory=dict)

    def get_envs(self, test_objects: bool, n: int) -> list[gym.Env[Any, Any]]:
        pool = self.envs.setdefault(test_objects, [])
        # only the Kuka env knows test_objects; False is its default, so other envs work too
        extra = {"test_objects": True} if test_objects else {}
        while len(pool) < n:
            pool.append(make_env(self.env_id, self.env_kwargs, **extra))
        return pool[:n]

    def close(self) -> None:
        for pool in self.envs.values():
            for env in pool:
                env.close()
        self.envs.clear()


_CONTEXTS: dict[str, _WorkerContext] = {}


def _init_worker(key: str, env_id: str, env_kwargs: dict[str, Any], encoder_state: Any) -> None:
    """Worker initializer: build the front-end once; environments are made on first use.

    ``encoder_state`` is the CNN's weights (a dict), another front-end object (picklable, e.g.
    the blob localiser with its calibration), or None.
    """
    encoder = Encoder(encoder_state) if isinstance(encoder_state, dict) else encoder_state
    _CONTEXTS[key] = _WorkerContext(env_id, dict(env_kwargs), encoder)


@dataclass
class _Task:
    key: str
    policy_key: str
    config: GrnConfig
    n_actions: int
    factory: Factory  # the controller's or reference policy's, pickled by reference
    genomes: list[Any]
    episodes: list[Episode]
    measure_distance: bool = False


def _run_task(task: _Task) -> dict[str, np.ndarray]:
    ctx = _CONTEXTS.get(task.key)
    if ctx is None:  # pragma: no cover - the pool always runs the initializer first
        raise EvodevoError("worker was not initialised for this evaluator")
    policy = ctx.policies.get(task.policy_key)
    if policy is None:
        policy = task.factory(task.config, task.n_actions)
        ctx.policies[task.policy_key] = policy
    by_objects: dict[bool, list[int]] = {}
    for i, ep in enumerate(task.episodes):
        by_objects.setdefault(ep.test_objects, []).append(i)
    n = len(task.episodes)
    out = {"reward": np.zeros(n), "success": np.zeros(n, bool), "steps": np.zeros(n, int)}
    if task.measure_distance:
        out["distance"] = np.full(n, np.nan)
    for test_objects, ids in by_objects.items():
        envs = ctx.get_envs(test_objects, len(ids))
        res = run_episodes(
            envs,
            ctx.encoder,
            policy,
            [task.genomes[i] for i in ids],
            [task.episodes[i] for i in ids],
            n_proprio=task.config.sensors.n_proprio,
            measure_distance=task.measure_distance,
            distance_at=getattr(task.config.evaluation, "distance_at", "end"),
            distance_to=getattr(task.config.evaluation, "distance_to", "nearest"),
        )
        for k in out:
            out[k][ids] = res[k]
    return out


def _check_sensors(config: GrnConfig, space: gym.Space[Any]) -> None:
    """A vector observation replaces the sensors: n_visual must be 0, n_proprio its size."""
    if not is_vector_observation(space):
        return
    dim, sens = int(space.shape[0]), config.sensors  # type: ignore[index]
    if sens.n_visual != 0 or sens.n_proprio != dim:
        raise EvodevoError(
            f"environment {config.env.id!r} has a {dim}-d vector observation, which is the "
            f"sensor vector; set sensors.n_visual: 0 and sensors.n_proprio: {dim} "
            f"(now {sens.n_visual} and {sens.n_proprio})"
        )


def _check_frontend(config: GrnConfig, encoder: Any, space: gym.Space[Any]) -> None:
    """Before any episode: the front-end is the config's and can read this observation."""
    if encoder is None or is_vector_observation(space):
        return
    want, have = config.sensors.encoder, frontend_name(encoder)
    if want != have:
        raise EvodevoError(
            f"the config asks for the visual front-end {want!r} but the evaluator was given "
            f"{have!r}; a run's genomes only run with the front-end they were evolved with"
        )
    check = getattr(encoder, "check_images", None)
    if check is not None and space.shape is not None:
        check(np.zeros((1, *space.shape), dtype=space.dtype))


def genome_key(genome: Any) -> Hashable | None:
    """What decides a genome's behaviour, for finding identical twins; None: never deduplicated.

    A genome may define ``behaviour_key()`` (e.g. a NEAT network, whose JSON also holds
    its id); otherwise the key is its type and the bytes, dtypes and shapes of its ``arrays()``;
    a genome without arrays counts by equality if it is hashable (e.g. an SB3 model reference),
    and None (a baseline's placeholder) is one genome.

    >>> import numpy as np
    >>> from evodevo.grn.open_loop import OpenLoopGenome
    >>> a, b = OpenLoopGenome(np.zeros((2, 3))), OpenLoopGenome(np.zeros((2, 3)))
    >>> genome_key(a) == genome_key(b), genome_key(a) == genome_key(OpenLoopGenome(np.ones((2, 3))))
    (True, False)
    """
    if genome is None:
        return ("None",)
    kind = f"{type(genome).__module__}.{type(genome).__qualname__}"
    own = getattr(genome, "behaviour_key", None)
    if callable(own):
        return (kind, own())
    arrays = genome.arrays() if hasattr(genome, "arrays") else {}
    if arrays:
        h = hashlib.blake2b(digest_size=20)
        for name in sorted(arrays):
            a = np.ascontiguousarray(arrays[name])
            h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
            h.update(a.tobytes())
        return (kind, h.hexdigest())
    try:
        hash(genome)
    except TypeError:
        return None
    return (kind, genome)


def _twins(genomes: Sequence[Any]) -> list[int]:
    """For each genome, the index of its first identical genome (itself if none before it)."""
    first: dict[Hashable, int] = {}
    rep = []
    for i, g in enumerate(genomes):
        key = genome_key(g)
        rep.append(i if key is None else first.setdefault(key, i))
    return rep


def _shape_key(genome: Any) -> tuple[Any, ...]:
    if genome is None:
        return ()
    arrays = genome.arrays() if hasattr(genome, "arrays") else {}
    return tuple((k, v.shape) for k, v in sorted(arrays.items()))


class Evaluator:
    """Scores genomes on episodes, in-process or over worker processes.

    Args:
        config: the run's :class:`~evodevo.grn.config.GrnConfig`.
        encoder: the run's encoder (None for policies that do not look).
        workers: worker processes; 1 runs in this process.
        max_retries: resubmissions of a task whose worker died.

    Use as a context manager, or call :meth:`close`.
    """

    def __init__(
        self,
        config: GrnConfig,
        encoder: Any,
        workers: int = 1,
        max_retries: int = 1,
        backend: str = "local",
        address: str | None = None,
    ) -> None:
        self.config = config
        self.key = uuid.uuid4().hex
        env_kwargs = evaluator_env_kwargs(config)
        probe = make_env(config.env.id, env_kwargs)
        try:
            self.action_space = probe.action_space
            self.n_actions = action_dims(probe.action_space)
            _check_sensors(config, probe.observation_space)
            _check_frontend(config, encoder, probe.observation_space)
        finally:
            probe.close()
        state: Any = encoder
        if isinstance(encoder, Encoder):
            state = {k: v.clone() for k, v in encoder.weights().items()}
        # backend "local": in-process or a process pool; "ray": Ray actors. Either
        # way each worker builds its environments once and the results are the same.
        self.pool = make_pool(
            backend,
            workers,
            initializer=_init_worker,
            initargs=(self.key, config.env.id, env_kwargs, state),
            max_retries=max_retries,
            address=address,
        )
        self.episodes_run = 0
        """Episodes run (not counting the twins' copies)."""
        self.env_steps = 0
        self.episodes_saved = 0
        """Episodes copied from an identical genome instead of run (``evaluation.dedupe``)."""
        self._policy_counter = itertools.count()

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Shut the workers down and close this process' environments."""
        self.pool.close()
        ctx = _CONTEXTS.pop(self.key, None)
        if ctx is not None:
            ctx.close()

    def evaluate(
        self,
        genomes: Sequence[Any],
        episodes: Sequence[Episode],
        config: GrnConfig | None = None,
        baseline: str | None = None,
        measure_distance: bool = False,
    ) -> EpisodeResults:
        """Run every genome on every episode.

        Args:
            genomes: genomes of the controller kind of ``config`` (ignored entries for baselines).
            episodes: the episodes, the same for every genome.
            config: a config overriding the evaluator's (e.g. an ablation without noise).
            baseline: a trivial policy of BASELINES ("zero", "random", "turn") to run instead
                (genomes may be [None]).
            measure_distance: also measure the gripper-to-object distance at each episode's end
                (``EpisodeResults.distance``; the shaped training fitness).

        Returns:
            (len(genomes), len(episodes)) arrays. With ``evaluation.dedupe`` (the default) each
            distinct genome (:func:`genome_key`) is run once and its rows copied to its twins.
        """
        cfg = config if config is not None else self.config
        rep = list(range(len(genomes)))
        if getattr(cfg.evaluation, "dedupe", True) and len(genomes) > 1:
            rep = _twins(genomes)
        distinct = sorted(set(rep))
        if len(distinct) < len(genomes):
            res = self._evaluate(
                [genomes[i] for i in distinct], episodes, cfg, baseline, measure_distance
            )
            rows = np.searchsorted(distinct, rep)
            out = EpisodeResults(
                res.reward[rows],
                res.success[rows],
                res.steps[rows],
                wall_s=res.wall_s,
                distance=None if res.distance is None else res.distance[rows],
                episodes_saved=(len(genomes) - len(distinct)) * len(episodes),
            )
            self.episodes_saved += out.episodes_saved
            return out
        return self._evaluate(genomes, episodes, cfg, baseline, measure_distance)

    def _evaluate(
        self,
        genomes: Sequence[Any],
        episodes: Sequence[Episode],
        cfg: GrnConfig,
        baseline: str | None,
        measure_distance: bool,
    ) -> EpisodeResults:
        """Run every (genome, episode) pair, ``lockstep`` pairs per task."""
        policy_key = f"{baseline}|{cfg!r}"
        factory = policy_factory(cfg, baseline)  # resolved here: workers import nothing by name
        lockstep = cfg.evaluation.lockstep
        items = [(g, e) for g in range(len(genomes)) for e in range(len(episodes))]
        tasks: list[_Task] = []
        chunks: list[list[tuple[int, int]]] = []
        current: list[tuple[int, int]] = []
        for item in items:
            if current and (
                len(current) >= lockstep
                or _shape_key(genomes[current[0][0]]) != _shape_key(genomes[item[0]])
            ):
                chunks.append(current)
                current = []
            current.append(item)
        if current:
            chunks.append(current)
        for chunk in chunks:
            tasks.append(
                _Task(
                    self.key,
                    policy_key,
                    cfg,
                    self.n_actions,
                    factory,
                    [genomes[g] for g, _ in chunk],
                    [episodes[e] for _, e in chunk],
                    measure_distance,
                )
            )
        t0 = time.perf_counter()
        results = self.pool.map(_run_task, tasks)
        shape = (len(genomes), len(episodes))
        out = EpisodeResults(np.zeros(shape), np.zeros(shape, bool), np.zeros(shape, int))
        if measure_distance:
            out.distance = np.full(shape, np.nan)
        for chunk, res in zip(chunks, results, strict=True):
            for j, (g, e) in enumerate(chunk):
                out.reward[g, e] = res["reward"][j]
                out.success[g, e] = res["success"][j]
                out.steps[g, e] = res["steps"][j]
                if out.distance is not None:
                    out.distance[g, e] = res["distance"][j]
        out.wall_s = time.perf_counter() - t0
        self.episodes_run += out.reward.size
        self.env_steps += out.env_steps
        return out
