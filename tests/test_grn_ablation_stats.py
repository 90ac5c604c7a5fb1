"""Ablation tables (SPEC §2.5): paired McNemar p on the same episodes, Holm over the table."""

from __future__ import annotations

import numpy as np
import pytest

from evodevo.grn.ablations import ablation_row, ablations_markdown, add_holm
from evodevo.stats import holm


def test_holm_by_hand():
    # sorted 0.01, 0.03, 0.04 -> 3 * 0.01, max(0.03, 2 * 0.03), max(0.06, 1 * 0.04)
    assert holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])  # capped at 1
    assert holm([]) == []


def test_rows_pair_each_ablation_with_intact_on_the_same_episodes():
    intact = np.array([1] * 10 + [0] * 10, dtype=bool)
    worse = np.array([0] * 10 + [0] * 10, dtype=bool)  # loses the 10 intact wins: 0 vs 10
    swapped = np.array([0] * 10 + [1] * 10, dtype=bool)  # same rate, 10 vs 10 discordant
    rows = [
        ablation_row("intact", 10, 20, 10, 20, intact, intact),
        ablation_row("worse", 0, 20, 10, 20, worse, intact),
        ablation_row("swapped", 10, 20, 10, 20, swapped, intact),
    ]
    add_holm(rows)
    assert rows[0]["mcnemar_p"] == 1.0 and "mcnemar_p_holm" not in rows[0]
    assert rows[1]["mcnemar_p"] == pytest.approx(2 * 0.5**10)
    assert rows[2]["mcnemar_p"] == pytest.approx(1.0)
    assert rows[1]["mcnemar_p_holm"] == pytest.approx(2 * 2 * 0.5**10)
    assert rows[2]["mcnemar_p_holm"] == pytest.approx(1.0)
    # the discordant episodes are kept, so that several seeds' tables pool paired
    assert (rows[1]["only_ablated"], rows[1]["only_intact"]) == (0, 10)
    assert (rows[2]["only_ablated"], rows[2]["only_intact"]) == (10, 10)
    assert (rows[0]["only_ablated"], rows[0]["only_intact"]) == (0, 0)
    md = ablations_markdown(rows, "test", 10000)
    line = next(m for m in md.splitlines() if m.startswith("| worse |"))
    assert f"| {2 * 0.5**10:.3g} | {4 * 0.5**10:.3g} |" in line
    # rows of an older run without per-episode results still print
    old = [{k: v for k, v in r.items() if not k.startswith("mcnemar")} for r in rows]
    assert "| — | — |" in ablations_markdown(old, "test", 10000)
