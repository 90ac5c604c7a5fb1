"""`evodevo baselines kuka` / `evaluate` at tiny budgets on the real Kuka env (SPEC §4)."""

from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from evodevo.baselines.kuka_config import NeatConfig
from evodevo.cli.baselines import app
from evodevo.errors import ConfigError, EvodevoError

pytest.importorskip("pybullet")
pytest.importorskip("stable_baselines3")
pytest.importorskip("neat")

runner = CliRunner()


class Killed(Exception):
    """Stands in for SIGKILL mid-run (click turns KeyboardInterrupt into an exit)."""


TINY = """\
budget:
  eval_every_steps: 8
  eval_episodes: 1
  checkpoint_every_steps: 8
ppo:
  n_steps: 8
  batch_size: 8
  n_epochs: 1
td3:
  buffer_size: 200
  batch_size: 8
  learning_starts: 4
neat:
  population: 2
  episodes: 1
  elitism: 1
evaluation:
  lockstep: 2
"""


def invoke(*args: object):
    res = runner.invoke(app, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    assert res.exit_code == 0, res.output
    return res


@pytest.fixture
def tiny(tmp_path):
    p = tmp_path / "tiny.yaml"
    p.write_text(TINY)
    return p


def _summary(out):
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("method", ["ppo", "td3"])
def test_sb3_baseline_trains_to_the_exact_step_budget_and_is_evaluable(tmp_path, tiny, method):
    out = tmp_path / method
    invoke(
        "kuka",
        "--method",
        method,
        "--budget-steps",
        16,
        "--seed",
        1,
        "--config",
        tiny,
        "--out",
        out,
        "--quiet",
    )
    saved = json.loads((out / "config.json").read_text())
    assert saved["kind"] == "baseline" and saved["config"]["method"] == method
    s = _summary(out)
    assert s["env_steps"] == 16 and s["stopped_by"] == "steps" and s["wall_s"] > 0
    curve = (out / "learning_curve.csv").read_text().splitlines()
    assert [int(r.split(",")[0]) for r in curve[1:]] == [8, 16]
    assert s["success_history"] == [float(r.split(",")[2]) for r in curve[1:]]
    assert (out / "model.safetensors").is_file()
    # only the last checkpoint is kept (TD3: with its replay buffer); nothing is a pickle
    models = sorted(p.name for p in (out / "checkpoints").glob("*.safetensors"))
    assert models == ["rl_model_16_steps.safetensors"]
    assert (out / "checkpoints" / "rl_model_replay_buffer_16_steps.npz").is_file() == (
        method == "td3"
    )
    assert not list(out.rglob("*.zip")) and not list(out.rglob("*.pkl"))
    res = invoke("evaluate", out, "--test-episodes", 2, "--no-baselines", "--json")
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["controller"] == method and result["episodes"] == 2
    # the printed result is the saved one, and its count is that of the saved episodes
    assert json.loads((out / "eval_test_0.json").read_text())["successes"] == result["successes"]
    rows = (out / "eval_test_0_episodes.csv").read_text().splitlines()
    header = rows[0].split(",")
    genome = [dict(zip(header, r.split(","), strict=True)) for r in rows[1:]]
    genome = [r for r in genome if r["policy"] == "genome"]
    assert len(genome) == 2 and sum(int(r["success"]) for r in genome) == result["successes"]


def test_a_wall_clock_budget_stops_training_by_time(tmp_path, tiny):
    out = tmp_path / "ppo"
    invoke(
        "kuka",
        "--method",
        "ppo",
        "--budget-minutes",
        0.001,
        "--config",
        tiny,
        "--out",
        out,
        "--quiet",
    )
    s = _summary(out)
    assert s["stopped_by"] == "time" and s["budget"] == {"env_steps": None, "minutes": 0.001}
    assert s["env_steps"] >= 1 and s["env_steps"] < 16 and s["wall_s"] >= 0.06


def test_sb3_policy_acts_like_the_saved_model(tmp_path, tiny):
    """The evaluator's policy returns the model's own deterministic actions, batched."""
    import numpy as np

    from evodevo.baselines.kuka_config import KukaBaselineConfig
    from evodevo.baselines.policies import Sb3Model, Sb3Policy, load_sb3

    out = tmp_path / "ppo"
    invoke(
        "kuka", "--method", "ppo", "--budget-steps", 8, "--config", tiny, "--out", out, "--quiet"
    )
    model = load_sb3("ppo", out / "model.safetensors")
    imgs = np.random.default_rng(0).integers(0, 256, (3, 48, 48, 3), dtype=np.uint8)
    policy = Sb3Policy(KukaBaselineConfig().evaluator_config(), 3)
    state = policy.reset_state([Sb3Model("ppo", str(out / "model.safetensors"))] * 3)
    got = policy.step(state, np.arange(3), imgs, np.zeros((3, 4)), [], np.zeros(3, bool))
    want = np.stack([model.predict(im, deterministic=True)[0] for im in imgs])
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert np.all(np.abs(got) <= 1.0)


def test_neat_baseline_one_generation_and_evaluation(tmp_path, tiny):
    out = tmp_path / "neat"
    invoke(
        "kuka", "--method", "neat", "--config", tiny, "--out", out, "--quiet", "--budget-steps", 1
    )
    s = _summary(out)
    # one generation of 2 genomes x 1 episode, then the step budget is spent
    assert s["generations_run"] == 1 and s["episodes_run"] == 2 and s["stopped_by"] == "steps"
    assert 2 <= s["env_steps"] <= 16
    for name in ("encoder.pt", "neat.ini", "best_genome.json", "history.csv"):
        assert (out / name).is_file(), name
    assert "pop_size               = 2" in (out / "neat.ini").read_text()
    assert "weight_mutate_rate      = 0.8" in (out / "neat.ini").read_text()
    res = invoke("evaluate", out, "--test-episodes", 1, "--json")
    result = json.loads(res.output.strip().splitlines()[-1])
    assert result["controller"] == "neat" and set(result["baselines"]) == {
        "zero",
        "random",
        "turn",
        "scripted",
    }


def test_ppo_on_the_blob_front_end_reads_4_features_and_is_evaluable(tmp_path, tiny):
    """``ppo.encoder: blob`` trains an MLP policy on the blob features (the
    wrapper encodes every frame as the GRN evaluator does) and the evaluator runs it on them."""
    import numpy as np

    from evodevo.baselines.feature_env import FeatureObservation
    from evodevo.baselines.policies import blob_frontend
    from evodevo.grn.evaluator import make_env

    cfg = tmp_path / "blob.yaml"
    cfg.write_text(tiny.read_text().replace("  n_epochs: 1\n", "  n_epochs: 1\n  encoder: blob\n"))
    out = tmp_path / "ppo_blob"
    invoke(
        "kuka", "--method", "ppo", "--budget-steps", 16, "--config", cfg, "--out", out, "--quiet"
    )
    assert _summary(out)["env_steps"] == 16
    res = invoke("evaluate", out, "--test-episodes", 1, "--noise", 0.03, "--json")
    assert json.loads(res.output.strip().splitlines()[-1])["controller"] == "ppo"
    from evodevo.baselines.policies import load_sb3

    model = load_sb3("ppo", out / "model.safetensors")
    assert model.observation_space.shape == (4,)
    # the wrapper's features are the front-end's on the same frame
    env = make_env("evodevo/KukaDiverseObject-v0", {"max_steps": 8})
    fe = blob_frontend("evodevo/KukaDiverseObject-v0", {"max_steps": 8})
    wrapped = FeatureObservation(env, fe)
    try:
        obs, info = wrapped.reset(seed=10000)
        img, info2 = env.reset(seed=10000)
        want = fe.encode(img[None], info2["proprio"][None].astype(float), fe.reset(1), np.arange(1))
        np.testing.assert_allclose(obs, want[0], rtol=1e-6)
        assert obs.shape == (4,) and obs[3] in (0.0, 1.0)
    finally:
        wrapped.close()
    with pytest.raises(ConfigError, match="ppo.encoder"):
        from evodevo.baselines.kuka_config import PpoConfig

        PpoConfig(encoder="cnn").validate()


def test_neat_on_the_blob_front_end_with_the_shaped_fitness(tmp_path, tiny):
    """NEAT reads the vision preset's 4 blob features (``neat.encoder: blob``)
    and is selected with the GRN's shaped term; the run saves and reloads that front-end."""
    cfg = tmp_path / "blob.yaml"
    cfg.write_text(
        tiny.read_text().replace("  elitism: 1\n", "  elitism: 1\n  encoder: blob\n")
        + "  distance_weight: 1.0\n  distance_at: grasp\n"
    )
    out = tmp_path / "neat_blob"
    invoke(
        "kuka", "--method", "neat", "--config", cfg, "--out", out, "--quiet", "--budget-steps", 1
    )
    assert (out / "frontend.npz").is_file() and not (out / "encoder.pt").exists()
    assert "num_inputs              = 4" in (out / "neat.ini").read_text()
    history = (out / "history.csv").read_text().splitlines()
    assert len(history) == 2  # header + generation 0
    from evodevo.grn.evaluation import load_run

    loaded = load_run(out)
    assert loaded.encoder.name == "blob" and loaded.config.sensors.encoder == "blob"
    with pytest.raises(ConfigError, match="neat.encoder"):
        NeatConfig(encoder="retina").validate()


# ``random`` takes the same code path as ``zero`` (about 20 s each): it runs with -m slow.
@pytest.mark.parametrize("method", ["zero", pytest.param("random", marks=pytest.mark.slow)])
def test_trivial_baselines_need_no_training_and_match_the_evaluators_own(tmp_path, method):
    out = tmp_path / method
    invoke("kuka", "--method", method, "--out", out, "--quiet")
    assert _summary(out)["env_steps"] == 0
    res = invoke("evaluate", out, "--test-episodes", 2, "--json")
    result = json.loads(res.output.strip().splitlines()[-1])
    # the run directory's policy is the very trivial policy measured beside it, same seeds
    assert result["successes"] == result["baselines"][method]["successes"]
    # `evodevo grn evaluate` takes the same run directory through the same code
    from evodevo.cli import app as main_app

    res = runner.invoke(main_app, ["grn", "evaluate", str(out), "--test-episodes", "2", "--json"])
    assert res.exit_code == 0, res.output
    via_grn = json.loads(res.output.strip().splitlines()[-1])
    assert via_grn["controller"] == method and via_grn["successes"] == result["successes"]


def _killed_at_20_of_24(method, tiny, out, monkeypatch):
    """Train ``method`` for 24 env steps into ``out``, killed at step 20 (last checkpoint: 16)."""
    from evodevo.baselines import sb3_kuka

    original = sb3_kuka.BudgetCallback._on_step

    def killed_at_20(self):
        if self.num_timesteps == 20:
            raise Killed
        return original(self)

    with monkeypatch.context() as m:
        m.setattr(sb3_kuka.BudgetCallback, "_on_step", killed_at_20)
        with pytest.raises(Killed):
            runner.invoke(
                app,
                ["kuka", "--method", method, "--budget-steps", "24", "--config", str(tiny)]
                + ["--out", str(out), "--quiet"],
                catch_exceptions=False,
            )


def test_killed_ppo_run_resumes_from_its_last_checkpoint(tmp_path, tiny, monkeypatch):
    out = tmp_path / "ppo"
    _killed_at_20_of_24("ppo", tiny, out, monkeypatch)
    assert not (out / "summary.json").exists()
    assert [p.name for p in (out / "checkpoints").glob("*.safetensors")] == [
        "rl_model_16_steps.safetensors"
    ]
    # a fresh start into the same folder is refused
    with pytest.raises(EvodevoError, match="--resume"):
        invoke("kuka", "--method", "ppo", "--budget-steps", 24, "--config", tiny, "--out", out)
    invoke("kuka", "--method", "ppo", "--out", out, "--resume", "--quiet")
    s = _summary(out)
    assert s["env_steps"] == 24 and "replay_buffer_refilled_at" not in s
    curve = (out / "learning_curve.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in curve] == [8, 16, 24]
    clock = json.loads((out / "checkpoints" / "clock.json").read_text())
    assert clock["16"]["train_s"] <= clock["24"]["train_s"]


def test_td3_resumed_without_its_replay_buffer_refills_it_and_says_so(tmp_path, tiny, monkeypatch):
    from evodevo.baselines.sb3_files import read_sb3_counters

    out = tmp_path / "td3"
    _killed_at_20_of_24("td3", tiny, out, monkeypatch)
    (out / "checkpoints" / "rl_model_replay_buffer_16_steps.npz").unlink()
    res = runner.invoke(app, ["kuka", "--method", "td3", "--out", str(out), "--resume", "--quiet"])
    assert res.exit_code == 0, res.output
    assert "replay buffer of the 16-step checkpoint" in res.output
    s = _summary(out)
    assert s["env_steps"] == 24 and s["replay_buffer_refilled_at"] == [16]
    # learning_starts 4: the 16-step checkpoint holds the updates after steps 5-15 (11; it is
    # written before step 16's update). After the refill no update until step 20, then after
    # steps 21-23 (the budget stops the run before step 24's): 14. Without it: 11 + 7 = 18.
    counters = read_sb3_counters("td3", out / "model.safetensors")
    assert counters["learning_starts"] == 20
    assert counters["_n_updates"] == 14


def test_killed_neat_run_resumes_at_its_next_generation(tmp_path, tiny, monkeypatch):
    from evodevo.baselines import neat_kuka

    out = tmp_path / "neat"
    cfg = tmp_path / "gen2.yaml"
    cfg.write_text(TINY.replace("  elitism: 1\n", "  elitism: 1\n  generations: 2\n"))
    args = ["kuka", "--method", "neat", "--config", str(cfg), "--out", str(out), "--quiet"]
    original = neat_kuka.RunReporter.end_generation

    def killed_after_first(self, config, population, species_set):
        original(self, config, population, species_set)
        raise Killed

    monkeypatch.setattr(neat_kuka.RunReporter, "end_generation", killed_after_first)
    with pytest.raises(Killed):
        runner.invoke(app, args, catch_exceptions=False)
    monkeypatch.setattr(neat_kuka.RunReporter, "end_generation", original)
    assert json.loads((out / "checkpoints" / "neat_state.json").read_text())["generation"] == 1
    # the per-generation summary of the killed run says it is not finished (reproduce resumes it)
    killed = _summary(out)
    assert killed["done"] is False and killed["stopped_by"] == "running"
    invoke("kuka", "--method", "neat", "--out", out, "--resume", "--quiet")
    s = _summary(out)
    assert s["generations_run"] == 2 and s["episodes_run"] == 4
    assert s["done"] is True and s["stopped_by"] == "generations"
    hist = (out / "history.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in hist] == [0, 1]


def test_bad_input_gives_clear_errors(tmp_path, tiny):
    with pytest.raises(EvodevoError, match="--method 'sac' is not known"):
        invoke("kuka", "--method", "sac", "--out", tmp_path / "x")
    with pytest.raises(EvodevoError, match="--budget-steps 0 must be > 0"):
        invoke("kuka", "--method", "ppo", "--budget-steps", 0, "--out", tmp_path / "x")
    with pytest.raises(EvodevoError, match="--budget-minutes -1.0 must be > 0"):
        invoke("kuka", "--method", "td3", "--budget-minutes", -1, "--out", tmp_path / "x")
    bad = tmp_path / "bad.yaml"
    bad.write_text("ppo:\n  clip: 0.2\n")
    with pytest.raises(EvodevoError, match="unknown config key ppo.clip"):
        invoke("kuka", "--method", "ppo", "--config", bad, "--out", tmp_path / "x")
    # a GRN run passed to the baseline evaluator
    grn = tmp_path / "grn"
    grn.mkdir()
    (grn / "config.json").write_text(json.dumps({"kind": "grn", "config": {}}))
    with pytest.raises(EvodevoError, match="holds a 'grn' run, not a Kuka baseline run"):
        invoke("evaluate", grn)
    with pytest.raises(EvodevoError, match="not a baseline run"):
        invoke("kuka", "--method", "ppo", "--out", grn, "--resume")


def test_a_model_of_another_method_is_refused_by_the_evaluator(tmp_path, tiny):
    td3 = tmp_path / "td3"
    invoke(
        "kuka", "--method", "td3", "--budget-steps", 8, "--config", tiny, "--out", td3, "--quiet"
    )
    ppo = tmp_path / "ppo"
    invoke(
        "kuka", "--method", "ppo", "--out", ppo, "--config", tiny, "--budget-steps", 8, "--quiet"
    )
    shutil.copy(td3 / "model.safetensors", ppo / "model.safetensors")
    with pytest.raises(EvodevoError, match="is not a saved PPO model"):
        invoke("evaluate", ppo, "--test-episodes", 1)
    from evodevo.grn.evaluation import evaluate_run

    with pytest.raises(EvodevoError, match="is not a saved PPO model"):
        evaluate_run(ppo, episodes=1)
