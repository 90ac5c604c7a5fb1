"""Continual-learning metrics of SPEC §6 (AUC, forward transfer, forgetting, BWT, episodes to
threshold) against hand-worked run folders, and their table on a tiny real grid."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from evodevo.errors import EvodevoError
from evodevo.evidence.normalise import RANDOM_RETURNS
from evodevo.neuromod.compare import CL_TITLE, continual_markdown, run_grid, write_report
from evodevo.neuromod.config import BiarmConfig, DQNConfig, EvalConfig, TaskConfig
from evodevo.neuromod.continual_metrics import (
    backward_transfer,
    episodes_to_threshold,
    forward_transfer,
    grid_metrics,
    run_metrics,
)
from evodevo.neuromod.continual_table import continual_runs_csv, continual_table
from evodevo.runs import RunDir

pytestmark = pytest.mark.usefixtures("one_torch_thread")

CP_RANDOM = RANDOM_RETURNS["CartPole-v1"]  # normalised 0; its solved return 475 is 1
#: MountainCar-v0: random policy -200 (0), solved -110 (1): R = -200 + 90 u.
ENVS = ("MountainCar-v0", "CartPole-v1")
LIMITS = {"MountainCar-v0": 200, "CartPole-v1": 500}  # their own step limits


def _run(
    path: Path,
    variant: str,
    seed: int,
    curves: tuple[list[float], list[float]],
    returns: tuple[tuple[float, float], tuple[float, float]],
) -> Path:
    """A finished run folder with the files and columns `biarm train` writes: per task its
    training returns (metrics.csv) and (initial, final) greedy returns (summary.json)."""
    run = RunDir(path)
    run.write_config({"variant": variant, "seed": seed, "episodes_scale": 1.0}, "biarm")
    rows, step = [], 0
    for i, (env, curve) in enumerate(zip(ENVS, curves, strict=True)):
        for e, r in enumerate(curve):
            step += 10
            rows.append(
                {"task": i, "env_id": env, "episode": e, "return": r, "length": 10,
                 "epsilon": 0.5, "lr": 0.001, "step": step}
            )  # fmt: skip
    run.write_csv("metrics.csv", rows)
    tasks = []
    for env, curve, (ini, fin) in zip(ENVS, curves, returns, strict=True):
        tasks.append(
            {"env_id": env, "episodes": len(curve), "max_steps": LIMITS[env], "initial_return": ini,
             "final_return": fin, "returns_after": [ini], "retention": 1.0,
             "us_per_step": 1.0}
        )  # fmt: skip
    run.write_summary(
        {"variant": variant, "seed": seed, "eval_seeds": [1_000_000, 1_000_001], "tasks": tasks}
    )
    return path


#: pnn: MountainCar returns normalise to [0, 0, 0.5, 1, 1 (clipped)], CartPole to
#: [0 (clipped), 1, 1 (clipped), 0]; greedy MountainCar -110 after its task, -155 at the end.
PNN = (
    ([-200.0, -200.0, -155.0, -110.0, -100.0], [10.0, 475.0, 500.0, CP_RANDOM]),
    ((-110.0, -155.0), (500.0, 500.0)),
)
#: single: MountainCar [0, 0, 0, 0, 1] (AUC 0.2), CartPole [0, 0, 1, 1] (AUC 0.5).
SINGLE = (
    ([-200.0] * 4 + [-110.0], [CP_RANDOM, CP_RANDOM, 475.0, 475.0]),
    ((-110.0, -110.0), (475.0, 475.0)),
)


def test_metrics_of_a_hand_worked_run(tmp_path):
    run = _run(tmp_path / "pnn", "pnn", 0, *PNN)
    m = run_metrics(run, reference_aucs={0: 0.2, 1: 0.5}, reference={0: "r0", 1: "r1"}, window=2)
    mc, cp = m.tasks
    assert (mc.env_id, mc.episodes, cp.episodes) == ("MountainCar-v0", 5, 4)
    assert mc.auc == pytest.approx(-765.0 / 5)  # mean training return
    assert cp.auc == pytest.approx((10.0 + 475.0 + 500.0 + CP_RANDOM) / 4)
    assert mc.auc_normalised == pytest.approx(0.5) and cp.auc_normalised == pytest.approx(0.5)
    assert mc.forward_transfer == pytest.approx((0.5 - 0.2) / (1 - 0.2))  # 0.375
    assert cp.forward_transfer == 0.0 and (mc.reference, cp.reference) == ("r0", "r1")
    assert mc.forgetting == pytest.approx(45.0)  # -110 right after, -155 at the end
    assert cp.forgetting is None  # last task
    # greedy returns normalised: MountainCar 1 -> 0.5; BWT over the tasks before the last
    assert m.backward_transfer == pytest.approx(-0.5)
    # rolling means over 2: MountainCar -200, -177.5, -132.5, -105 -> >= -110 after 5 episodes;
    # CartPole 242.5, 487.5 -> >= 475 after 3
    assert (mc.threshold, cp.threshold) == (-110.0, 475.0)
    assert (mc.episodes_to_threshold, cp.episodes_to_threshold) == (5, 3)
    assert m.mean_forward_transfer == pytest.approx(0.1875)
    # the default window of 20 needs 20 episodes: never reached here
    default = run_metrics(run)
    assert [t.episodes_to_threshold for t in default.tasks] == [None, None]
    assert [t.forward_transfer for t in default.tasks] == [None, None]
    # a threshold given per environment replaces the solved return
    low = run_metrics(run, thresholds={"MountainCar-v0": -180.0, "CartPole-v1": None}, window=2)
    assert [(t.threshold, t.episodes_to_threshold) for t in low.tasks] == [
        (-180.0, 3),
        (None, None),
    ]


def test_equations_on_their_own():
    assert forward_transfer(0.2, 0.2) == 0.0
    assert forward_transfer(1.0, 0.5) == 1.0 and forward_transfer(0.0, 0.5) == -1.0
    assert forward_transfer(0.9, 1.0) is None  # a reference at 1 leaves nothing to transfer
    assert backward_transfer([0.7], [0.1]) is None  # one task: nothing comes after it
    assert backward_transfer([1.0, 0.4, 0.3], [0.5, 0.6, 0.9]) == pytest.approx(-0.15)
    assert episodes_to_threshold([0.0] * 19 + [100.0], threshold=5.0) == 20
    assert episodes_to_threshold([0.0] * 19 + [99.0], threshold=5.0) is None
    assert episodes_to_threshold([9.0, 9.0], threshold=5.0, window=1) == 1
    with pytest.raises(EvodevoError, match="window=0"):
        episodes_to_threshold([1.0], 0.0, window=0)


def test_grid_pairs_by_seed_and_falls_back_to_the_reference_mean(tmp_path):
    grid = {
        "pnn": {s: _run(tmp_path / f"pnn{s}", "pnn", s, *PNN) for s in (0, 1)},
        "single": {0: _run(tmp_path / "single0", "single", 0, *SINGLE)},
    }
    # reference seed 2: MountainCar [0, 0, 0, 1, 1] (AUC 0.4); its CartPole as seed 0's
    curves = ([-200.0] * 3 + [-110.0] * 2, SINGLE[0][1])
    grid["single"][2] = _run(tmp_path / "single2", "single", 2, curves, SINGLE[1])
    m = grid_metrics(grid, window=2)
    paired = m["pnn"][0].tasks[0]
    assert paired.forward_transfer == pytest.approx(0.375) and paired.reference == "single seed 0"
    fallback = m["pnn"][1].tasks[0]  # seed 1 has no reference: mean AUC_ref (0.2 + 0.4) / 2
    assert fallback.forward_transfer == pytest.approx((0.5 - 0.3) / (1 - 0.3))
    assert fallback.reference == "mean of single seeds 0, 2 (seed 1 missing)"
    # the reference against itself transfers nothing
    assert all(t.forward_transfer == 0.0 for r in m["single"].values() for t in r.tasks)
    rows = list(csv.DictReader(continual_runs_csv(m).splitlines()))
    assert [(r["variant"], r["seed"], r["env_id"]) for r in rows[:2]] == [
        ("pnn", "0", "MountainCar-v0"),
        ("pnn", "0", "CartPole-v1"),
    ]
    assert float(rows[0]["forward_transfer"]) == pytest.approx(0.375)
    assert rows[1]["forgetting"] == ""  # last task


def test_a_run_identical_to_its_reference_has_zero_forward_transfer(tmp_path):
    ref = _run(tmp_path / "single", "single", 3, *PNN)
    copy = tmp_path / "pnn"
    shutil.copytree(ref, copy)
    summary = RunDir(copy, create=False).read_summary() | {"variant": "pnn"}
    RunDir(copy, create=False).write_summary(summary)
    m = grid_metrics({"pnn": {3: copy}, "single": {3: ref}})
    assert [t.forward_transfer for t in m["pnn"][3].tasks] == [0.0, 0.0]


def test_bad_run_folders_are_clear_errors(tmp_path):
    run = _run(tmp_path / "pnn", "pnn", 0, *PNN)
    rows = RunDir(run, create=False).read_csv("metrics.csv")
    RunDir(run, create=False).write_csv("metrics.csv", [r for r in rows if r["task"] == "0"])
    with pytest.raises(EvodevoError, match="no training episode of task 1"):
        run_metrics(run)
    good = _run(tmp_path / "pnn1", "pnn", 1, *PNN)
    short = (([-200.0] * 3, SINGLE[0][1]), SINGLE[1])
    ref = _run(tmp_path / "single", "single", 1, *short)
    with pytest.raises(EvodevoError, match="same tasks and episodes"):
        grid_metrics({"pnn": {1: good}, "single": {1: ref}})
    # a grid whose runs lack metrics.csv gets a line saying why, not a failed report
    (tmp_path / "grid" / "runs").mkdir(parents=True)
    shutil.copytree(good, tmp_path / "grid" / "runs" / "pnn__s1")
    (tmp_path / "grid" / "runs" / "pnn__s1" / "metrics.csv").unlink()
    assert continual_markdown(tmp_path / "grid").startswith("(no continual-learning metrics: ")


def test_table_of_hand_worked_runs(tmp_path):
    grid = {v: {s: _run(tmp_path / f"{v}{s}", v, s, *PNN) for s in (0, 1)} for v in ("pnn",)}
    table = continual_table(grid_metrics(grid), reps=200)
    md = table.markdown()
    assert "FT vs single" not in md
    assert "`evodevo biarm compare --variants single --seeds 0-1 --out DIR`" in md
    assert "seeds 1000000..1000001 (the test range, SPEC §6)" in md
    assert "| pnn | MountainCar-v0 | 2 | -153.0 [-153.0, -153.0] | 0.500 [0.500, 0.500] |" in md
    assert "| 45.00 [45.00, 45.00] | — (0/2 runs; threshold -110) |" in md  # 5 episodes < 20
    assert "| pnn | CartPole-v1 | 2 |" in md and "| — (last task) |" in md
    assert "| pnn | 2 | -0.500 [-0.500, -0.500] |" in md  # BWT
    rows = list(csv.DictReader(table.csv().splitlines()))
    bwt = next(r for r in rows if r["metric"] == "backward_transfer")
    assert (bwt["env_id"], float(bwt["mean"]), bwt["runs"]) == ("sequence", -0.5, "2")


def test_one_run_per_variant_has_no_interval_and_no_paired_verdict(tmp_path):
    grid = {v: {0: _run(tmp_path / v, v, 0, *PNN)} for v in ("pnn", "biarm")}
    md = continual_table(grid_metrics(grid), reps=50).markdown()
    assert "| biarm | MountainCar-v0 | 1 | -153.0 | 0.500 | 45.00 | — (0/1 runs;" in md
    assert "need at least 2 seeds that another variant shares with pnn; this grid has 1." in md


TINY = BiarmConfig(
    tasks=[TaskConfig("CartPole-v1", 6, 500), TaskConfig("CartPole-v1", 6, 500)],
    dqn=DQNConfig(batch_size=16, learning_starts=16, target_update=20),
    eval=EvalConfig(episodes=1, validation_episodes=1),
    checkpoint_every=0,
)
#: The same environment twice: rows are told apart by their place in the sequence.
TINY_TASKS = ("CartPole-v1 (task 1)", "CartPole-v1 (task 2)")


def test_tables_of_a_tiny_real_grid(tmp_path):
    """pnn, its single-task reference and biarm, 2 seeds each, trained for a few episodes."""
    run_grid(TINY, list(TINY_VARIANTS), [0, 1], tmp_path, workers=1)
    md = write_report(tmp_path, figures=False, reps=200).read_text()
    section = md.split(f"## {CL_TITLE}")[1]
    assert "FT vs single" in section and "--variants single" not in section
    grid = {v: {s: tmp_path / "runs" / f"{v}__s{s}" for s in (0, 1)} for v in TINY_VARIANTS}
    m = grid_metrics(grid)
    # the first column has no laterals, so PNN's and the reference's are the same network
    assert [m["pnn"][s].tasks[0].forward_transfer for s in (0, 1)] == [0.0, 0.0]
    assert [m["pnn"][s].tasks[0].auc for s in (0, 1)] == [
        m["single"][s].tasks[0].auc for s in (0, 1)
    ]
    assert all(m["pnn"][s].backward_transfer == 0.0 for s in (0, 1))  # frozen columns
    for v in TINY_VARIANTS:
        for task in TINY_TASKS:
            assert f"| {v} | {task} | 2 |" in section
    first = next(r for r in section.splitlines() if r.startswith(f"| pnn | {TINY_TASKS[0]} |"))
    assert first.split(" | ")[5] == "0.000 [0.000, 0.000]"  # FT
    assert first.split(" | ")[6] == "0.00 [0.00, 0.00]"  # forgetting of a frozen column
    # paired against pnn: single and biarm, 2 tasks, FT and AUC: 8 comparisons, Holm
    assert "Holm-corrected over the 8 comparisons" in section
    assert f"| FT | {TINY_TASKS[0]} | single − pnn | 2 | 0.000 [0.000, 0.000] |" in section
    # the files beside the report
    rows = list(csv.DictReader((tmp_path / "table_cl_metrics.csv").open()))
    ft = {(r["variant"], r["task"]): r for r in rows if r["metric"] == "forward_transfer"}
    assert len(ft) == 3 * 3  # two tasks and the sequence, per variant
    assert float(ft[("pnn", "0")]["mean"]) == 0.0 and ft[("pnn", "")]["env_id"] == "sequence"
    assert all(r["runs_with_value"] == "2" for r in ft.values())
    assert len(list(csv.DictReader((tmp_path / "table_cl_paired.csv").open()))) == 8
    assert len(list(csv.DictReader((tmp_path / "table_cl_runs.csv").open()))) == 3 * 2 * 2
    own = (tmp_path / "table_cl_metrics.md").read_text()
    assert own.startswith(f"## {CL_TITLE}") and own.count("Budget:") == 1
    # every earlier table is still there
    for name in ("table_3_2", "table_3_3", "table_3_5", "table_continual"):
        assert (tmp_path / f"{name}.md").is_file() and (tmp_path / f"{name}.csv").is_file()


TINY_VARIANTS = ("pnn", "single", "biarm")


def test_a_shortened_step_limit_has_no_normalised_metrics(tmp_path):
    """The random-policy and solved anchors hold for the environment's own step limit only."""
    run = _run(tmp_path / "pnn", "pnn", 0, *PNN)
    summary = RunDir(run, create=False).read_summary()
    summary["tasks"][0]["max_steps"] = 50  # MountainCar's own limit is 200
    RunDir(run, create=False).write_summary(summary)
    m = grid_metrics({"pnn": {0: run}, "single": {0: run}})
    mc, cp = m["pnn"][0].tasks
    assert mc.auc == pytest.approx(-153.0) and mc.auc_normalised is None
    assert mc.forward_transfer is None and cp.forward_transfer == 0.0
    assert m["pnn"][0].backward_transfer is None
    md = continual_table(m, reps=50).markdown()
    assert "— (no normalisation anchors for this step limit)" in md


