"""evodevo reproduce: budgets, the report from fixture run directories, the pipeline plan."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from evodevo.config import from_dict, to_dict
from evodevo.errors import ConfigError, EvodevoError
from evodevo.reproduce.budget import ReproduceConfig, preset
from evodevo.reproduce.pipeline import Step, plan, run_step
from evodevo.reproduce.report import markdown_to_html, write_report

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["quick", "thesis"])
def test_yaml_budgets_equal_presets(name):
    data = yaml.safe_load((ROOT / "configs" / f"reproduce_{name}.yaml").read_text())
    assert to_dict(from_dict(ReproduceConfig, data)) == to_dict(preset(name))


def test_bad_budget_values():
    with pytest.raises(ConfigError, match="not a budget"):
        preset("huge")
    with pytest.raises(ConfigError, match="unknown variant 'dqn'"):
        from_dict(ReproduceConfig, {"biarm": {"variants": ["dqn"]}})
    with pytest.raises(ConfigError, match="grn.population=0"):
        from_dict(ReproduceConfig, {"grn": {"population": 0}})


def test_plan_covers_every_part(tmp_path):
    steps = plan(preset("thesis"), tmp_path)
    names = [s.name for s in steps]
    assert names[0] == "biarm-compare"
    assert {
        "grn-evolve-plain-s0",
        "grn-evolve-plain-s2",
        "grn-evolve-blind-s0",
        "grn-evolve-openloop-s0",
    } <= set(names)
    assert "grn-ablate-plain-s0" in names and "grn-evaluate-plain-s1-test_noisy" in names
    ev = next(s for s in steps if s.name == "grn-evaluate-plain-s0-test_noisy")
    assert ev.argv[ev.argv.index("--test-episodes") + 1] == "200" and "--json" in ev.argv
    # the nine ablations need a plain GRN genome; the neuromodulated GRN ablates its modulators
    plain_ab = next(s for s in steps if s.name == "grn-ablate-plain-s0")
    mod_ab = next(s for s in steps if s.name == "grn-ablate-neuromodulated-s0")
    assert "--modulators" not in plain_ab.argv and plain_ab.outputs[0].name == "ablations.csv"
    assert "--modulators" in mod_ab.argv
    assert mod_ab.outputs[0].name == "modulator_ablations.csv"


@pytest.mark.parametrize("vision_budget", ["same", "preset"])
def test_vision_runs_use_their_preset_budget_when_asked(tmp_path, vision_budget):
    cfg = preset("thesis")
    cfg.grn.vision_budget = vision_budget
    steps = {s.name: s for s in plan(cfg, tmp_path)}
    assert steps["grn-evolve-plain-s0"].argv[2:4] == ["--population", "12"]
    for name in ("grn-evolve-vision-s0", "grn-evolve-vision_blind-s0"):
        own = "--population" not in steps[name].argv
        assert own == (vision_budget == "preset"), steps[name].argv
    with pytest.raises(ConfigError, match="grn.vision_budget='huge'"):
        from_dict(ReproduceConfig, {"grn": {"vision_budget": "huge"}})


def test_plan_reuses_baselines_and_runs_controls_early(tmp_path):
    steps = plan(preset("thesis"), tmp_path)
    names = [s.name for s in steps]
    # every evaluation reuses the trivial policies of its object split instead of rerunning them
    for s in steps:
        if s.name.startswith("grn-evaluate-"):
            split = s.argv[s.argv.index("--objects") + 1]
            src = s.argv[s.argv.index("--baselines-from") + 1]
            assert src == str(tmp_path / "grn" / f"baselines_{split}.json")
            assert names.index(f"grn-baselines-{split}") < names.index(s.name)
    # controls right after the first evolution; ablations after every evolution and test
    assert names.index("grn-evolve-blind-s0") < names.index("grn-evolve-plain-s1")
    assert names.index("grn-evolve-openloop-s0") < names.index("grn-evolve-plain-s1")
    last_eval = max(i for i, n in enumerate(names) if n.startswith("grn-evaluate-"))
    assert min(i for i, n in enumerate(names) if n.startswith("grn-ablate-")) > last_eval


def _rate(k: int, n: int) -> dict:
    from evodevo.stats import rate

    r = rate(k, n)
    return {
        "successes": k,
        "n": n,
        "success_rate": r.rate,
        "ci_low": r.ci_low,
        "ci_high": r.ci_high,
    }


def _fixture(out: Path) -> ReproduceConfig:
    cfg = from_dict(
        ReproduceConfig,
        {
            "name": "fixture",
            "biarm": {"enabled": False},
            "grn": {"seeds": "0", "control_seeds": "0", "test_episodes": 40},
        },
    )
    g = out / "grn"
    plain = g / "plain_s0"
    plain.mkdir(parents=True)
    noisy = _rate(30, 40) | {"episodes": 40, "clean": _rate(32, 40), "retention": 30 / 32}
    noisy["baselines"] = {"zero": _rate(12, 40), "random": _rate(10, 40)}
    (plain / "repro_test_noisy.json").write_text(json.dumps(noisy))
    (plain / "repro_train_clean.json").write_text(
        json.dumps(_rate(20, 40) | {"episodes": 40, "baselines": {}})
    )
    (plain / "summary.json").write_text(json.dumps({"generations_run": 7}))
    for label, k in (("blind", 24), ("openloop", 23)):
        (g / f"{label}_s0").mkdir()
        (g / f"{label}_s0" / "repro_test_clean.json").write_text(
            json.dumps(_rate(k, 40) | {"episodes": 40, "baselines": {}})
        )
    return cfg


def test_report_values_from_fixture_runs(tmp_path):
    cfg = _fixture(tmp_path)
    md = write_report(tmp_path, cfg).read_text()
    # clean 32/40 = 80.0 %, noisy 30/40 = 75.0 %, retention 93.8 %, all-zero 12/40 = 30.0 %
    assert "| plain | 0 | 7 | 80.0 % [" in md and "| 75.0 % [" in md and "93.8 %" in md
    assert "30.0 % [" in md and "57.5 % (n=40)" in md
    # pooled GRN 32/40 vs blind 24/40: Fisher exact two-sided p = 0.0881 (scipy), not significant
    from scipy.stats import fisher_exact

    p = fisher_exact([[32, 8], [24, 16]])[1]
    assert (
        f"{p:.3g}" in md and "blind GRN (no vision), seed 0: +20.0 points, not significantly" in md
    )
    html = (tmp_path / "report.html").read_text()
    assert "<table>" in html and "80.0 %" in html


def test_each_preset_is_compared_with_its_own_controls(tmp_path):
    """The vision preset's GRN is pooled and paired with its own blind twin, never with the
    thesis preset's runs (and the thesis GRN never with the vision preset's)."""
    cfg = _fixture(tmp_path)
    cfg.grn.controllers = ["plain", "vision"]
    g = tmp_path / "grn"
    vis = g / "vision_s0"
    vis.mkdir()
    noisy = _rate(27, 40) | {"episodes": 40, "clean": _rate(28, 40), "retention": 27 / 28}
    noisy["baselines"] = {"zero": _rate(12, 40), "random": _rate(10, 40)}
    (vis / "repro_test_noisy.json").write_text(json.dumps(noisy))
    (vis / "summary.json").write_text(json.dumps({"generations_run": 15}))
    (g / "vision_blind_s0").mkdir()
    (g / "vision_blind_s0" / "repro_test_clean.json").write_text(
        json.dumps(_rate(20, 40) | {"episodes": 40, "baselines": {}})
    )
    md = write_report(tmp_path, cfg).read_text()
    assert "| GRN (plain, pooled over seeds) | 80.0 % [" in md  # 32/40, not 60/80
    assert "| GRN (vision, pooled over seeds) | 70.0 % [" in md  # 28/40
    thesis, vision = md.split("Controls evolved with the same budget (SPEC §2.5), the vision")
    assert "blind GRN (no vision), seed 0" in thesis and "vision preset (no vision)" not in thesis
    assert "vision preset (no vision), seed 0 | 50.0 % [" in vision
    assert "best open-loop policy" not in vision.split("### Ablations")[0]


def test_markdown_to_html_inlines_images(tmp_path):
    import base64

    png = base64.b64decode(
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNkYPhfDwAChwGA60e6kgAAAABJRU5ErkJggg=="
    )
    (tmp_path / "a.png").write_bytes(png)
    html = markdown_to_html(
        "# T\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n![x](a.png)\n- item\n", tmp_path
    )
    assert "<h1>T</h1>" in html and "<td>1</td>" in html and "data:image/png;base64," in html
    assert "<li>item</li>" in html


def test_markdown_to_html_links_figures_past_the_inline_budget(tmp_path):
    import base64

    png = base64.b64decode(
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNkYPhfDwAChwGA60e6kgAAAABJRU5ErkJggg=="
    )
    (tmp_path / "figs").mkdir()
    for name in ("a", "b", "c"):
        (tmp_path / "figs" / f"{name}.png").write_bytes(png)
    md = "![a](figs/a.png)\n![b](figs/b.png)\n![c](figs/c.png)\n"
    one = len(base64.b64encode(png))
    html = markdown_to_html(md, tmp_path, inline_budget=2 * one)
    assert html.count("data:image/png;base64,") == 2
    assert '<img alt="c" src="figs/c.png">' in html and "1 figure(s) past" in html
    assert "figure(s) past" not in markdown_to_html(md, tmp_path, inline_budget=3 * one)
    assert markdown_to_html(md, tmp_path, inline_budget=0).count("base64,") == 0
    with pytest.raises(ValueError, match="inline_budget"):
        markdown_to_html(md, tmp_path, inline_budget=-1)


def test_failed_step_is_a_clear_error(tmp_path):
    step = Step(
        "bad",
        ["grn", "evaluate", str(tmp_path / "missing"), "--json"],
        [tmp_path / "x.json"],
        capture_json=tmp_path / "x.json",
    )
    with pytest.raises(EvodevoError, match="step bad failed"):
        run_step(step, tmp_path / "logs", echo=False)
    assert "does not exist" in (tmp_path / "logs" / "bad.log").read_text()


@pytest.mark.slow
def test_reproduce_tiny_end_to_end(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {
                "name": "tiny",
                "workers": 1,
                "biarm": {
                    "variants": ["biarm", "pnn"],
                    "seeds": "0",
                    "tasks": ["CartPole-v1"],
                    "episodes_scale": 0.01,
                    "eval_episodes": 2,
                },
                "grn": {
                    "seeds": "0",
                    "population": 2,
                    "generations": 1,
                    "episodes": 1,
                    "test_episodes": 2,
                    "train_episodes": 1,
                    "ablation_episodes": 1,
                    "controls": True,
                    "controllers": ["plain", "neuromodulated"],
                },
                "kuka": {"methods": ["ppo", "neat"], "seeds": "0", "budget_scales": [1.0]},
            }
        )
    )
    from evodevo.reproduce import run_reproduce

    md = run_reproduce(out=tmp_path / "out", config=cfg).read_text()
    for needle in (
        "Table 3.2",
        "Table 3.5",
        "Test success, robustness",
        "blind GRN",
        "open-loop",
        "Ablations",
        "Table 4.2",
        "| ppo |",
        "| neat |",
        "| neuromodulated |",
        "Where we differ and why (1×)",
        "Against the constant turn,",
    ):
        assert needle in md
    # no section fell back to its placeholder line, e.g. "(no BIARM tables: ...)"
    assert not [line for line in md.splitlines() if line.startswith("(no ")]


def _episodes_csv(path: Path, policies: dict[str, list[int]]) -> None:
    lines = ["policy,episode,seed,noisy,test_objects,reward,success,steps"]
    for policy, succ in policies.items():
        lines += [f"{policy},{i},{1000 + i},0,1,{s}.0,{s},7" for i, s in enumerate(succ)]
    path.write_text("\n".join(lines) + "\n")


def test_report_pairs_controls_on_the_same_episodes(tmp_path):
    """Per GRN seed, every control is compared on the same episodes with the exact McNemar test;
    the trivial policies (with the constant turn) come from grn/baselines_test.json."""
    cfg = _fixture(tmp_path)
    g = tmp_path / "grn"
    grn = [1] * 32 + [0] * 8
    _episodes_csv(g / "plain_s0" / "eval_test_0.03_episodes.csv", {"genome": grn})
    # open loop: 23 successes, all on episodes the GRN also won -> 9 vs 0 discordant
    _episodes_csv(g / "openloop_s0" / "eval_test_0_episodes.csv", {"genome": [1] * 23 + [0] * 17})
    # constant turn: 32 successes on episodes 8..39 -> 8 vs 8 discordant
    turn = [0] * 8 + [1] * 32
    base = {"zero": _rate(12, 40), "random": _rate(10, 40), "turn": _rate(32, 40)}
    (g / "baselines_test.json").write_text(json.dumps({"key": {}, "baselines": base}))
    _episodes_csv(
        g / "baselines_test_episodes.csv",
        {"zero": [1] * 12 + [0] * 28, "random": [1] * 10 + [0] * 30, "turn": turn},
    )
    md = write_report(tmp_path, cfg).read_text()
    row = next(line for line in md.splitlines() if line.startswith("| best open-loop policy"))
    assert "s0: +22.5 (p = 0.0039)" in row  # 2 * 0.5**9
    row = next(line for line in md.splitlines() if line.startswith("| constant turn"))
    assert "80.0 % [" in row and "s0: +0.0 (p = 1)" in row
    # the blind control has no per-episode file: no paired entry, only Fisher
    row = next(line for line in md.splitlines() if line.startswith("| blind GRN"))
    assert row.endswith("| — |")


def test_kuka_runs_are_paired_with_trivial_policies_and_the_grn(tmp_path):
    """Each baseline run: points over each trivial policy and the same-seed GRN, McNemar p."""
    from evodevo.reproduce.kuka_report import kuka_paired

    cfg = _fixture(tmp_path)
    g = tmp_path / "grn"
    _episodes_csv(g / "plain_s0" / "eval_test_0.03_episodes.csv", {"genome": [1] * 32 + [0] * 8})
    _episodes_csv(
        g / "baselines_test_episodes.csv",
        {"zero": [1] * 12 + [0] * 28, "random": [1] * 10 + [0] * 30, "turn": [0] * 8 + [1] * 32},
    )
    run = tmp_path / "kuka" / "ppo_x1_s0"
    run.mkdir(parents=True)
    # PPO wins episodes 0..19: vs zero 8 vs 0 discordant, vs GRN 0 vs 12
    _episodes_csv(run / "eval_test_0_episodes.csv", {"genome": [1] * 20 + [0] * 20})
    (run / "repro_test_clean.json").write_text(json.dumps(_rate(20, 40) | {"episodes": 40}))
    (run / "summary.json").write_text(json.dumps({"env_steps": 1234}))
    (run / "config.json").write_text(json.dumps({"config": {"seed": 0, "method": "ppo"}}))
    (run / "learning_curve.csv").write_text(
        "env_steps,train_s,success,mean_reward,episodes\n"
        "1000,1.0,0.3,0.3,10\n2000,2.0,0.7,0.7,10\n3000,3.0,0.2,0.2,10\n"
    )
    lines = kuka_paired(tmp_path, cfg, [run])
    row = next(line for line in lines if line.startswith("| ppo |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:4] == ["ppo", "0", "1234", "0.70 / 0.20"] and cells[4].startswith("50.0 % [")
    assert cells[5] == "+20.0 (p = 0.0078)"  # 2 * 0.5**8
    assert cells[6] == f"+25.0 (p = {2 * 0.5**10:.2g})"  # random: 10 vs 0 discordant
    # turn wins 8..39, PPO 0..19: PPO-only 0..7 (8), turn-only 20..39 (20)
    from scipy.stats import binomtest

    p_turn = binomtest(8, 28, 0.5).pvalue
    assert cells[7] == f"-30.0 (p = {p_turn:.2g})"
    assert cells[8] == "—"  # no scripted pipeline in this fixture
    assert cells[9] == f"-30.0 (p = {2 * 0.5**12:.2g})"
    # best 0.70, last 0.20: the fall of 0.5 is named under the table
    assert "Training success fell by 0.3 or more" in "\n".join(lines)
    assert "ppo seed 0 (0.70 → 0.20)" in "\n".join(lines)
    assert "all-zero actions 30.0 % [" in lines[0]
    assert (
        "Against the constant turn, 0 of 1 runs are significantly better and 1 significantly worse"
        in "\n".join(lines)
    )


def test_unfinished_kuka_runs_are_named_with_their_progress(tmp_path):
    """A budget's baseline run without a summary is listed as in progress (env steps reached of
    its budget) or not started; a tested run is not listed."""
    from evodevo.reproduce.kuka_report import unfinished_runs

    kuka = tmp_path / "kuka"
    done, going, absent = kuka / "ppo_x5_s0", kuka / "ppo_x5_s1", kuka / "td3_x5_s0"
    done.mkdir(parents=True)
    going.mkdir()
    (going / "config.json").write_text(json.dumps({"config": {"budget": {"env_steps": 43560}}}))
    (going / "learning_curve.csv").write_text(
        "env_steps,train_s,success,mean_reward,episodes\n1000,1.0,0.3,0.3,10\n35000,9.0,0.1,0.1,10\n"
    )
    line = unfinished_runs([done, going, absent], [done])
    assert len(line) == 1
    assert "`ppo_x5_s1` (in progress: 35,000 of 43,560 env steps)" in line[0]
    assert "`td3_x5_s0` (not started)" in line[0] and "ppo_x5_s0`" not in line[0]
    assert unfinished_runs([done], [done]) == []


def test_a_td3_run_resumed_without_its_replay_buffer_is_named_in_the_report(tmp_path):
    from evodevo.reproduce.kuka_report import refill_notes

    refilled, clean = tmp_path / "td3_x5_s0", tmp_path / "td3_x5_s1"
    for d, extra in ((refilled, {"replay_buffer_refilled_at": [23000]}), (clean, {})):
        d.mkdir()
        (d / "summary.json").write_text(json.dumps({"method": "td3", **extra}))
    lines = refill_notes([refilled, clean])
    assert len(lines) == 2 and lines[1] == ""
    assert lines[0].startswith("- `td3_x5_s0` is not an uninterrupted run")
    assert "at 23,000 env steps" in lines[0]
    assert refill_notes([clean]) == []


def test_coverage_lists_what_a_budget_leaves_out():
    from evodevo.reproduce.report import coverage

    assert coverage(preset("thesis")) == []
    quick = "\n".join(coverage(preset("quick")))
    assert "- `biarm.seeds`: [0] (full protocol [0, 1, 2, 3, 4]; missing [1, 2, 3, 4])" in quick
    assert "- `kuka.budget_scales`: [1.0] (full protocol [1.0, 5.0]; missing [5.0])" in quick
    assert "- `grn.population`: 4 (full protocol 12)" in quick
    part = from_dict(ReproduceConfig, {"name": "part", "biarm": {"enabled": False}})
    assert coverage(part)[4:-1] == ["- `biarm`: not run (the full protocol runs it)"]


def test_an_evolution_stopped_mid_way_is_not_done(tmp_path):
    """grn evolve writes summary.json after every generation: a run that stopped at
    generation 6 of 15 (``"done": false``) must resume, not be skipped as finished."""
    import json

    from evodevo.reproduce.pipeline import Step

    summary = tmp_path / "summary.json"
    step = Step("grn-evolve-x", ["grn", "evolve"], [summary])
    assert not step.done()  # nothing yet
    summary.write_text(json.dumps({"generations_run": 6, "done": False}))
    assert not step.done()
    summary.write_text("{half-writ")
    assert not step.done()
    summary.write_text(json.dumps({"generations_run": 15, "done": True}))
    assert step.done()
    summary.write_text(json.dumps({"variant": "biarm"}))  # summaries without the flag: final
    assert step.done()
    # a NEAT baseline's per-generation summary from before the flag existed
    summary.write_text(json.dumps({"method": "neat", "stopped_by": "running"}))
    assert not step.done()
    summary.write_text(json.dumps({"method": "neat", "stopped_by": "steps"}))
    assert step.done()


def test_report_pools_the_ablation_tables_of_every_seed(tmp_path):
    cfg = _fixture(tmp_path)
    cfg = from_dict(ReproduceConfig, {**to_dict(cfg), "grn": {**to_dict(cfg.grn), "seeds": "0-1"}})
    g = tmp_path / "grn"
    (g / "plain_s1").mkdir()
    rows = {
        0: [{"ablation": "intact", "successes": 20, "episodes": 40},
            {"ablation": "no_decay", "successes": 12, "episodes": 40, "mcnemar_p": 0.0078,
             "only_ablated": 0, "only_intact": 8}],
        1: [{"ablation": "intact", "successes": 22, "episodes": 40},
            {"ablation": "no_decay", "successes": 18, "episodes": 40, "mcnemar_p": 0.125,
             "only_ablated": 0, "only_intact": 4}],
    }  # fmt: skip
    for s, r in rows.items():
        (g / f"plain_s{s}" / "ablations.json").write_text(json.dumps({"rows": r}))
    md = write_report(tmp_path, cfg).read_text()
    assert "### Ablations (thesis Section 4.7), plain, seeds 0, 1" in md
    row = next(line for line in md.splitlines() if line.startswith("| no_decay"))
    # 30/80 against 42/80; McNemar on 0 vs 12 discordant episodes: 2 * 0.5**12
    assert "s0: -20.0 (0.0078); s1: -10.0 (0.12)" in row and "| 37.5 % [" in row
    assert "| -15.0 [" in row and f"{2 * 0.5**12:.3g} (McNemar) | 2 of 2 |" in row
    assert "[seed 1](grn/plain_s1/ablations.md)" in md


def test_report_pairs_the_neuromodulated_grn_with_the_plain_one(tmp_path):
    cfg = _fixture(tmp_path)
    grn_cfg = {**to_dict(cfg.grn), "controllers": ["plain", "neuromodulated"]}
    cfg = from_dict(ReproduceConfig, {**to_dict(cfg), "grn": grn_cfg})
    g = tmp_path / "grn"
    (g / "neuromodulated_s0").mkdir()
    # plain wins episodes 0-31; neuromodulated 0-29 and 32-39: 2 vs 8 discordant
    _episodes_csv(g / "plain_s0" / "eval_test_0.03_episodes.csv", {"genome": [1] * 32 + [0] * 8})
    _episodes_csv(
        g / "neuromodulated_s0" / "eval_test_0.03_episodes.csv",
        {"genome": [1] * 30 + [0] * 2 + [1] * 8},
    )
    md = write_report(tmp_path, cfg).read_text()
    assert "### neuromodulated vs plain GRN, paired on the same test episodes" in md
    row = next(line for line in md.splitlines() if line.startswith("| 0 | 80.0 % ["))
    p = 2 * sum(math.comb(10, i) for i in range(3)) / 2**10  # exact McNemar, 2 vs 8
    assert "| 95.0 % [" in row and f"+15.0 (p = {p:.2g})" in row
    assert "| pooled | 80.0 % [" in md and f"+15.0 (p = {p:.2g}, discordant" in md


def test_report_names_the_finished_biarm_runs_when_they_differ_from_the_budget(tmp_path):
    cfg = from_dict(
        ReproduceConfig,
        {
            "name": "fixture",
            "biarm": {"seeds": "0", "variants": ["biarm"]},
            "grn": {"enabled": False},
            "kuka": {"enabled": False},
        },
    )
    bdir = tmp_path / "biarm"
    task = {"env_id": "CartPole-v1", "episodes": 1, "initial_return": 9.0, "final_return": 9.0,
            "retention": 1.0, "us_per_step": 1.0}  # fmt: skip
    for seed in (0, 3):
        run = bdir / "runs" / f"biarm__s{seed}"
        run.mkdir(parents=True)
        summary = {"variant": "biarm", "seed": seed, "tasks": [task]}
        (run / "summary.json").write_text(json.dumps(summary))
    (bdir / "table_3_2.md").write_text("## Table 3.2\n\n| x |\n|---|\n| 1 |\n")
    md = write_report(tmp_path, cfg).read_text()
    assert "Finished runs: seeds 0, 3 for every variant (2 each)." in md


def test_only_selects_steps_by_name_pattern(tmp_path):
    """``reproduce --only``: shell patterns (repeatable, comma-separated) pick steps by name; a
    pattern matching nothing is an error that lists the budget's step names."""
    from evodevo.reproduce.pipeline import select

    steps = plan(preset("thesis"), tmp_path)
    assert select(steps, None) == steps
    chosen = [s.name for s in select(steps, ["kuka-*-td3-x5-s0"])]
    assert chosen == ["kuka-train-td3-x5-s0", "kuka-evaluate-td3-x5-s0"]
    both = [s.name for s in select(steps, ["kuka-train-td3-x5-s0, kuka-train-neat-x5-s1"])]
    order = [s.name for s in steps]
    assert set(both) == {"kuka-train-td3-x5-s0", "kuka-train-neat-x5-s1"}
    assert both == sorted(both, key=order.index)  # in the budget's order, not the patterns'
    with pytest.raises(
        EvodevoError, match=r"--only 'kuka-x' matches no step.*kuka-train-ppo-x1-s0"
    ):
        select(steps, ["kuka-x"])


