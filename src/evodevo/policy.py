"""Load a trained controller and act with it in one environment (Stable-Baselines3-shaped).

:func:`load` reads any trained run directory -- a GRN run (plain, neuromodulated, blind, open
loop), a Kuka baseline run (PPO, TD3, NEAT) or a BIARM run (one column per task) -- and returns
a :class:`Policy`::

    policy = evodevo.load("runs/quick/grn/plain_s0")
    env = policy.make_env()
    obs, info = env.reset(seed=7)
    policy.reset(seed=7)
    action = policy.predict(obs, info)

``reset(seed=s)`` with the environment's reset seed ``s`` makes the episode the one
``evodevo grn evaluate`` runs with that seed (the GRN's noise stream is derived from it), so the
two give the same actions and rewards (a test checks it). The GRN policies go through the
evaluator's own pieces -- the run loader, the run's visual front-end (``encode``), the
controller kind's ``reset_state``/``step``, the sensor scaling and the action scaling -- so a new
front-end or controller kind works here without change. A BIARM column acts greedily with the
module states as training left them, as ``evaluate_column`` does.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

import evodevo.baselines  # noqa: F401  (registers the loader and controllers of Kuka baseline runs)
from evodevo.config import from_dict
from evodevo.errors import EvodevoError
from evodevo.grn.controller import make_policy
from evodevo.grn.env_interface import (
    action_dims,
    is_vector_observation,
    policy_vector_range,
    proprio_of,
    scale_actions,
    scale_observation,
)
from evodevo.grn.env_interface import make_env as make_grn_env
from evodevo.grn.evaluation import load_run
from evodevo.grn.evaluator import Episode
from evodevo.grn.frontends import encode
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.padding import check_fits
from evodevo.neuromod.tasks import make_env as make_task_env
from evodevo.neuromod.tasks import resolve_tasks
from evodevo.neuromod.trainer import load_agent
from evodevo.neuromod.variants import get_variant
from evodevo.runs import RunDir, read_json
from evodevo.seeding import derive

__all__ = ["Policy", "GrnPolicy", "BiarmPolicy", "load"]


class Policy(abc.ABC):
    """A trained controller acting in one environment at a time."""

    #: Gymnasium id of the environment the policy was trained for.
    env_id: str

    @abc.abstractmethod
    def make_env(self, **kwargs: Any) -> Any:
        """The environment the policy was trained for (``render_mode="rgb_array"`` for videos)."""

    @abc.abstractmethod
    def reset(self, seed: int | None = None) -> None:
        """Start a new episode (pass the environment's reset seed to reproduce an evaluation)."""

    @abc.abstractmethod
    def predict(
        self, obs: Any, info: dict[str, Any] | None = None, reward: float | None = None
    ) -> Any:
        """The action for observation ``obs`` (and its ``info``), ready for ``env.step``.

        Args:
            obs: the observation of ``env.reset`` or of the last ``env.step``.
            info: its info dict (the Kuka env's proprioception is in ``info["proprio"]``).
            reward: the reward the previous action earned; the neuromodulated GRN reads it
                (its reward-so-far signal), the other policies ignore it.
        """


# ---------------------------------------------------------------------------------------- GRN
class GrnPolicy(Policy):
    """A GRN genome (any controller kind) or a Kuka baseline, driven as ``grn evaluate`` does.

    Args:
        loaded: a run loaded by :func:`evodevo.grn.evaluation.load_run`.
    """

    def __init__(self, loaded: Any) -> None:
        self.run = loaded.run
        self.config = loaded.config
        self.kind = str(loaded.kind)
        self.genome = loaded.genome
        self.encoder = loaded.encoder
        self.env_id = str(self.config.env.id)
        env = make_grn_env(self.env_id, self.config.env.kwargs)
        try:
            self.observation_space: Any = env.observation_space
            self.action_space: Any = env.action_space
            n_actions = action_dims(env.action_space)
        finally:
            env.close()
        self.controller = make_policy(self.config, n_actions, None)
        self.vector = is_vector_observation(self.observation_space)
        self._episodes = 0
        self._state: Any = None

    def make_env(self, test_objects: bool = False, **kwargs: Any) -> Any:
        """The run's environment; ``test_objects=True`` for the Kuka env's held-out objects."""
        return make_grn_env(
            self.env_id, self.config.env.kwargs, test_objects=test_objects, **kwargs
        )

    def reset(self, seed: int | None = None) -> None:
        if seed is None:
            seed = derive(self.config.seed, 23, self._episodes)
        self._episodes += 1
        self._rng = np.random.default_rng(Episode(int(seed)).noise_seed)
        self._state = self.controller.reset_state([self.genome])
        self._use_encoder = bool(
            self.controller.uses_encoder and self.encoder is not None and not self.vector
        )
        self._fstate = (
            self.encoder.reset(1) if self._use_encoder and hasattr(self.encoder, "reset") else None
        )
        self._steps = 0

    def _sensors(self, obs: Any, info: dict[str, Any] | None) -> np.ndarray:
        n = int(self.config.sensors.n_proprio)
        if not self.vector:
            return proprio_of(info or {}, n)
        v = scale_observation(obs, self.observation_space, policy_vector_range(self.controller))
        if v.shape[0] != n:
            raise EvodevoError(f"the observation has {v.shape[0]} values; the policy expects {n}")
        return v

    def predict(
        self, obs: Any, info: dict[str, Any] | None = None, reward: float | None = None
    ) -> Any:
        if self._state is None:
            self.reset()
        observe = getattr(self.controller, "observe_reward", None)
        if observe is not None and self._steps > 0:
            if reward is None:
                raise EvodevoError(
                    f"the {self.kind} controller reads the reward: pass the previous step's "
                    "reward, policy.predict(obs, info, reward)"
                )
            observe(self._state, np.arange(1), np.array([float(reward)]))
        obs_b = np.asarray(obs)[None]
        prop_b = self._sensors(obs, info)[None]
        idx = np.arange(1)
        feats = (
            encode(self.encoder, obs_b, prop_b, self._fstate, idx) if self._use_encoder else None
        )
        if getattr(self.controller, "uses_image", False):  # e.g. an SB3 CNN policy
            feats = obs_b
        actions = self.controller.step(
            self._state, idx, feats, prop_b, [self._rng], np.array([False])
        )
        if not np.all(np.isfinite(actions)):
            raise EvodevoError("the controller produced non-finite actions")
        self._steps += 1
        return scale_actions(np.asarray(actions)[0], self.action_space)


# -------------------------------------------------------------------------------------- BIARM
class BiarmPolicy(Policy):
    """One column of a trained BIARM (or PNN, EWC, fine-tune) agent, acting greedily.

    Args:
        agent: the trained :class:`~evodevo.neuromod.agent.BiarmAgent`.
        specs: the run's task specs (one column per task).
        task: the column's index.
    """

    def __init__(self, agent: Any, specs: list[Any], task: int) -> None:
        if not 0 <= task < len(specs):
            raise EvodevoError(
                f"task {task} is not a column of this run; it has {len(specs)} "
                f"({', '.join(s.env_id for s in specs)})"
            )
        self.agent, self.specs, self.task = agent, specs, task
        self.spec = specs[task]
        self.env_id = str(self.spec.env_id)
        self._x = torch.zeros(1, agent.obs_dim)

    def column(self, task: int | str) -> BiarmPolicy:
        """The policy of another task's column (index or Gymnasium id)."""
        return BiarmPolicy(self.agent, self.specs, _task_index(self.specs, task))

    def make_env(self, **kwargs: Any) -> Any:
        """The column's task environment with the run's step limit."""
        if not kwargs:
            return make_task_env(self.env_id, self.spec.max_steps)
        steps = {} if self.spec.max_steps is None else {"max_episode_steps": self.spec.max_steps}
        return gym.make(self.env_id, **steps, **kwargs)

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset: a column's greedy action depends on the observation only."""

    def predict(
        self, obs: Any, info: dict[str, Any] | None = None, reward: float | None = None
    ) -> int:
        flat = np.asarray(obs, dtype=np.float32).reshape(-1)
        check_fits(flat.size, self.agent.obs_dim, self.env_id)
        row = self._x.numpy()[0]
        row[:] = 0.0
        row[: flat.size] = flat  # phi (Eq. 3.10), as evaluate_column pads
        return int(self.agent.greedy_q(self._x, self.task).argmax())


def _task_index(specs: list[Any], task: int | str) -> int:
    if isinstance(task, str) and not task.lstrip("-").isdigit():
        ids = [s.env_id for s in specs]
        if task not in ids:
            raise EvodevoError(f"task {task!r} is not in this run's tasks {ids}")
        return ids.index(task)
    return int(task)


# --------------------------------------------------------------------------------------- load
def load(
    run_dir: str | Path,
    task: int | str | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Policy:
    """The trained policy of a run directory.

    Args:
        run_dir: a run of ``grn evolve``, ``baselines kuka`` or ``biarm train`` (in a
            ``biarm compare`` folder: ``OUT/runs/VARIANT__sSEED``).
        task: BIARM only: the column, as an index or a Gymnasium id (``"CartPole-v1"``).
        overrides: GRN and Kuka-baseline runs only: what the policy is run on, ``evaluation.*``
            and ``env.*`` keys (``--set`` of a test; :func:`evodevo.grn.evaluation.test_overrides`).

    Raises:
        EvodevoError: the folder holds no run, a run of another kind, or no trained policy.
    """
    run = RunDir(run_dir, create=False)
    kind = run.read_config().get("kind")
    if kind == "biarm":
        if overrides:
            raise EvodevoError(
                "overrides (--set) apply to GRN and Kuka-baseline runs; a BIARM column is run "
                "on its task as trained"
            )
        return _load_biarm(run.path, task)
    if task is not None:
        raise EvodevoError(f"task= applies to BIARM runs; {str(run.path)!r} is a {kind!r} run")
    return GrnPolicy(load_run(run.path, overrides))


def _load_biarm(path: Path, task: int | str | None) -> BiarmPolicy:
    saved = dict(read_json(path / "config.json")["config"])
    variant = get_variant(str(saved.pop("variant")))
    saved.pop("seed", None)
    if variant.architecture == "sb3":
        raise EvodevoError(
            f"{str(path)!r} is a {variant.name} run (Stable-Baselines3 DQN per task); load a "
            "task's model with evodevo.baselines.policies.load_sb3('dqn', "
            "'<run>/checkpoints/sb3_task<i>.safetensors') instead"
        )
    specs, _ = resolve_tasks(from_dict(BiarmConfig, saved))
    if task is None:
        if len(specs) != 1:
            raise EvodevoError(
                f"a BIARM run has one column per task; choose one with task=0..{len(specs) - 1} "
                f"or an id ({', '.join(s.env_id for s in specs)})"
            )
        task = 0
    return BiarmPolicy(load_agent(path), specs, _task_index(specs, task))
