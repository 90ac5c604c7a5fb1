"""Ablation tables of several seeds pooled into one (grn/ablation_pooling.py), and in the report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from scipy.stats import binomtest, fisher_exact

from evodevo.errors import EvodevoError
from evodevo.grn.ablation_pooling import (
    pool_ablations,
    pooled_ablations_markdown,
    read_ablation_tables,
)


def _row(name: str, k: int, n: int = 40, **paired: int) -> dict:
    return {"ablation": name, "successes": k, "episodes": n, **paired}


SEED0 = [_row("intact", 20), _row("fewer_genes", 10, only_ablated=1, only_intact=11)]
SEED1 = [_row("intact", 24), _row("fewer_genes", 14, only_ablated=0, only_intact=10)]


def test_pooled_counts_change_and_paired_test():
    rows = pool_ablations({0: SEED0, 1: SEED1})
    intact, fewer = rows
    assert intact["ablation"] == "intact" and intact["successes"] == 44 and intact["p"] == 1.0
    assert (fewer["successes"], fewer["episodes"]) == (24, 80)
    assert (fewer["intact_successes"], fewer["intact_episodes"]) == (44, 80)
    assert fewer["change"] == pytest.approx(24 / 80 - 44 / 80)
    assert fewer["change_ci_low"] < fewer["change"] < fewer["change_ci_high"] < 0
    # McNemar on the discordant episodes summed over seeds: 1 vs 21
    assert fewer["test"] == "McNemar"
    assert fewer["p"] == pytest.approx(binomtest(1, 22, 0.5).pvalue)
    assert fewer["per_seed"][0][0] == pytest.approx(-0.25) and fewer["seeds_lower"] == 2


def test_without_discordant_counts_the_pooled_test_is_fisher():
    old = [_row("intact", 20), _row("no_noise", 26)]  # a table from before the counts existed
    rows = pool_ablations({0: SEED0[:1] + [_row("no_noise", 22, only_ablated=2, only_intact=0)],
                           1: old})  # fmt: skip
    no_noise = rows[1]
    assert no_noise["test"] == "Fisher"
    assert no_noise["p"] == pytest.approx(fisher_exact([[48, 32], [40, 40]])[1])
    assert no_noise["seeds_lower"] == 0
    md = pooled_ablations_markdown(rows)
    assert "| no_noise | s0: +5.0; s1: +15.0 | 60.0 % [" in md and "(Fisher) | 0 of 2 |" in md


def test_read_tables_from_run_dirs_and_a_bad_file(tmp_path: Path):
    for seed, rows in ((0, SEED0), (1, SEED1)):
        d = tmp_path / f"plain_s{seed}"
        d.mkdir()
        (d / "ablations.json").write_text(json.dumps({"rows": rows}))
    (tmp_path / "plain_s2").mkdir()  # not ablated yet: left out
    dirs = {s: tmp_path / f"plain_s{s}" for s in range(3)}
    assert sorted(read_ablation_tables(dirs)) == [0, 1]
    (tmp_path / "plain_s2" / "ablations.json").write_text("{}")
    with pytest.raises(EvodevoError, match="plain_s2/ablations.json is not an ablation table"):
        read_ablation_tables(dirs)
    with pytest.raises(EvodevoError, match="no 'intact' row"):
        pool_ablations({0: SEED0[1:]})
