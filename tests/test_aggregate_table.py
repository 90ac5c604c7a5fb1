"""Aggregates over runs and tasks of a BIARM grid (SPEC §6): IQM, probability of improvement
and performance profiles from rliable, on returns normalised between random and solved."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from evodevo.evidence.normalise import task_scale
from evodevo.neuromod.aggregate_table import aggregate_markdown, normalised_finals


def _summary(finals: list[float], max_steps: list[int | None] | None = None) -> dict[str, Any]:
    envs = ["CartPole-v1", "Acrobot-v1"]
    steps = max_steps or [None, None]
    return {
        "eval_seeds": list(range(1_000_000, 1_000_020)),
        "tasks": [
            {"env_id": e, "max_steps": m, "final_return": f}
            for e, m, f in zip(envs, steps, finals, strict=True)
        ],
    }


def _grid(shift: float) -> dict[str, dict[int, dict[str, Any]]]:
    rng = np.random.default_rng(0)
    return {
        "pnn": {s: _summary([200 + 10 * rng.random(), -300 + rng.random()]) for s in range(6)},
        "biarm": {
            s: _summary([200 + shift + 10 * rng.random(), -300 + shift + rng.random()])
            for s in range(6)
        },
    }


def test_finals_are_normalised_per_task_between_random_and_solved() -> None:
    runs = _grid(0.0)
    scores, tasks = normalised_finals(runs)
    assert tasks == ["CartPole-v1", "Acrobot-v1"] and scores["pnn"].shape == (6, 2)
    cart = task_scale("CartPole-v1")
    want = (runs["pnn"][0]["tasks"][0]["final_return"] - cart.random_return) / cart.span
    assert np.isclose(scores["pnn"][0, 0], want)


def test_a_dominating_variant_has_probability_of_improvement_near_one(tmp_path: Path) -> None:
    text = aggregate_markdown(_grid(150.0), tmp_path / "profile.png", reps=300)
    row = next(line for line in text.splitlines() if line.startswith("| biarm | 6 | 6 |"))
    point = float(row.split("|")[4].split()[0])
    assert point == 1.0
    assert "IQM" in text and "the test range" in text
    assert (tmp_path / "profile.png").stat().st_size > 0
    even = aggregate_markdown(_grid(0.0), reps=300)
    row = next(line for line in even.splitlines() if line.startswith("| biarm | 6 | 6 |"))
    assert 0.2 < float(row.split("|")[4].split()[0]) < 0.8


def test_tasks_without_anchors_are_said_not_aggregated() -> None:
    runs = {"pnn": {0: _summary([100.0, -200.0], max_steps=[50, None])}}
    assert "no aggregate over tasks" in aggregate_markdown(runs, reps=100)
