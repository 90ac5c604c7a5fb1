"""Table 4.2 (`evodevo compare kuka`) from small fixture run directories: values checked."""

from __future__ import annotations

import csv
import json

import pytest
from typer.testing import CliRunner

from evodevo.baselines.table_4_2 import build_table, markdown
from evodevo.cli.compare import app
from evodevo.errors import EvodevoError
from evodevo.stats import wilson_interval

runner = CliRunner()


def _write(path, name, text):
    path.mkdir(parents=True, exist_ok=True)
    (path / name).write_text(text)


def fixture_run(
    root,
    name,
    kind,
    config,
    wall_s,
    env_steps,
    successes,
    episodes,
    curve,
    test_seed=10_000,
):
    """A run directory with config, summary, training curve and test result."""
    run = root / name
    _write(run, "config.json", json.dumps({"kind": kind, "config": config}))
    _write(run, "summary.json", json.dumps({"wall_s": wall_s, "env_steps": env_steps}))
    lo, hi = wilson_interval(successes, episodes)
    ev = {
        "success_rate": successes / episodes,
        "ci_low": lo,
        "ci_high": hi,
        "successes": successes,
        "episodes": episodes,
        "objects": "test",
        "test_seed": test_seed,
    }
    _write(run, "eval_test_0.json", json.dumps(ev))
    if kind == "grn":
        rows = ["generation,best_success,elapsed_s"]
        rows += [f"{i},{s},{t}" for i, (t, s) in enumerate(curve)]
        _write(run, "history.csv", "\n".join(rows) + "\n")
    elif curve:
        rows = ["env_steps,train_s,success,mean_reward,episodes"]
        rows += [f"{100 * (i + 1)},{t},{s},0,10" for i, (t, s) in enumerate(curve)]
        _write(run, "learning_curve.csv", "\n".join(rows) + "\n")
    return run


@pytest.fixture
def runs(tmp_path):
    grn0 = fixture_run(
        tmp_path,
        "grn0",
        "grn",
        {"seed": 0, "controller": "plain"},
        360.0,
        13_000,
        24,
        40,
        [(60.0, 0.3), (120.0, 0.6), (180.0, 0.8)],
    )
    grn1 = fixture_run(
        tmp_path,
        "grn1",
        "grn",
        {"seed": 1, "controller": "plain"},
        480.0,
        14_000,
        20,
        40,
        [(60.0, 0.2), (240.0, 0.5)],
    )
    ppo = fixture_run(
        tmp_path,
        "ppo0",
        "baseline",
        {"seed": 0, "method": "ppo"},
        1200.0,
        13_500,
        10,
        40,
        [(600.0, 0.1), (1200.0, 0.4)],
    )
    zero = fixture_run(
        tmp_path, "zero0", "baseline", {"seed": 0, "method": "zero"}, 0.0, 0, 18, 40, []
    )
    return [grn0, grn1, ppo, zero]


def test_rows_pool_seeds_with_wilson_and_compute_efficiency_and_time_to_target(runs):
    table, per_run = build_table(runs, "test", target=0.5)
    assert [r.method for r in table] == ["grn", "ppo", "zero"]
    grn, ppo, zero = table
    # GRN: 44 of 80 pooled over seeds 0 and 1
    assert (grn.successes, grn.episodes, grn.runs, grn.seeds) == (44, 80, 2, "0,1")
    assert grn.success_rate == pytest.approx(0.55)
    assert (grn.ci_low, grn.ci_high) == pytest.approx(wilson_interval(44, 80))
    assert grn.train_min == pytest.approx(7.0)  # mean of 6 and 8 minutes
    assert grn.efficiency == pytest.approx(55.0 / 7.0)
    # first reach of 0.5: seed 0 at 120 s, seed 1 at 240 s -> mean 3 minutes, 2 of 2 runs
    assert grn.time_to_target_min == pytest.approx(3.0) and grn.reached_target == 2
    assert grn.env_steps == pytest.approx(13_500)
    assert (grn.thesis_success, grn.thesis_minutes, grn.thesis_efficiency) == (57.5, 6.5, 8.85)
    assert ppo.success_rate == pytest.approx(0.25) and ppo.efficiency == pytest.approx(25 / 20)
    assert ppo.time_to_target_min is None and ppo.reached_target == 0
    assert (ppo.thesis_success, ppo.thesis_episodes) == (50.0, 10)
    assert zero.efficiency is None and zero.thesis_success is None
    assert [r.seed for r in per_run] == [0, 1, 0, 0]
    md = markdown(table, per_run, 0.5)
    assert "| grn | 2 (0,1) | last (last generation's best) | 55.0 % [" in md and "(44/80)" in md
    assert (
        "| 7.0 min | 13500 | 0 | 7.86 | 3.0 min (2/2) | 80 | 57.5 % | 6.5 min | 8.85 | 40 |" in md
    )
    assert "| zero | 1 (0) | untrained | 45.0 % [" in md
    assert "| 0.0 min | 0 | 0 | — | — (0/1) | 40 | — |" in md
    assert "test seed 10000 (validation range)" in md
    assert "Return rule: last for every trained learner." in md