def test_step_status_done_in_progress_to_do(tmp_path):
    """``reproduce --plan`` labels: to do (nothing there), in progress (a checkpoint or an
    unfinished summary: it resumes), done (every output, none unfinished)."""
    from evodevo.reproduce.pipeline import status

    run = tmp_path / "run"
    step = Step("kuka-train-x", ["baselines", "kuka"], [run / "summary.json"], resume_if=run / "ck")
    assert status(step) == "to do"
    (run / "ck").mkdir(parents=True)
    assert status(step) == "to do"  # an empty checkpoint folder is not a start
    (run / "ck" / "state.json").write_text("{}")
    assert status(step) == "in progress"
    (run / "summary.json").write_text(json.dumps({"stopped_by": "running"}))
    assert status(step) == "in progress"
    (run / "summary.json").write_text(json.dumps({"stopped_by": "steps"}))
    assert status(step) == "done"


def test_plan_lists_steps_and_runs_nothing(tmp_path, capsys):
    from evodevo.reproduce.pipeline import run_reproduce

    run_reproduce("quick", tmp_path / "out", show_plan=True, only=["kuka-*-ppo-*"])
    lines = capsys.readouterr().out.splitlines()
    assert lines and all(": to do" in line and "ppo" in line for line in lines)
    assert not (tmp_path / "out").exists()  # not even config.json


