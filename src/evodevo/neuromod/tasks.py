"""Task sequence resolution and input checks, all before training starts (SPEC §1, §1.1).

Any Gymnasium environment with a ``Box`` observation and a ``Discrete`` action space works;
anything else is an :class:`~evodevo.errors.EvodevoError` naming the value and what is accepted.

>>> from evodevo.neuromod.config import BiarmConfig, TaskConfig
>>> specs, d_max = resolve_tasks(BiarmConfig(tasks=[TaskConfig("CartPole-v1", 10, 50)]))
>>> specs[0].obs_dim, specs[0].n_actions, d_max
(4, 2, 4)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from evodevo.envs import CARTPOLE_ID
from evodevo.envs.env_ids import parse_env_id
from evodevo.errors import EvodevoError, env_module_error
from evodevo.neuromod.config import THESIS_TASKS, BiarmConfig, TaskConfig
from evodevo.neuromod.padding import check_fits
from evodevo.safe_io import check_import

__all__ = ["TaskSpec", "resolve_tasks", "make_env", "tasks_from_ids"]


@dataclass(frozen=True)
class TaskSpec:
    """A checked task: id, scaled episode count, step limit and space sizes."""

    env_id: str
    episodes: int
    max_steps: int | None
    obs_dim: int
    n_actions: int


def make_env(env_id: str, max_steps: int | None) -> gym.Env:
    """``gym.make`` with the task's step limit, or a one-line error for an unknown id.

    ``env_id`` may carry the environment's own parameters, ``ID[key=value,...]``
    (:mod:`evodevo.envs.env_ids`)."""
    base, params = parse_env_id(env_id)
    check_import(base, "environment")
    kwargs: dict[str, Any] = {} if max_steps is None else {"max_episode_steps": int(max_steps)}
    try:
        return gym.make(base, **params, **kwargs)
    except TypeError as exc:  # a parameter the environment does not take
        raise EvodevoError(
            f"environment {env_id!r}: {exc}; give only parameters that {base} takes"
        ) from None
    except gym.error.Error as exc:
        raise EvodevoError(
            f"unknown or unusable environment id {env_id!r} ({str(exc).splitlines()[0]}); "
            "give a registered Gymnasium id such as CartPole-v1"
        ) from None
    except ImportError as exc:  # a "module:EnvName-v0" id whose module cannot be imported
        raise env_module_error(env_id, exc) from None


def _spaces(env_id: str, env: gym.Env) -> tuple[int, int]:
    obs_space, act_space = env.observation_space, env.action_space
    if not isinstance(obs_space, gym.spaces.Box):
        raise EvodevoError(
            f"{env_id} has a {type(obs_space).__name__} observation space; "
            "only Box observations are accepted"
        )
    if not isinstance(act_space, gym.spaces.Discrete):
        raise EvodevoError(
            f"{env_id} has a {type(act_space).__name__} action space; "
            "only Discrete actions are accepted (DQN needs one Q-value per action)"
        )
    return int(np.prod(obs_space.shape)), int(act_space.n)


def tasks_from_ids(cfg: BiarmConfig, ids: list[str]) -> list[TaskConfig]:
    """Task configs for ``--tasks`` ids: the config's own entry, else the thesis table, else
    ``default_episodes`` with the environment's own step limit."""
    own = {t.env_id: t for t in cfg.tasks}
    thesis = {e: (n, m) for e, n, m in THESIS_TASKS}
    thesis[CARTPOLE_ID] = thesis["CartPole-v1"]  # the same task with other constants
    out = []
    for env_id in ids:
        base = parse_env_id(env_id)[0]
        if env_id in own:
            t = own[env_id]
            out.append(TaskConfig(t.env_id, t.episodes, t.max_steps))
        elif base in thesis:
            out.append(TaskConfig(env_id, *thesis[base]))
        else:
            out.append(TaskConfig(env_id, cfg.default_episodes, None))
    return out


def resolve_tasks(cfg: BiarmConfig) -> tuple[list[TaskSpec], int]:
    """Check every task's environment and return the specs and ``d_max`` (Eq. 3.10)."""
    if not (cfg.episodes_scale > 0 and math.isfinite(cfg.episodes_scale)):
        raise EvodevoError(
            f"episodes scale {cfg.episodes_scale} must be a positive number (e.g. 0.25)"
        )
    specs = []
    for t in cfg.tasks:
        env = make_env(t.env_id, t.max_steps)
        try:
            obs_dim, n_actions = _spaces(t.env_id, env)
        finally:
            env.close()
        specs.append(TaskSpec(t.env_id, cfg.scaled_episodes(t), t.max_steps, obs_dim, n_actions))
    largest = max(s.obs_dim for s in specs)
    d_max = cfg.network.d_max if cfg.network.d_max is not None else largest
    for s in specs:
        check_fits(s.obs_dim, d_max, s.env_id)
    return specs, d_max
