"""The forgetting measure of thesis Eq. 1.4 and the returns it needs (SPEC §1.7).

Eq. 1.4 (Chaudhry et al. 2018, thesis ref. [71]):

    F_i^(t) = max_{k in {1..t-1}} (Acc_{i,k} - Acc_{i,t})

where ``Acc_{i,k}`` is the performance on task i after training on task k. In reinforcement
learning "accuracy" is the mean greedy evaluation return (same fixed seeds as SPEC §1.7), so
``F`` is in return units: positive means the task got worse than it once was, 0 means no
forgetting, negative means it only got better. A task does not exist before it is trained (its
column or head is created with it), so the max runs over ``k = i..t-1``; we report
``t = T``, the end of the sequence, so the last task has no forgetting (``nan``).

The trainer calls :func:`record_returns_after` once at the end of every task but the last: it
evaluates every earlier task again, so each task's summary holds ``returns_after`` =
``[Acc_{i,i}, Acc_{i,i+1}, ..., Acc_{i,T-1}]`` (means over the evaluation episodes), and
``final_return`` is ``Acc_{i,T}``. Runs written before ``returns_after`` existed have only
``initial_return`` (``Acc_{i,i}``); for them :func:`forgetting` returns ``initial - final``,
a lower bound of Eq. 1.4.

>>> forgetting({"returns_after": [100.0, 180.0, 150.0], "final_return": 120.0})
60.0
>>> forgetting({"initial_return": -90.0, "final_return": -100.0})
10.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.evaluation import evaluate_column
from evodevo.neuromod.tasks import TaskSpec

__all__ = ["forgetting", "record_returns_after"]


def forgetting(task: Mapping[str, Any], last: bool = False) -> float:
    """Eq. 1.4 at the end of the sequence for one task's summary entry (``nan`` if ``last``)."""
    if last:
        return math.nan
    history = task.get("returns_after")
    if not history:
        history = [task["initial_return"]]
    return float(max(float(a) for a in history) - float(task["final_return"]))


def record_returns_after(
    agent: BiarmAgent,
    specs: Sequence[TaskSpec],
    index: int,
    results: list[dict[str, Any]],
    seeds: list[int],
) -> None:
    """After task ``index``: start its ``returns_after`` and extend every earlier task's.

    ``results[index]`` must already hold ``eval_returns_initial``. After the last task nothing
    is evaluated (the final evaluation is ``Acc_{i,T}``).
    """
    res = results[index]
    res["returns_after"] = [float(np.mean(res["eval_returns_initial"]))]
    if index == len(specs) - 1:
        return
    for j in range(index):
        returns = evaluate_column(agent, j, specs[j], seeds)
        # a run resumed from a checkpoint older than returns_after starts from Acc_{j,j}
        history = results[j].setdefault(
            "returns_after", [float(np.mean(results[j]["eval_returns_initial"]))]
        )
        history.append(float(np.mean(returns)))
