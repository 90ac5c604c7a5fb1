"""GRN against its controls with the evolution as the unit (SPEC §6): per-seed differences, an
exact sign-flip test over seeds, Holm, and a verdict against 5 points."""

from __future__ import annotations

import json
from pathlib import Path

from evodevo.reproduce.budget import GrnBudget
from evodevo.reproduce.grn_controls import run_level_block


def _test(path: Path, successes: int, n: int = 100) -> None:
    path.mkdir(parents=True, exist_ok=True)
    (path / "repro_test_noisy.json").write_text(
        json.dumps({"episodes": n, "clean": {"successes": successes, "n": n}})
    )
    (path / "repro_test_clean.json").write_text(json.dumps({"episodes": n, "successes": successes}))


def test_run_level_rows_pair_seeds_and_decide_against_delta(tmp_path: Path) -> None:
    g = GrnBudget(seeds="0-6")
    for s in range(7):
        _test(tmp_path / f"vision_s{s}", 70 + s % 2)
        _test(tmp_path / f"blind_s{s}", 50)
    trivial = {"turn": {"successes": 141, "n": 200}, "zero": {"successes": 30, "n": 100}}
    text = "\n".join(run_level_block(tmp_path, g, "vision", [("blind", "blind GRN")], trivial))
    lines = [line for line in text.splitlines() if "| success" in line]

    def row(arms: str) -> str:
        return next(line for line in lines if line.split("|")[2].strip().startswith(arms))

    blind = row("GRN (vision) − blind GRN")
    assert "| 7 |" in blind and blind.rstrip(" |").endswith("different")  # +20.4 on 7 of 7 seeds
    # -0.5 or +0.5 points per seed against 70.5 %: the interval lies inside ±5 points
    assert row("GRN (vision) − constant turn").rstrip(" |").endswith("equivalent within δ")
    assert row("GRN (vision) − all-zero").rstrip(" |").endswith("different")


def test_fewer_than_two_grn_runs_give_no_run_level_table(tmp_path: Path) -> None:
    _test(tmp_path / "vision_s0", 70)
    assert run_level_block(tmp_path, GrnBudget(seeds="0"), "vision", [], {}) == []
