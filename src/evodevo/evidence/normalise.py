"""Returns normalised per task, and the equivalence margin δ (SPEC §6).

A return ``R`` on a task becomes ``(R - R_random) / (R_solved - R_random)``: 0 is a uniform
random policy, 1 is the task's solved threshold, so scores of different tasks can be pooled by
:mod:`evodevo.evidence.aggregate`. ``R_solved`` is Gymnasium's ``reward_threshold`` of the env
spec; ``R_random`` is the mean return of a uniform random policy, measured by
:func:`measure_random_return` (the stored numbers of the four default tasks say which command
produced them). The margin δ below which two learners count as equivalent is ±10 % of that span
for returns (0.1 on the normalised scale) and ±5 points for success rates.

>>> s = task_scale("CartPole-v1")
>>> s.solved_return, round(s.random_return, 2)
(475.0, 22.63)
>>> float(s.normalise(475.0)), round(s.delta, 2)
(1.0, 45.24)
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from evodevo.envs.env_ids import parse_env_id
from evodevo.errors import EvodevoError, env_module_error

__all__ = [
    "RANDOM_EPISODES",
    "RANDOM_FIRST_SEED",
    "RANDOM_RETURNS",
    "RANDOM_RETURNS_COMMAND",
    "RETURN_MARGIN_FRACTION",
    "SUCCESS_RATE_MARGIN",
    "TaskScale",
    "measure_random_return",
    "solved_return",
    "task_scale",
    "normalise_returns",
    "return_margin",
]

#: Episodes behind each stored random-policy return (SPEC §6: at least 100).
RANDOM_EPISODES = 1000
#: Episode ``i`` of the measurement resets the env and seeds the action space with this + i.
RANDOM_FIRST_SEED = 10_000

#: Mean return of a uniform random policy, measured by :func:`measure_random_return` with
#: ``RANDOM_EPISODES`` episodes on seeds ``RANDOM_FIRST_SEED..`` and each env's own step limit
#: (gymnasium 1.4.0, Box2D 2.3.10, numpy 2.4), by :data:`RANDOM_RETURNS_COMMAND`.
RANDOM_RETURNS: dict[str, float] = {
    "CartPole-v1": 22.629,
    "Acrobot-v1": -498.469,
    "MountainCar-v0": -200.0,
    "LunarLander-v3": -192.477,
}

#: The command that measured :data:`RANDOM_RETURNS`.
RANDOM_RETURNS_COMMAND = (
    "python -c 'from evodevo.evidence.normalise import measure_random_return as m; "
    '[print(e, round(m(e), 3)) for e in ("CartPole-v1", "Acrobot-v1", "MountainCar-v0", '
    '"LunarLander-v3")]\''
)

#: δ for returns: this fraction of the span from a random policy to the solved threshold.
RETURN_MARGIN_FRACTION = 0.10
#: δ for success rates, as a fraction (5 percentage points).
SUCCESS_RATE_MARGIN = 0.05


@dataclass(frozen=True)
class TaskScale:
    """The two anchors of one task's normalisation and the margin δ that follows from them.

    Attributes:
        env_id: Gymnasium id the anchors belong to.
        random_return: ``R_random``, mean return of a uniform random policy (score 0).
        solved_return: ``R_solved``, the solved threshold (score 1).
    """

    env_id: str
    random_return: float
    solved_return: float

    def __post_init__(self) -> None:
        if not self.solved_return > self.random_return:
            raise EvodevoError(
                f"{self.env_id}: the solved return {self.solved_return} must exceed the "
                f"random-policy return {self.random_return}; give anchors with R_solved > R_random"
            )

    @property
    def span(self) -> float:
        """``R_solved - R_random``."""
        return self.solved_return - self.random_return

    @property
    def delta(self) -> float:
        """δ of SPEC §6 in return units: ``RETURN_MARGIN_FRACTION * span``."""
        return RETURN_MARGIN_FRACTION * self.span

    def normalise(self, returns: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """``(R - R_random) / (R_solved - R_random)``; not clipped (above 1 is past solved)."""
        return (np.asarray(returns, dtype=float) - self.random_return) / self.span


def _make(env_id: str, max_steps: int | None) -> gym.Env:
    base, params = parse_env_id(env_id)  # ID[key=value,...]: the environment's own parameters
    kwargs: dict[str, Any] = {} if max_steps is None else {"max_episode_steps": int(max_steps)}
    try:
        env = gym.make(base, **params, **kwargs)
    except gym.error.Error as exc:
        raise EvodevoError(
            f"unknown or unusable environment id {env_id!r} ({str(exc).splitlines()[0]}); "
            "give a registered Gymnasium id such as CartPole-v1"
        ) from None
    except ImportError as exc:
        raise env_module_error(env_id, exc) from None
    if max_steps is None and (env.spec is None or env.spec.max_episode_steps is None):
        env.close()
        raise EvodevoError(
            f"{env_id} has no step limit, so a random episode may never end; pass max_steps"
        )
    return env


def measure_random_return(
    env_id: str,
    episodes: int = RANDOM_EPISODES,
    seed: int = RANDOM_FIRST_SEED,
    max_steps: int | None = None,
) -> float:
    """Mean return of a uniform random policy over ``episodes`` episodes.

    Episode ``i`` resets the env with ``seed + i`` and draws its actions from the action space
    seeded with ``seed + i``, so the number is reproducible and independent of global RNGs.

    Args:
        env_id: Gymnasium id.
        episodes: Number of episodes (SPEC §6 uses at least 100).
        seed: Seed of the first episode.
        max_steps: Step limit; ``None`` keeps the env's own.

    Returns:
        The mean undiscounted return.

    >>> measure_random_return("CartPole-v1", episodes=3, seed=0) == measure_random_return(
    ...     "CartPole-v1", episodes=3, seed=0)
    True
    """
    if episodes < 1:
        raise EvodevoError(f"episodes={episodes} must be at least 1")
    env = _make(env_id, max_steps)
    totals = np.empty(episodes)
    try:
        for i in range(episodes):
            env.reset(seed=seed + i)
            env.action_space.seed(seed + i)
            total, done = 0.0, False
            while not done:
                _, reward, terminated, truncated, _ = env.step(env.action_space.sample())
                total += float(reward)
                done = terminated or truncated
            totals[i] = total
    finally:
        env.close()
    return float(totals.mean())


@functools.lru_cache(maxsize=64)
def _measured(env_id: str, episodes: int, seed: int) -> float:
    """:func:`measure_random_return`, once per process for each task (tables ask per run)."""
    return measure_random_return(env_id, episodes, seed)


def solved_return(env_id: str) -> float:
    """Gymnasium's ``reward_threshold`` of ``env_id``'s spec.

    An id with parameters (``ID[key=value,...]``) has the threshold of its base id: the same
    task with other dynamics.

    >>> solved_return("MountainCar-v0")
    -110.0
    >>> solved_return("evodevo/CartPole-v1[length=1.0]")
    475.0
    """
    try:
        spec = gym.spec(parse_env_id(env_id)[0])
    except gym.error.Error as exc:
        raise EvodevoError(
            f"unknown environment id {env_id!r} ({str(exc).splitlines()[0]}); "
            "give a registered Gymnasium id, or pass solved_return yourself"
        ) from None
    if spec.reward_threshold is None:
        raise EvodevoError(
            f"{env_id} has no reward_threshold in its Gymnasium spec; pass solved_return yourself"
        )
    return float(spec.reward_threshold)


def task_scale(
    env_id: str,
    random_return: float | None = None,
    solved: float | None = None,
    episodes: int = RANDOM_EPISODES,
    seed: int = RANDOM_FIRST_SEED,
) -> TaskScale:
    """The :class:`TaskScale` of ``env_id``.

    Anchors given by the caller win; otherwise ``R_random`` comes from :data:`RANDOM_RETURNS`,
    or is measured now for a task not in the table (``episodes`` episodes from ``seed``), and
    ``R_solved`` from the env spec.
    """
    if random_return is None:
        random_return = RANDOM_RETURNS.get(env_id)
        if random_return is None:
            random_return = _measured(env_id, episodes, seed)
    return TaskScale(
        env_id, float(random_return), solved_return(env_id) if solved is None else float(solved)
    )


def normalise_returns(
    returns: Sequence[Sequence[float]] | np.ndarray, scales: Sequence[TaskScale]
) -> np.ndarray:
    """A ``runs x tasks`` matrix of returns, each column normalised by its task's scale.

    >>> scales = [TaskScale("a", 0.0, 10.0), TaskScale("b", -100.0, 0.0)]
    >>> normalise_returns([[5.0, -50.0], [10.0, 0.0]], scales).tolist()
    [[0.5, 0.5], [1.0, 1.0]]
    """
    r = np.asarray(returns, dtype=float)
    if r.ndim != 2 or r.shape[1] != len(scales):
        raise EvodevoError(
            f"returns of shape {r.shape} do not match {len(scales)} task scales; "
            "give a runs x tasks matrix with one column per scale"
        )
    return np.stack([s.normalise(r[:, j]) for j, s in enumerate(scales)], axis=1)


def return_margin(scale: TaskScale, normalised: bool = False) -> float:
    """δ for returns of a task: in return units, or 0.1 on the normalised scale.

    >>> return_margin(TaskScale("a", -200.0, -110.0))
    9.0
    """
    return RETURN_MARGIN_FRACTION if normalised else scale.delta