def test_reproduce_report_shows_the_metrics_and_the_quick_budget_trains_the_reference(tmp_path):
    from evodevo.config import from_dict
    from evodevo.reproduce.budget import ReproduceConfig, preset
    from evodevo.reproduce.report import write_report as reproduce_report

    assert {"pnn", "single"} <= set(preset("quick").biarm.variants)  # FT in `make run`'s report
    for v in ("pnn", "single"):
        for s in (0, 1):
            _run(tmp_path / "biarm" / "runs" / f"{v}__s{s}", v, s, *(PNN if v == "pnn" else SINGLE))
    cfg = from_dict(
        ReproduceConfig,
        {
            "name": "tiny",
            "biarm": {"seeds": "0-1", "variants": ["pnn", "single"], "tasks": list(ENVS)},
            "grn": {"enabled": False},
            "kuka": {"enabled": False},
        },
    )
    md = reproduce_report(tmp_path, cfg).read_text()
    section = md.split(f"#### {CL_TITLE}")[1].split("####")[0]
    assert (
        "| pnn | MountainCar-v0 | 2 | -153.0 [-153.0, -153.0] | 0.500 [0.500, 0.500] | 0.375"
        in section
    )
    assert "| FT | MountainCar-v0 | single − pnn | 2 | -0.375 [-0.375, -0.375] |" in section
