"""Pre-registered success-rate experiments decided from run files (evidence.experiment, SPEC §6)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.errors import ConfigError, EvodevoError
from evodevo.evidence.experiment import decide_experiment, load_experiment
from evodevo.evidence.experiment_table import write_experiment
from evodevo.seeding import parse_seeds

CLAIMS = Path(__file__).resolve().parents[1] / "docs" / "results" / "claims"


def _result(path: Path, successes: int, episodes: int = 200, seed: int = 1000000, **extra) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {"successes": successes, "episodes": episodes, "objects": "test", "test_seed": seed}
    path.write_text(json.dumps({**data, **extra}))


def _spec(tmp: Path, **over) -> Path:
    spec = {
        "name": "T1",
        "title": "a test experiment",
        "root": "runs",
        "seeds": "0-7",
        "delta": 5,
        "arms": {"a": "a_s{seed}/r.json", "b": "b_s{seed}/r.json"},
        "decision": ["a - b"],
        "claim": "higher",
        "reps": 500,
        **over,
    }
    p = tmp / "t1.yaml"
    import yaml

    p.write_text(yaml.safe_dump(spec))
    return p


def _fill(tmp: Path, a: list[int], b: list[int]) -> None:
    for s, k in enumerate(a):
        _result(tmp / "runs" / f"a_s{s}" / "r.json", k)
    for s, k in enumerate(b):
        _result(tmp / "runs" / f"b_s{s}" / "r.json", k)


def test_higher_supported_when_every_run_is_well_above(tmp_path: Path) -> None:
    _fill(tmp_path, [160, 150, 170, 155, 165, 158, 162, 168], [100, 104, 98, 110, 96, 102, 99, 101])
    res = decide_experiment(*load_experiment(_spec(tmp_path)))
    assert res.complete and res.reading == "supported"
    c = res.decision[0]
    assert c.n == 8 and c.mean_diff == pytest.approx(100 * (1288 - 810) / 8 / 200)
    assert c.p == pytest.approx(2 / 256)  # every sign agrees: the exact sign-flip test's floor


def test_higher_refuted_when_equivalent_within_delta(tmp_path: Path) -> None:
    _fill(tmp_path, [100, 101, 99, 100, 102, 98, 100, 101], [100, 100, 100, 100, 101, 99, 100, 100])
    res = decide_experiment(*load_experiment(_spec(tmp_path)))
    assert res.decision[0].verdict == "equivalent within δ"
    assert res.reading == "refuted"


def test_equivalent_claim_refuted_by_a_large_drop(tmp_path: Path) -> None:
    _fill(tmp_path, [60, 50, 70, 55, 65, 58, 62, 68], [140, 150, 145, 155, 160, 150, 149, 151])
    res = decide_experiment(*load_experiment(_spec(tmp_path, claim="equivalent")))
    assert res.decision[0].verdict == "different" and res.reading == "refuted"


def test_missing_runs_read_pending_with_the_numbers_so_far(tmp_path: Path) -> None:
    _fill(tmp_path, [160, 150, 170], [100, 104, 98])
    res = decide_experiment(*load_experiment(_spec(tmp_path)))
    assert not res.complete
    assert res.reading == "pending (runs so far of the 8 registered per arm: a 3, b 3)"
    assert res.decision[0].n == 3


def test_part_reads_the_clean_half_of_a_noisy_test(tmp_path: Path) -> None:
    for s in range(8):
        _result(tmp_path / "runs" / f"g_s{s}" / "n.json", 100 + s, clean={"successes": 100})
    spec = _spec(
        tmp_path,
        arms={"noisy": "g_s{seed}/n.json", "clean": "g_s{seed}/n.json#clean"},
        decision=["noisy - clean"],
        claim="equivalent",
    )
    res = decide_experiment(*load_experiment(spec))
    assert res.decision[0].mean_diff == pytest.approx(100 * 3.5 / 200)


def test_write_experiment_writes_tables_and_figure(tmp_path: Path) -> None:
    _fill(tmp_path, [160, 150, 170, 155, 165, 158, 162, 168], [100, 104, 98, 110, 96, 102, 99, 101])
    md = write_experiment(_spec(tmp_path, target=70, beside=["b - a"]))
    assert md == tmp_path / "runs" / "t1" / "table.md"
    text = md.read_text()
    assert "**Reading (claim: higher): supported.**" in text and "locked test range" in text
    assert "| a | 8 | 0,1,2,3,4,5,6,7 |" in text and "pooled ≥ 70 %" in text
    for f in ("comparisons.csv", "runs.csv", "runs.png"):
        assert (md.parent / f).stat().st_size > 0
    assert len((md.parent / "runs.csv").read_text().splitlines()) == 17


def test_runs_tested_on_different_episodes_are_refused(tmp_path: Path) -> None:
    _fill(tmp_path, [160] * 8, [100] * 7)
    _result(tmp_path / "runs" / "b_s7" / "r.json", 100, seed=10000)
    with pytest.raises(EvodevoError, match="different episodes"):
        decide_experiment(*load_experiment(_spec(tmp_path)))


def test_corrupt_result_file_names_the_file(tmp_path: Path) -> None:
    _fill(tmp_path, [160] * 8, [100] * 8)
    (tmp_path / "runs" / "b_s3" / "r.json").write_text("{not json")
    with pytest.raises(EvodevoError, match="b_s3/r.json"):
        decide_experiment(*load_experiment(_spec(tmp_path)))


@pytest.mark.parametrize(
    ("over", "match"),
    [
        ({"decision": ["a - c"]}, "names arm 'c'"),
        ({"decision": ["a minus b"]}, "is not a comparison"),
        ({"metric": "value", "arms": {"a": "a.json#x", "b": "b_s{seed}.json#x"}}, "has no {seed}"),
        ({"colour": "red"}, "unknown config key colour"),
        ({"claim": "better"}, "not accepted"),
        ({"delta": 0}, "must be > 0"),
        ({"seeds": "x-y"}, "not a seed list"),
    ],
)
def test_bad_specs_give_one_clear_error(tmp_path: Path, over: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        load_experiment(_spec(tmp_path, **over))


def test_no_result_yet_is_an_error_not_an_empty_table(tmp_path: Path) -> None:
    with pytest.raises(EvodevoError, match="no result file of T1"):
        decide_experiment(*load_experiment(_spec(tmp_path)))


REGISTERED = [*sorted(CLAIMS.glob("[eg][0-9].yaml")), CLAIMS / "e2b.yaml"]


def test_every_g_experiment_is_transcribed() -> None:
    assert [p.stem for p in REGISTERED if p.stem.startswith("g")] == [f"g{i}" for i in range(1, 8)]


@pytest.mark.parametrize("spec", REGISTERED, ids=lambda p: p.name)
def test_registered_specs_load(spec: Path) -> None:
    loaded, root = load_experiment(spec)
    assert loaded.name.lower() == spec.stem
    assert root.resolve().is_relative_to(CLAIMS)
    for arm in loaded.arms.values():
        # locked-range tests, BIARM summaries (locked eval seeds) or their per-run scores
        assert any(k in arm for k in ("_locked", "summary.json#tasks", "table_run_scores"))


@pytest.mark.parametrize("spec", REGISTERED, ids=lambda p: p.name)
def test_every_registered_design_can_support_its_claim(spec: Path) -> None:
    """A claim that needs "different" needs m * 2 / 2**n < 0.05 (G3 and E3 were amended so)."""
    loaded, _ = load_experiment(spec)
    assert loaded.can_support, (spec.name, loaded.smallest_decision_p)


@pytest.mark.parametrize(
    ("seeds", "decision", "floor", "can"),
    [
        ("0-5", ["a - b", "a - c", "b - c"], 3 * 2 / 64, False),
        ("0-7", ["a - b"], 2 / 256, True),
    ],
)
def test_a_design_that_cannot_reach_p_below_alpha_says_so(
    tmp_path: Path, seeds: str, decision: list[str], floor: float, can: bool
) -> None:
    arms = {x: f"{x}_s{{seed}}/r.json" for x in "abc"}
    p = _spec(tmp_path, seeds=seeds, arms=arms, decision=decision)
    n = len(parse_seeds(seeds, "seeds"))
    for x, k in zip("abc", (180, 120, 60), strict=True):  # every run far apart: all signs agree
        for s in range(n):
            _result(tmp_path / "runs" / f"{x}_s{s}" / "r.json", k + s)
    res = decide_experiment(*load_experiment(p))
    assert res.spec.smallest_decision_p == pytest.approx(floor)
    assert res.spec.can_support is can
    assert res.decision[0].p_adj == pytest.approx(floor)  # the floor is reached, not passed
    assert (res.reading == "supported") is can
    assert ("cannot read 'supported'" in res.reading) is not can
    assert f"can reach is {floor:.3g}" in write_experiment(p).read_text()


def test_the_registered_g3_design_is_kept_and_cannot_support() -> None:
    amended, _ = load_experiment(CLAIMS / "g3.yaml")
    registered, _ = load_experiment(CLAIMS / "g3_as_registered.yaml")
    assert registered.seeds == "0-5" and amended.seeds == "0-7"
    assert registered.arms == amended.arms and registered.decision == amended.decision
    assert not registered.can_support and amended.can_support


DESCRIPTIVE = [
    CLAIMS / "g7_pendulum.yaml",
    *sorted((CLAIMS.parent / "thesis").glob("*/locked.yaml")),
    *sorted((CLAIMS.parent / "grn_general").glob("*.yaml")),
]


@pytest.mark.parametrize("spec", DESCRIPTIVE, ids=lambda p: str(p.relative_to(CLAIMS.parent)))
def test_descriptive_specs_load_and_read_the_locked_range(spec: Path) -> None:
    """The tables beside the experiments (re-tests, the GRN beyond Kuka) read locked-range files
    and decide no claim."""
    loaded, _ = load_experiment(spec)
    assert loaded.claim == "none"
    assert all("_locked" in arm for arm in loaded.arms.values())


def test_cli_compare_experiment(tmp_path: Path) -> None:
    _fill(tmp_path, [160] * 8, [100] * 8)
    out = tmp_path / "out"
    res = CliRunner().invoke(
        app, ["compare", "experiment", str(_spec(tmp_path)), "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "The decision" in res.output and (out / "table.md").is_file()


def _summary(path: Path, lunar: float, seeds: list[int] | None = None) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tasks = [
        {"env_id": "CartPole-v1", "final_return": 500.0},
        {"env_id": "LunarLander-v3", "final_return": lunar},
    ]
    path.write_text(json.dumps({"tasks": tasks, "eval_seeds": seeds or [1000000, 1000001]}))


def test_value_metric_reads_a_task_of_a_biarm_summary(tmp_path: Path) -> None:
    for s in range(8):
        _summary(tmp_path / "runs" / f"biarm__s{s}" / "summary.json", 250.0 + s)
        _summary(tmp_path / "runs" / f"pnn__s{s}" / "summary.json", 150.0 + s)
    key = "summary.json#tasks[env_id=LunarLander-v3].final_return"
    spec = _spec(
        tmp_path,
        metric="value",
        delta=None,
        delta_task="LunarLander-v3",
        test_key="eval_seeds",
        arms={"biarm": "biarm__s{seed}/" + key, "pnn": "pnn__s{seed}/" + key},
        decision=["biarm - pnn"],
    )
    loaded, root = load_experiment(spec)
    assert loaded.margin == pytest.approx(39.25, abs=0.01)  # 10 % of random -> solved
    res = decide_experiment(loaded, root)
    assert res.decision[0].mean_diff == pytest.approx(100.0)
    assert res.reading == "supported"
    md = write_experiment(spec)
    assert "return, LunarLander-v3" in md.read_text() and "eval_seeds" in md.read_text()
    assert (md.parent / "runs.csv").read_text().startswith("arm,seed,value")


def test_value_metric_refuses_runs_evaluated_on_other_seeds(tmp_path: Path) -> None:
    for s in range(8):
        _summary(tmp_path / "runs" / f"a_s{s}" / "r.json", 1.0, [1000000] if s else [10000])
        _summary(tmp_path / "runs" / f"b_s{s}" / "r.json", 1.0, [1000000])
    spec = _spec(
        tmp_path,
        metric="value",
        delta=1.0,
        test_key="eval_seeds",
        arms={
            "a": "a_s{seed}/r.json#tasks[1].final_return",
            "b": "b_s{seed}/r.json#tasks[1].final_return",
        },
    )
    with pytest.raises(EvodevoError, match="different episodes"):
        decide_experiment(*load_experiment(spec))


def test_value_metric_needs_a_margin_and_a_key(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="needs delta or delta_task"):
        load_experiment(
            _spec(tmp_path, metric="value", delta=None, arms={"a": "a{seed}#x", "b": "b{seed}#x"})
        )
    with pytest.raises(ConfigError, match="names no value"):
        load_experiment(_spec(tmp_path, metric="value"))


def test_a_missing_key_names_the_file(tmp_path: Path) -> None:
    for s in range(8):
        _summary(tmp_path / "runs" / f"a_s{s}" / "r.json", 1.0)
        _summary(tmp_path / "runs" / f"b_s{s}" / "r.json", 1.0)
    spec = _spec(
        tmp_path,
        metric="value",
        arms={
            "a": "a_s{seed}/r.json#tasks[env_id=Foo].final_return",
            "b": "b_s{seed}/r.json#tasks[0].x",
        },
    )
    with pytest.raises(EvodevoError, match=r"a_s0/r.json.*0 items of tasks have env_id = Foo"):
        decide_experiment(*load_experiment(spec))


def test_claim_read_on_a_subset_of_the_decision(tmp_path: Path) -> None:
    for s in range(8):
        _result(tmp_path / "runs" / f"a_s{s}" / "r.json", 160 + s)
        _result(tmp_path / "runs" / f"b_s{s}" / "r.json", 100 + s % 2)
        _result(tmp_path / "runs" / f"c_s{s}" / "r.json", 160 + s)
    arms = {"a": "a_s{seed}/r.json", "b": "b_s{seed}/r.json", "c": "c_s{seed}/r.json"}
    both = _spec(tmp_path, arms=arms, decision=["a - b", "a - c"])
    assert decide_experiment(*load_experiment(both)).reading == "refuted"  # a ties c
    on_b = _spec(tmp_path, arms=arms, decision=["a - b", "a - c"], claim_on=["a - b"])
    assert decide_experiment(*load_experiment(on_b)).reading == "supported"
    with pytest.raises(ConfigError, match="not one of the decision"):
        load_experiment(_spec(tmp_path, arms=arms, decision=["a - b"], claim_on=["a - c"]))


def test_higher_by_delta_needs_the_mean_above_delta(tmp_path: Path) -> None:
    _fill(tmp_path, [108 + s % 2 for s in range(8)], [100] * 8)  # +4.25 points, all above
    res = decide_experiment(*load_experiment(_spec(tmp_path)))
    assert res.decision[0].verdict == "different" and res.reading == "supported"
    res = decide_experiment(*load_experiment(_spec(tmp_path, claim="higher_by_delta")))
    assert res.reading == "inconclusive"


def test_value_metric_reads_a_cell_of_a_run_scores_table(tmp_path: Path) -> None:
    rows = ["variant,seed,final_normalised_iqm"]
    rows += [f"biarm,{s},{0.9 + s / 100}" for s in range(8)]
    rows += [f"pnn,{s},{0.7 + s / 100}" for s in range(5)]  # seeds 5-7 not run yet
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "table_run_scores.csv").write_text("\n".join(rows) + "\n")
    col = "table_run_scores.csv#[variant={v},seed={{seed}}].final_normalised_iqm"
    spec = _spec(
        tmp_path,
        metric="value",
        delta=0.1,
        arms={"biarm": col.format(v="biarm"), "pnn": col.format(v="pnn")},
        decision=["biarm - pnn"],
    )
    res = decide_experiment(*load_experiment(spec))
    assert res.arms["pnn"].seeds == [0, 1, 2, 3, 4]
    assert res.decision[0].mean_diff == pytest.approx(0.2)
    assert res.reading == "pending (runs so far of the 8 registered per arm: biarm 8, pnn 5)"


def test_claim_groups_read_once_per_group_under_one_holm_family(tmp_path: Path) -> None:
    for s in range(8):
        for arm, k in (("a", 160 + s), ("b", 100), ("c", 100 + s % 2), ("d", 100)):
            _result(tmp_path / "runs" / f"{arm}_s{s}" / "r.json", k)
    arms = {x: f"{x}_s{{seed}}/r.json" for x in "abcd"}
    spec = _spec(
        tmp_path,
        arms=arms,
        decision=["a - b", "c - d"],
        claim_groups={"first": ["a - b"], "second": ["c - d"]},
    )
    res = decide_experiment(*load_experiment(spec))
    assert res.reading == "first: supported; second: refuted"
    assert all(c.family_size == 2 for c in res.decision)
    with pytest.raises(ConfigError, match="not both"):
        load_experiment(_spec(tmp_path, arms=arms, decision=["a - b"], claim_on=["a - b"],
                              claim_groups={"g": ["a - b"]}))  # fmt: skip


def test_an_untrained_reference_tested_once_stands_beside_every_seed(tmp_path: Path) -> None:
    _fill(tmp_path, [160 + s for s in range(8)], [100] * 8)
    base = {"zero": {"successes": 70, "n": 200}, "turn": {"successes": 105, "n": 200}}
    key = {"episodes": 200, "objects": "test", "test_seed": 1000000}
    (tmp_path / "runs" / "baselines_locked.json").write_text(
        json.dumps({"key": key, "baselines": base})
    )
    arms = {"a": "a_s{seed}/r.json", "turn": "baselines_locked.json#baselines.turn"}
    md = write_experiment(_spec(tmp_path, arms=arms, decision=["a - turn"]))
    res = decide_experiment(*load_experiment(_spec(tmp_path, arms=arms, decision=["a - turn"])))
    assert res.arms["turn"].reference and res.decision[0].n == 8
    assert res.decision[0].mean_diff == pytest.approx(100 * (163.5 - 105) / 200)
    text = md.read_text()
    assert "| turn | one test | (untrained) |" in text and "| 105 / 200 |" in text
    assert "turn,,105,200,52.5" in (md.parent / "runs.csv").read_text()


def test_run_columns_describe_the_runs_beside_the_arm_table(tmp_path: Path) -> None:
    """G3 reports each arm's training wall time beside its table: a run column."""
    _fill(tmp_path, [160, 150, 170], [100, 104, 98])
    for arm, seed, wall in (("a", 0, 60.0), ("a", 1, 120.0), ("b", 0, 30.0)):
        (tmp_path / "runs" / f"{arm}_s{seed}" / "summary.json").write_text(
            json.dumps({"wall_s": wall})
        )
    spec = _spec(tmp_path, run_columns={"wall (s)": "summary.json#wall_s"})
    res = decide_experiment(*load_experiment(spec))
    assert res.arms["a"].columns == {"wall (s)": {0: 60.0, 1: 120.0}}  # seed 2 has no summary
    assert res.arms["b"].columns == {"wall (s)": {0: 30.0}}
    md = write_experiment(spec).read_text()
    assert "| wall (s): mean [min, max] |" in md
    assert "| 90 [60, 120] |" in md and "| 30 [30, 30] |" in md
    runs = (tmp_path / "runs" / "t1" / "runs.csv").read_text().splitlines()
    assert runs[0].endswith(",wall (s)") and runs[1].endswith(",60.0") and runs[3].endswith(",")


@pytest.mark.parametrize("where", ["summary.json", "#wall_s", "a_s{seed}/summary.json#wall_s"])
def test_a_run_column_must_name_a_key_in_a_file_of_the_run(tmp_path: Path, where: str) -> None:
    with pytest.raises(ConfigError, match="run_columns.wall"):
        load_experiment(_spec(tmp_path, run_columns={"wall": where}))