def test_header_says_what_ran_this_time():
    """a report rewritten from saved runs said "0.0 min for the steps run this time"."""
    from evodevo.reproduce.report import _this_time

    assert (
        _this_time(0.01, 0) == "; no step ran this time (the report is drawn from the saved runs)."
    )
    assert _this_time(90.0, 2) == "; 2 steps ran this time, in 1.5 min."
    assert _this_time(None, None) == "."


TINY_ENVS = ("CartPole-v1", "Acrobot-v1", "MountainCar-v0", "LunarLander-v3")
ABLATION_NAMES = ("no-da", "no-5ht", "no-ne", "no-ach")


def _tiny_grid(bdir: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> None:
    """A finished BIARM grid as `biarm compare` leaves it: run folders with config.json (the
    machine), summary.json and metrics.csv, 4 tasks x (biarm, pnn, 4 ablations) x seeds.

    PNN's final returns are negative on LunarLander (-100, -50, 20), BIARM's 100 above them on
    every seed, so a percentage of the PNN mean would be meaningless there.
    """
    from evodevo.runs import RunDir

    for k, variant in enumerate(("biarm", "pnn", *ABLATION_NAMES)):
        for seed in seeds:
            run = RunDir(bdir / "runs" / f"{variant}__s{seed}")
            run.write_config({"variant": variant, "seed": seed, "episodes_scale": 0.01}, "biarm")
            tasks = []
            for i, env in enumerate(TINY_ENVS):
                base = (-100.0, -50.0, 20.0)[seed % 3] if env == "LunarLander-v3" else 50.0 + i
                final = base + (100.0 if variant == "biarm" else 0.0) - (k if k > 1 else 0)
                tasks.append(
                    {
                        "env_id": env,
                        "episodes": 4 + i,
                        "max_steps": 500,
                        "initial_return": final,
                        "final_return": final,
                        "retention": 1.0,
                        "returns_after": [final],
                        "eval_returns_final": [final, final],
                        "us_per_step": 100.0 + 10 * (variant == "biarm"),
                    }  # fmt: skip
                )
            run.write_summary(
                {
                    "variant": variant,
                    "seed": seed,
                    "module_learning": "fixed",
                    "adapter_dim": 32,
                    "eval_seeds": [10000, 10001],
                    "tasks": tasks,
                }  # fmt: skip
            )
            metrics = [
                {"task": i, "env_id": env, "episode": e, "return": float(e + seed), "step": e}
                for i, env in enumerate(TINY_ENVS)
                for e in range(30)
            ]
            run.write_csv("metrics.csv", metrics)


def _tiny_cfg() -> ReproduceConfig:
    return from_dict(
        ReproduceConfig,
        {
            "name": "tiny",
            "biarm": {
                "seeds": "0-2",
                "variants": ["biarm", "pnn", *ABLATION_NAMES],
                "tasks": list(TINY_ENVS),
                "eval_episodes": 2,
            },
            "grn": {"enabled": False},
            "kuka": {"enabled": False},
        },
    )


def test_report_from_a_tiny_grid_lists_every_ablation_pair_and_states_its_budget_once(tmp_path):
    cfg = _tiny_cfg()
    _tiny_grid(tmp_path / "biarm")
    md = write_report(tmp_path, cfg).read_text()
    section = md.split("## BIARM (thesis Chapter 3)")[1]
    # budget, seeds and machine once, at the top; no Python dict or list of seeds anywhere
    assert section.count("Budget:") == 1 and section.count("Machine:") == 1
    top = section.split("###")[0]
    assert "seeds 0-2 (3 per variant)" in top and "Machine: " in top and "CPUs" in top
    assert "(seeds 10000..10001: the validation range, SPEC §6)" in top
    assert "module learning `fixed`" in top
    assert "{'" not in section and "[0, 1, 2]" not in section
    # each table: a heading, then one line of caption, then the table
    lines = section.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("#### Table") or line.startswith("#### Extended"):
            assert lines[i + 1] == "" and lines[i + 2] and not lines[i + 2].startswith("|")
            assert lines[i + 3] == "" and lines[i + 4].startswith("| ")
            table = [r for r in lines[i + 4 :] if r.startswith("|")]
            table = table[: next((j for j, r in enumerate(lines[i + 4 :]) if not r), None)]
            assert len({r.count("|") for r in table}) == 1, line  # no stray "|" in a cell
    # Table 3.2: BIARM - PNN in return, paired by seed (+100 on 3 of 3 seeds: exact p = 2/8)
    t32 = next(line for line in lines if line.startswith("| LunarLander-v3 | -43.33"))
    header = next(line for line in lines if line.startswith("| Environment | PNN (ours)"))
    assert t32.count("|") == header.count("|") == 9  # 8 columns: no stray "|" in a cell
    assert "| +100.00 (p = 0.25; higher on 3/3 seeds) |" in t32
    assert "BIARM − PNN (ours, paired by seed)" in section
    assert "Improvement (thesis, as printed: % of abs(PNN))" in section
    assert "+330.77 %" not in section  # 100 / |-43.33|: the old percentage of a negative mean
    # Table 3.3 says what it measured and cites the benchmark beside it
    assert "µs per training step, measured while training" in section
    assert "sharing the machine's cores" in section and "| 1.11-1.17 |" in section
    # every (task, ablation) pair in the ablation bullet, which ends in a full stop
    bullet = next(line for line in lines if line.startswith("- **Ablations**"))
    for env in TINY_ENVS:
        for a in ABLATION_NAMES:
            per_task = bullet.split(f"{env}: ")[1].split(";")[0]
            assert f" {a} " in f" {per_task}", (env, a)
    assert "all 16 (task, ablation) pairs" in bullet and bullet.endswith(").")
    # Table 3.5 holds the thesis' two models only; every variant is in the extended table
    t35 = section.split("#### Table 3.5")[1].split("####")[0]
    assert "| biarm |" in t35 and "| pnn |" in t35 and "no-da" not in t35
    ext = section.split("#### Extended")[1].split("####")[0]
    assert all(f"| {a} | LunarLander-v3 |" in ext for a in ABLATION_NAMES)


def test_biarm_compare_report_states_its_budget_once(tmp_path):
    from evodevo.neuromod.compare import write_report as compare_report

    _tiny_grid(tmp_path)
    md = compare_report(tmp_path, figures=False).read_text()
    assert md.count("Budget:") == 1 and md.count("Machine:") == 1 and "{'" not in md
    assert "seeds 0-2 for every variant (3 each)" in md
    # a table file read on its own still names its budget, once, under the table
    t32 = (tmp_path / "table_3_2.md").read_text()
    assert t32.count("Budget:") == 1 and t32.index("| Environment") < t32.index("Budget:")
    # E5's decision: biarm against each ablation, every cell under one Holm family (the tiny
    # grid's MountainCar and LunarLander stop at 500 steps: no δ, so 2 tasks x 4 modules)
    abl = (tmp_path / "table_ablation_verdicts.md").read_text()
    assert "Holm over all 8 cells" in abl and abl.count("| biarm − no-") == 8
    assert "Is every module necessary?" in md and "- `no-ach`: inconclusive" in md
    assert len((tmp_path / "table_ablation_verdicts.csv").read_text().splitlines()) == 9


def test_learning_curve_legend_covers_no_panel(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from evodevo.neuromod.compare import collect
    from evodevo.neuromod.figures import learning_curves

    _tiny_grid(tmp_path, seeds=(0,))
    captured = []
    real_close = plt.close
    try:
        plt.close = captured.append  # keep the figure to inspect it
        name = learning_curves(tmp_path, collect(tmp_path), window=5)
    finally:
        plt.close = real_close
    fig = captured[0]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    assert len(legend.get_texts()) == 6
    for ax in fig.axes:
        assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_title()
    assert (tmp_path / name).stat().st_size > 1000
    real_close(fig)


def test_a_compare_step_is_done_only_when_its_grid_is(tmp_path):
    """Tables drawn from a partial grid (`biarm report`) do not mark the compare step done."""
    from evodevo.neuromod.compare import grid_progress, record_grid

    grid = tmp_path / "grid"
    step = Step("biarm-compare", ["biarm", "compare"], [grid / "table_3_2.md"])
    (grid / "runs").mkdir(parents=True)
    (grid / "table_3_2.md").write_text("partial\n")
    assert step.done()  # a folder without grid.json: the table alone decides (older grids)
    record_grid(grid, ["pnn__s0", "biarm__s0"])
    record_grid(grid, ["biarm__s0", "pnn__s1"])  # a second call adds to the grid
    assert json.loads((grid / "grid.json").read_text())["runs"] == [
        "pnn__s0",
        "biarm__s0",
        "pnn__s1",
    ]
    assert grid_progress(grid) == (0, 3) and not step.done()
    for name in ("pnn__s0", "biarm__s0"):
        (grid / "runs" / name).mkdir()
        (grid / "runs" / name / "summary.json").write_text("{}")
    assert grid_progress(grid) == (2, 3) and not step.done()
    (grid / "runs" / "pnn__s1").mkdir()
    (grid / "runs" / "pnn__s1" / "summary.json").write_text("{}")
    assert grid_progress(grid) == (3, 3) and step.done()
    assert grid_progress(tmp_path) is None