def test_cli_writes_markdown_and_csv_with_the_same_values(runs, tmp_path):
    out = tmp_path / "table"
    res = runner.invoke(app, ["kuka", *map(str, runs), "--out", str(out), "--target", "0.3"])
    assert res.exit_code == 0, res.output
    assert "Table 4.2" in res.output
    with (out / "table_4_2.csv").open() as fh:
        rows = {r["method"]: r for r in csv.DictReader(fh)}
    assert float(rows["grn"]["success_rate"]) == pytest.approx(0.55)
    assert float(rows["ppo"]["time_to_target_min"]) == pytest.approx(20.0)  # 0.4 at 1200 s
    assert float(rows["grn"]["time_to_target_min"]) == pytest.approx(2.5)  # 60 s and 240 s
    assert rows["zero"]["efficiency"] == ""
    with (out / "table_4_2_runs.csv").open() as fh:
        assert len(list(csv.DictReader(fh))) == 4
    assert (out / "table_4_2.md").read_text().startswith("Table 4.2")


def test_refuses_mixed_test_seeds_untested_runs_and_other_kinds(runs, tmp_path):
    other = fixture_run(
        tmp_path,
        "td3",
        "baseline",
        {"seed": 0, "method": "td3"},
        60.0,
        100,
        1,
        40,
        [],
        test_seed=7,
    )
    with pytest.raises(EvodevoError, match="different test seeds"):
        build_table([*runs, other])
    (runs[2] / "eval_test_0.json").unlink()
    with pytest.raises(EvodevoError, match="evodevo baselines evaluate"):
        build_table(runs)
    biarm = tmp_path / "biarm"
    _write(biarm, "config.json", json.dumps({"kind": "biarm", "config": {}}))
    with pytest.raises(EvodevoError, match="holds a 'biarm' run"):
        build_table([biarm])
    with pytest.raises(EvodevoError, match="no run directory"):
        build_table([])


def test_a_noisy_grn_test_supplies_its_clean_result(runs):
    """`grn evaluate --noise S` stores the clean test of the same episodes under "clean"."""
    grn0 = runs[0]
    clean = json.loads((grn0 / "eval_test_0.json").read_text())
    (grn0 / "eval_test_0.json").unlink()
    lo, hi = wilson_interval(9, 40)
    noisy = {
        "success_rate": 9 / 40,
        "ci_low": lo,
        "ci_high": hi,
        "successes": 9,
        "episodes": 40,
        "objects": "test",
        "test_seed": 10_000,
        "noise": 0.03,
        "clean": {k: clean[k] for k in ("successes", "success_rate", "ci_low", "ci_high")},
    }
    (grn0 / "eval_test_0.03.json").write_text(json.dumps(noisy))
    from evodevo.baselines.table_4_2 import read_run

    row = read_run(grn0)
    assert (row.successes, row.episodes) == (24, 40)  # the clean numbers, not the noisy 9/40
    assert row.success_rate == pytest.approx(0.6)
    (grn0 / "eval_test_0.03.json").unlink()
    with pytest.raises(EvodevoError, match="no test result"):
        read_run(grn0)
