"""Per-run scores of a BIARM grid (table_run_scores.csv): what E3 and E4 compare."""

from __future__ import annotations

import pytest

from evodevo.evidence.normalise import task_scale
from evodevo.neuromod.continual_metrics import RunMetrics, TaskMetrics
from evodevo.neuromod.run_scores import COLUMNS, run_scores, run_scores_csv

TASKS = ["CartPole-v1", "Acrobot-v1", "MountainCar-v0", "LunarLander-v3"]


def _summary(finals: list[float]) -> dict:
    return {"tasks": [{"env_id": t, "final_return": f} for t, f in zip(TASKS, finals, strict=True)]}


def _task(i: int, ft: float | None) -> TaskMetrics:
    return TaskMetrics(i, TASKS[i], 10, 0.0, 0.5, 0.0, 0.0, None, None, None, ft)


def test_iqm_of_normalised_finals_and_transfer_after_the_first_task():
    solved = [task_scale(t).solved_return for t in TASKS]
    rand = [task_scale(t).random_return for t in TASKS]
    # normalised finals 1.0, 0.5, 0.0, 0.25 -> IQM = mean of the middle two (0.25, 0.5)
    finals = [r + f * (s - r) for r, s, f in zip(rand, solved, (1.0, 0.5, 0.0, 0.25), strict=True)]
    runs = {"biarm": {3: _summary(finals)}}
    m = RunMetrics(
        "biarm", 3, "x", (1,), tuple(_task(i, ft) for i, ft in enumerate((None, 0.2, 0.4, 0.0)))
    )
    (row,) = run_scores(runs, {"biarm": {3: m}})
    assert row["final_normalised_iqm"] == pytest.approx(0.375)
    assert row["final_normalised_mean"] == pytest.approx(0.4375)
    assert row["forward_transfer_after_first"] == pytest.approx(0.2)  # tasks 2-4 only
    assert row["auc_normalised_mean"] == pytest.approx(0.5)
    text = run_scores_csv([row])
    assert text.splitlines()[0] == ",".join(COLUMNS) and text.splitlines()[1].startswith(
        "biarm,3,0.375"
    )


def test_without_metrics_or_anchors_the_cells_are_empty():
    runs = {
        "pnn": {0: {"tasks": [{"env_id": "CartPole-v1", "final_return": 1.0, "max_steps": 50}]}}
    }
    (row,) = run_scores(runs)
    assert row["final_normalised_iqm"] is None and row["forward_transfer_after_first"] is None
    assert run_scores_csv([row]).splitlines()[1] == "pnn,0,,,,,"
