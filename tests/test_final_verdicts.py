"""The final-return verdicts of a BIARM grid (SPEC §6): paired by seed, Holm over the tasks of
each pair, δ from the task's random-to-solved span."""

from __future__ import annotations

from evodevo.evidence.normalise import return_margin, task_scale
from evodevo.neuromod.final_verdicts import (
    final_return_comparisons,
    final_verdict_csv,
    final_verdict_markdown,
)

TASKS = ["CartPole-v1", "Acrobot-v1", "Pendulum-v1"]  # Pendulum: no solved threshold, no δ


def test_a_clear_gain_is_different_and_noise_is_equivalent_within_delta(grid_runs):
    runs = grid_runs(TASKS, {"pnn": [0, 0, 0], "biarm": [100, 0, 0]})
    got = final_return_comparisons(runs, reps=500)
    assert [c.task for c in got] == ["CartPole-v1", "Acrobot-v1"]  # Pendulum has no δ
    cart, acro = got
    assert cart.verdict == "different" and cart.mean_diff > 90
    assert acro.verdict == "equivalent within δ" and abs(acro.mean_diff) < 2
    assert cart.delta == return_margin(task_scale("CartPole-v1"))
    # Holm over the two tasks of the pair: the smaller p is doubled
    assert min(c.p_adj for c in got) == min(1.0, 2 * min(c.p for c in got))


def test_only_shared_seeds_are_paired_and_other_sequences_are_skipped(grid_runs):
    runs = grid_runs(TASKS, {"pnn": [0, 0, 0], "biarm": [5, 0, 0]})
    for s in range(6, 10):
        del runs["biarm"][s]
    runs["other"] = {0: {"tasks": [{"env_id": "CartPole-v1", "final_return": 1.0}]}}
    got = final_return_comparisons(runs, reps=200)
    assert {c.a for c in got} == {"biarm"} and all(c.n == 6 for c in got)
    assert "biarm − pnn" in final_verdict_markdown(got)
    assert final_verdict_csv(got).count("\n") == 1 + len(got)


def test_without_the_reference_there_is_nothing_to_decide(grid_runs):
    assert final_return_comparisons(grid_runs(TASKS, {"biarm": [0, 0, 0]})) == []
    assert "no variant" in final_verdict_markdown([])
