"""Which network a task keeps when it is frozen: the best by greedy validation (SPEC §1.6).

Table 3.1 does not say which network ends a task. With ``dqn.keep: last`` (the ``v1``
protocol) the column is frozen as it is after the last training episode, wherever the
training instability left it. With ``dqn.keep: best`` the column is checked every
``eval.validation_every`` training episodes, and after the last one, by greedy episodes on the
validation seeds ``eval.validation_seed + j`` (``eval.validation_episodes`` of them), as
Stable-Baselines3's ``EvalCallback`` does; the task keeps the parameters of the check with the
highest mean return (the earliest on a tie). The validation seeds are disjoint from the
evaluation seeds of SPEC §1.7 (checked when the config loads), so selection never sees the
episodes that Tables 3.2-3.5 report.

Validation episodes are greedy, do not train, do not update the neuromodulator states and
draw nothing from the training streams, so they change no training number: a run with
``keep: best`` trains exactly as the same run with ``keep: last`` and differs only in the
parameters each column is frozen with.

>>> from evodevo.neuromod.config import BiarmConfig
>>> keeper = BestColumn(BiarmConfig(), episodes=100)
>>> [k for k in range(1, 101) if keeper.due(k)][:3], keeper.due(100)
([25, 50, 75], True)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch

from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.evaluation import eval_seeds, evaluate_column
from evodevo.neuromod.tasks import TaskSpec

__all__ = ["BestColumn", "VALIDATION_FIELDS"]

#: Columns of ``validation.csv`` (one row per check).
VALIDATION_FIELDS = ["task", "env_id", "episode", "step", "return", "best_return", "best_episode"]


class BestColumn:
    """The best parameters of the trainable column seen so far by validation return.

    Args:
        cfg: the run config (``eval.validation_*``).
        episodes: the task's training episodes (a check always follows the last one).
    """

    def __init__(self, cfg: BiarmConfig, episodes: int) -> None:
        self.seeds = eval_seeds(cfg.eval.validation_seed, cfg.eval.validation_episodes)
        self.every = cfg.eval.validation_every
        self.episodes = episodes
        self.best_return = -math.inf
        self.best_episode = -1
        self.best_state: dict[str, torch.Tensor] | None = None
        self.checks = 0

    def due(self, episodes_done: int) -> bool:
        """Whether a check follows training episode number ``episodes_done`` (1-based)."""
        return episodes_done % self.every == 0 or episodes_done == self.episodes

    def check(
        self, agent: BiarmAgent, index: int, spec: TaskSpec, episodes_done: int, step: int
    ) -> dict[str, Any]:
        """Validate the current column; keep its parameters when they beat the best so far.

        Returns the ``validation.csv`` row.
        """
        mean = float(np.mean(evaluate_column(agent, index, spec, self.seeds)))
        self.offer(mean, episodes_done, agent.net.current)
        return {
            "task": index,
            "env_id": spec.env_id,
            "episode": episodes_done,
            "step": step,
            "return": mean,
            "best_return": self.best_return,
            "best_episode": self.best_episode,
        }

    def offer(self, mean: float, episodes_done: int, module: torch.nn.Module) -> None:
        """Count one check of mean validation return ``mean``; keep a copy of ``module``'s
        parameters when it beats the best so far (the earliest wins a tie)."""
        if mean > self.best_return:
            self.best_return = mean
            self.best_episode = episodes_done
            self.best_state = {k: v.detach().clone() for k, v in module.state_dict().items()}
        self.checks += 1

    def restore(self, agent: BiarmAgent) -> dict[str, Any]:
        """Load the best parameters into the trainable column (before it is frozen).

        Returns what ``summary.json`` records of the selection.
        """
        return self.restore_into(agent.net.current)

    def restore_into(self, module: torch.nn.Module) -> dict[str, Any]:
        """Load the best parameters into ``module``; returns the ``summary.json`` record."""
        if self.best_state is not None:
            module.load_state_dict(self.best_state)
        return {
            "kept": "best",
            "best_episode": self.best_episode,
            "best_validation_return": self.best_return,
            "validation_checks": self.checks,
            "validation_seeds": [self.seeds[0], self.seeds[-1]],
        }

    def state(self) -> dict[str, Any]:
        """What a mid-task checkpoint needs to continue the selection."""
        return {
            "best_return": self.best_return,
            "best_episode": self.best_episode,
            "best_state": self.best_state,
            "checks": self.checks,
        }

    def load_state(self, data: dict[str, Any]) -> None:
        """Restore :meth:`state` output."""
        self.best_return = float(data["best_return"])
        self.best_episode = int(data["best_episode"])
        self.best_state = data["best_state"]
        self.checks = int(data["checks"])
