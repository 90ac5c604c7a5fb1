"""`evodevo grn` commands: tiny evolve/evaluate on the real Kuka env, the rest on the fake env."""

from __future__ import annotations

import json

import pytest
from test_grn_fakeenv import FAKE_ID
from typer.testing import CliRunner

from evodevo.cli import app
from evodevo.errors import EvodevoError

runner = CliRunner()


def invoke(*args: str):
    res = runner.invoke(app, ["grn", *map(str, args)])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output
    return res


def test_evolve_and_evaluate_on_the_real_kuka_env(tmp_path):
    pytest.importorskip("pybullet")
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text("evolution:\n  early_stop: false\nevaluation:\n  lockstep: 2\n")
    out = tmp_path / "run"
    invoke(
        "evolve",
        "--population",
        2,
        "--generations",
        1,
        "--episodes",
        1,
        "--seed",
        0,
        "--config",
        cfg,
        "--out",
        out,
        "--quiet",
    )
    for name in ("best_genome.npz", "encoder.pt", "history.csv", "config.json", "summary.json"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["generations_run"] == 1 and summary["episodes_run"] == 2
    assert 2 <= summary["env_steps"] <= 16
    res = invoke("evaluate", out, "--test-episodes", 1, "--json")
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["episodes"] == 1 and set(result["baselines"]) == {
        "zero",
        "random",
        "turn",
        "scripted",
    }
    assert 0.0 <= result["ci_low"] <= result["success_rate"] <= result["ci_high"] <= 1.0
    assert (out / "eval_test_0.json").is_file() and (out / "eval_test_0_episodes.csv").is_file()


@pytest.fixture
def fake_run(tmp_path):
    cfg = tmp_path / "fake.yaml"
    cfg.write_text(
        f"env:\n  id: {FAKE_ID}\n  kwargs: {{max_steps: 8}}\n"
        "evolution:\n  population: 3\n  generations: 2\n  elite_fraction: 0.34\n"
        "evaluation:\n  episodes: 2\n  test_episodes: 6\n"
    )
    out = tmp_path / "run"
    invoke("evolve", "--config", cfg, "--out", out, "--quiet")
    return out


def test_evaluate_json_noise_ablate_plot_video(fake_run, tmp_path):
    res = invoke("evaluate", fake_run, "--noise", 0.03, "--objects", "train", "--json")
    r = json.loads(res.output.strip().splitlines()[-1])
    assert r["episodes"] == 6 and r["noise"] == 0.03 and "clean" in r and "retention" in r
    assert r["baselines"]["zero"]["n"] == 6
    res = invoke("ablate", fake_run, "--test-episodes", 4)
    assert "no_regulation" in res.output and (fake_run / "ablations.csv").is_file()
    res = invoke("plot", fake_run)
    names = {p.rsplit("/", 1)[-1] for p in res.output.split()}
    assert {
        "fitness_success.png",
        "connections.png",
        "regulatory_heatmap.png",
        "expression_trace.png",
        "ablations.png",
    } <= names
    assert any(n.startswith("rolling_success_eval_train") for n in names)
    base = tmp_path / "base" / "b.json"
    cfg = fake_run.parent / "fake.yaml"
    invoke("baselines", "--config", cfg, "--test-episodes", 6, "--objects", "train", "--out", base)
    res = invoke("evaluate", fake_run, "--objects", "train", "--baselines-from", base, "--json")
    reused = json.loads(res.output.strip().splitlines()[-1])
    assert reused["baselines"] == r["baselines"]  # same episodes, same trivial-policy results
    with pytest.raises(EvodevoError, match="was measured on"):
        invoke("evaluate", fake_run, "--objects", "test", "--baselines-from", base)
    gif = tmp_path / "ep.gif"
    invoke("video", fake_run, "--out", gif)
    assert gif.stat().st_size > 0


def test_a_test_on_other_episodes_keeps_the_runs_own_test(fake_run):
    """Re-testing a run on another first seed (an older run on the locked range, SPEC §6) writes
    its own files: the test the run was reported with is never overwritten."""
    invoke("evaluate", fake_run, "--objects", "train", "--no-baselines", "--json")
    own = (fake_run / "eval_train_0.json").read_text()
    other = json.loads((fake_run / "config.json").read_text())["config"]["evaluation"]
    seed = int(other["test_seed"]) + 17
    res = invoke("evaluate", fake_run, "--objects", "train", "--test-seed", seed, "--json")
    r = json.loads(res.output.strip().splitlines()[-1])
    assert r["test_seed"] == seed
    saved = json.loads((fake_run / f"eval_train_0_seed{seed}.json").read_text())
    assert saved["successes"] == r["successes"] and saved["test_seed"] == seed
    rows = (fake_run / f"eval_train_0_seed{seed}_episodes.csv").read_text().splitlines()
    header = rows[0].split(",")
    table = [dict(zip(header, row.split(","), strict=True)) for row in rows[1:]]
    for policy, score in [("genome", r)] + list(r["baselines"].items()):
        returns = [float(t["reward"]) for t in table if t["policy"] == policy]
        assert len(returns) == 6 and score["mean_reward"] == pytest.approx(sum(returns) / 6)
    assert (fake_run / "eval_train_0.json").read_text() == own


def test_ablate_with_set_writes_its_own_files_and_refuses_training_keys(fake_run):
    invoke("ablate", fake_run, "--test-episodes", 2)
    plain = (fake_run / "ablations.json").read_text()
    res = invoke("ablate", fake_run, "--test-episodes", 2, "--set", "env.kwargs.max_steps=3")
    changed = sorted(p.name for p in fake_run.glob("ablations_set-*"))
    assert [p.rsplit(".", 1)[1] for p in changed] == ["csv", "json", "md"]
    meta = json.loads((fake_run / changed[1]).read_text())
    assert meta["overrides"] == {"env": {"kwargs": {"max_steps": 3}}}
    assert "no_regulation" in res.output
    assert (fake_run / "ablations.json").read_text() == plain  # the plain test is kept
    assert "overrides" not in json.loads(plain)
    assert (fake_run / "figures" / changed[0].replace(".csv", ".png")).is_file()
    with pytest.raises(EvodevoError, match="genome"):
        invoke("ablate", fake_run, "--test-episodes", 2, "--set", "genome.regulation=false")


def test_video_with_set_runs_the_changed_test_and_refuses_training_keys(fake_run, tmp_path):
    import evodevo

    policy = evodevo.load(fake_run, overrides={"env": {"kwargs": {"max_steps": 3}}})
    assert policy.config.env.kwargs["max_steps"] == 3  # what the film runs on
    gif = tmp_path / "short.gif"
    invoke("video", fake_run, "--out", gif, "--set", "env.kwargs.max_steps=3")
    assert gif.stat().st_size > 0
    with pytest.raises(EvodevoError, match="genome"):
        invoke("video", fake_run, "--out", gif, "--set", "genome.regulation=false")


def test_open_loop_and_blind_runs(tmp_path):
    cfg = tmp_path / "fake.yaml"
    cfg.write_text(
        f"env:\n  id: {FAKE_ID}\nevolution:\n  population: 3\n  generations: 1\n  elite_fraction: 0.34\n"
        "evaluation:\n  episodes: 2\n  test_episodes: 2\n"
    )
    invoke("evolve", "--config", cfg, "--open-loop", "--out", tmp_path / "ol", "--quiet")
    r = json.loads(invoke("evaluate", tmp_path / "ol", "--json").output.strip().splitlines()[-1])
    assert r["controller"] == "open_loop"
    invoke("evolve", "--config", cfg, "--blind", "--out", tmp_path / "bl", "--quiet")
    r = json.loads(invoke("evaluate", tmp_path / "bl", "--json").output.strip().splitlines()[-1])
    assert r["blind"] is True


def test_user_errors_are_clear(tmp_path, fake_run):
    with pytest.raises(EvodevoError, match="does not exist"):
        invoke("evaluate", tmp_path / "missing")
    with pytest.raises(EvodevoError, match="choose test or train"):
        invoke("evaluate", fake_run, "--objects", "both")
    with pytest.raises(EvodevoError, match="controller='nope' is not known"):
        invoke("evolve", "--controller", "nope", "--out", tmp_path / "x")
    with pytest.raises(EvodevoError, match="already holds a run"):
        invoke("evolve", "--config", fake_run.parent / "fake.yaml", "--out", fake_run)
    # a genome with the wrong shape in the run directory
    import numpy as np

    from evodevo.grn.genome import save_arrays

    arrays = dict(np.load(fake_run / "best_genome.npz"))
    arrays.pop("__meta__")
    arrays["W_m"] = np.zeros((50, 7))
    save_arrays(fake_run / "best_genome.npz", "grn", arrays, {})
    with pytest.raises(EvodevoError, match="W_m has shape"):
        invoke("evaluate", fake_run)


def test_resume_of_a_run_killed_before_its_first_checkpoint_starts_it(tmp_path):
    """`--resume` with a saved config but no checkpoint yet runs from generation 0."""
    cfg = tmp_path / "fake.yaml"
    cfg.write_text(
        f"env:\n  id: {FAKE_ID}\nevolution:\n  population: 3\n  generations: 1\n  elite_fraction: 0.34\n"
        "evaluation:\n  episodes: 2\n  test_episodes: 2\n"
    )
    ref, out = tmp_path / "ref", tmp_path / "run"
    invoke("evolve", "--config", cfg, "--out", ref, "--quiet")
    invoke("evolve", "--config", cfg, "--out", out, "--quiet")
    # what a kill during generation 0 leaves behind: config and encoder, no checkpoint
    for name in ("summary.json", "history.csv", "best_genome.npz"):
        (out / name).unlink()
    for f in (out / "checkpoints").iterdir():
        f.unlink()
    invoke("evolve", "--config", cfg, "--out", out, "--resume", "--quiet")
    timing = {"eval_s", "evals_per_s", "elapsed_s"}

    def history(run):
        import csv

        with (run / "history.csv").open() as f:
            return [{k: v for k, v in r.items() if k not in timing} for r in csv.DictReader(f)]

    assert history(out) == history(ref)
    # a different config is still refused, and a folder with no run still needs no --resume
    with pytest.raises(EvodevoError, match="saved config differs"):
        invoke("evolve", "--config", cfg, "--seed", 5, "--out", out, "--resume", "--quiet")
    with pytest.raises(EvodevoError, match="does not exist"):
        invoke("evolve", "--config", cfg, "--out", tmp_path / "none", "--resume", "--quiet")
