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

The episodes themselves run in :mod:`evodevo.grn.lockstep` (:func:`run_episodes`), which this
module re-exports with :class:`Episode` and :class:`EpisodeResults`.
"""

from __future__ import annotations

import hashlib
import itertools
import time
import uuid
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from evodevo.errors import EvodevoError
from evodevo.grn.config import GrnConfig
from evodevo.grn.controller import Factory, policy_factory
from evodevo.grn.encoder import Encoder
from evodevo.grn.env_interface import (
    action_dims,
    evaluator_env_kwargs,
    is_vector_observation,
    make_env,
    scale_observation,
)
from evodevo.grn.frontends import frontend_name
from evodevo.grn.lockstep import NOISE_KEY, Episode, EpisodeResults, run_episodes
from evodevo.parallel import make_pool

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
