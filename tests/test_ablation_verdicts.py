"""BIARM against each module ablation (E5's rule): Holm over every cell, a reading per module."""

from __future__ import annotations

from evodevo.neuromod.ablation_verdicts import (
    ablation_comparisons,
    ablation_verdict_markdown,
    module_readings,
)

TASKS = ["CartPole-v1", "Acrobot-v1"]


def test_cells_are_holm_corrected_together_and_read_per_module(grid_runs):
    runs = grid_runs(
        TASKS, {"biarm": [0, 0], "no-da": [-100, 0], "no-ne": [0, 0], "no-ach": [0, 100]}
    )
    cells = ablation_comparisons(runs, reps=500)
    assert [(c.b, c.task) for c in cells] == [
        (m, t) for m in ("no-da", "no-ne", "no-ach") for t in TASKS
    ]
    assert all(c.family_size == 6 for c in cells)  # one family over every cell
    assert min(c.p_adj for c in cells) >= 6 * min(c.p for c in cells) - 1e-12
    readings = module_readings(cells)
    assert readings["no-da"].startswith("supported")  # biarm higher on CartPole, tied elsewhere
    assert readings["no-ne"].startswith("refuted")  # equivalent within δ on both tasks
    assert readings["no-ach"] == "inconclusive"  # the ablation is higher on Acrobot
    md = ablation_verdict_markdown(cells)
    assert "Holm over all 6 cells" in md and "- `no-ne`: refuted" in md


def test_without_ablations_or_biarm_there_is_nothing_to_decide(grid_runs):
    assert ablation_comparisons(grid_runs(TASKS, {"pnn": [0, 0], "no-da": [0, 0]})) == []
    assert ablation_comparisons(grid_runs(TASKS, {"biarm": [0, 0], "pnn": [0, 0]})) == []
    assert "no ablation" in ablation_verdict_markdown([])
