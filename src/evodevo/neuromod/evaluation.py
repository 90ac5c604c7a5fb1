"""Greedy evaluation, retention and improvement (SPEC §1.7; Tables 3.2, 3.5).

Evaluation episode j of every column uses the seed ``eval.seed + j`` in every run, after the
task ("initial") and after the whole sequence ("final"). Module states are not updated during
evaluation (they are read as they are at that moment).

>>> retention(500.0, 500.0)
1.0
>>> round(retention(-88.2, -93.5), 3)
0.943
>>> round(improvement(-93.5, -94.5), 2)
1.06
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch

from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.tasks import TaskSpec, make_env

__all__ = [
    "evaluate_column",
    "greedy_returns",
    "task_record",
    "retention",
    "improvement",
    "eval_seeds",
]


def eval_seeds(first: int, episodes: int) -> list[int]:
    """The fixed evaluation seeds ``first, first+1, ...``."""
    return [first + j for j in range(episodes)]


def greedy_returns(
    task: TaskSpec, seeds: Sequence[int], act: Callable[[np.ndarray], int]
) -> list[float]:
    """Undiscounted returns of episodes of ``task`` in which ``act(observation)`` picks every
    action, one episode per reset seed (the rollout of every evaluation, SPEC §1.7)."""
    env = make_env(task.env_id, task.max_steps)
    returns = []
    try:
        for s in seeds:
            obs, _ = env.reset(seed=int(s))
            total = 0.0
            while True:
                obs, r, term, trunc, _ = env.step(act(obs))
                total += float(r)
                if term or trunc:
                    break
            returns.append(total)
    finally:
        env.close()
    return returns


def evaluate_column(agent: BiarmAgent, col: int, task: TaskSpec, seeds: list[int]) -> list[float]:
    """Undiscounted returns of greedy episodes of column ``col``, one per seed."""
    x = torch.zeros(1, agent.obs_dim)
    row = x.numpy()[0]
    n = task.obs_dim

    def act(obs: np.ndarray) -> int:
        row[:n] = np.asarray(obs, dtype=np.float32).reshape(-1)
        return int(agent.greedy_q(x, col).argmax())

    return greedy_returns(task, seeds, act)


def task_record(result: Mapping[str, Any], final: list[float]) -> dict[str, Any]:
    """A task's entry of ``summary.json``: its saved results with the mean initial and final
    greedy return, the retention of Table 3.5 and the final returns."""
    ini_mean = float(np.mean(result["eval_returns_initial"]))
    fin_mean = float(np.mean(final))
    return {
        **result,
        "initial_return": ini_mean,
        "final_return": fin_mean,
        "retention": retention(ini_mean, fin_mean),
        "eval_returns_final": final,
    }


def retention(initial: float, final: float) -> float:
    """Table 3.5 retention: ``final/initial`` if initial > 0, ``initial/final`` if both < 0.

    Equal values give 1.0; any other case (a sign change or a zero) is undefined: ``nan``.
    """
    if initial == final:
        return 1.0
    if initial > 0:
        return final / initial
    if initial < 0 and final < 0:
        return initial / final
    return math.nan


def improvement(biarm: float, pnn: float) -> float:
    """Table 3.2 improvement in percent: ``(BIARM - PNN) / |PNN| * 100`` (nan if PNN is 0)."""
    if pnn == 0:
        return math.nan
    return (biarm - pnn) / abs(pnn) * 100.0
