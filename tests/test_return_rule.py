"""One model-return rule for every Kuka learner (SPEC §6; evodevo.grn.return_rule), on the fake env.

``validated``: the candidate with the most successes on the same validation episodes (training
objects, validation-range seeds) is returned, for the GRN, NEAT, PPO and TD3 alike; a killed run
resumes with the same returned model; the tables state each learner's rule.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from test_grn_evaluator import _Stop, _StopAfterFirst, fake_config, history
from test_grn_fakeenv import FAKE_ID

from evodevo.config import from_dict
from evodevo.errors import CheckpointError, ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.grn.evaluator import Episode, EpisodeResults, Evaluator
from evodevo.grn.evolution import evolve_run
from evodevo.grn.return_rule import (
    STATE_FILE,
    ValidatedBest,
    candidate_every,
    describe_rule,
    rule_of,
    validation_episodes,
)
from evodevo.seed_split import TEST, SeedSplitError
from evodevo.seeding import derive

V = 6
"""Validation episodes per candidate in these tests."""
VALIDATED = {"population": 4, "generations": 4, "early_stop": False, "keep": "validated"}


class Killed(Exception):
    """Stands in for SIGKILL between two writes."""


class ScriptedEvaluator:
    """Returns a fixed number of successes per candidate, in the order asked."""

    def __init__(self, successes: list[int]) -> None:
        self.successes = list(successes)
        self.calls: list[tuple[list, list[Episode]]] = []

    def evaluate(self, genomes, episodes, config=None):
        self.calls.append((list(genomes), list(episodes)))
        k = self.successes.pop(0)
        success = np.zeros((1, len(episodes)), bool)
        success[0, :k] = True
        steps = np.full((1, len(episodes)), 7)
        return EpisodeResults(success.astype(float), success, steps)


def grn_config(seed: int = 0, **evolution) -> GrnConfig:
    return fake_config(
        seed=seed,
        evolution={**VALIDATED, **evolution},
        evaluation={"episodes": 3, "validation_episodes": V},
    )


def validation_rows(run) -> list[dict[str, int]]:
    """``validation.csv`` without its timings (they differ between runs)."""
    with open(run / "validation.csv") as fh:
        return [
            {k: int(v) for k, v in r.items() if k not in ("seconds", "mean_return")}
            for r in csv.DictReader(fh)
        ]


def kept_index(rows: list[dict[str, int]]) -> int:
    """The candidate with the most successes, the later one on a tie."""
    best = max(r["successes"] for r in rows)
    return max(i for i, r in enumerate(rows) if r["successes"] == best)


# -- the shared keeper ----------------------------------------------------------------------
def test_the_keeper_returns_the_most_successes_and_the_later_candidate_on_a_tie():
    keeper = ValidatedBest(20_000, V, "generation")
    ev = ScriptedEvaluator([1, 3, 2, 3, 0])
    kept = [keeper.check(ev, f"g{g}", g, {"name": f"g{g}"}) for g in range(5)]
    assert kept == [True, True, False, True, False]
    assert keeper.best_state == {"name": "g3"} and keeper.best_row["successes"] == 3
    assert [r["kept_at"] for r in keeper.rows] == [0, 1, 1, 3, 3]  # last (g4) != kept (g3)
    # every candidate met the same episodes: clean, training objects, validation seeds
    episodes = [eps for _, eps in ev.calls]
    assert all(eps == validation_episodes(20_000, V) for eps in episodes)
    assert all(not e.test_objects and not e.noisy for e in episodes[0])
    assert [e.seed for e in episodes[0]] == [derive(20_000, i) for i in range(V)]
    assert keeper.summary()["validation_episodes"] == 5 * V == keeper.episodes_run
    assert keeper.summary()["seed_range"] == "validation"


def test_a_resume_drops_the_candidates_its_checkpoint_does_not_cover(tmp_path):
    keeper = ValidatedBest(20_000, V, "env_steps")
    for at, k in [(8, 1), (16, 2), (24, 2), (32, 0)]:
        keeper.offer(at, k, {"file": f"c{at}"})
    # a checkpoint at 16 covers 8 and 16: the state before 16's is superseded
    assert keeper.prune(upto=16) == [{"file": "c8"}]
    path = tmp_path / STATE_FILE
    keeper.save(path)
    back = ValidatedBest.load(path, 20_000, V, "env_steps", upto=None)
    assert back.rows == keeper.rows and back.best_state == {"file": "c24"}
    # resumed from the checkpoint at 16: candidates 24 and 32 are validated again
    cut = ValidatedBest.load(path, 20_000, V, "env_steps", upto=16)
    assert [r["at"] for r in cut.rows] == [8, 16] and cut.best_state == {"file": "c16"}
    with pytest.raises(CheckpointError, match="written for 6 episodes from seed 20000"):
        ValidatedBest.load(path, 20_000, V + 1, "env_steps", upto=None)
    fresh = ValidatedBest.load(tmp_path / "none.safetensors", 20_000, V, "env_steps", upto=None)
    assert fresh.rows == [] and fresh.best_state is None


class ReturnEvaluator(ScriptedEvaluator):
    """No episode succeeds; each candidate's episodes return a fixed reward, in order."""

    def evaluate(self, genomes, episodes, config=None):
        self.calls.append((list(genomes), list(episodes)))
        reward = np.full((1, len(episodes)), float(self.successes.pop(0)))
        none = np.zeros((1, len(episodes)), bool)
        return EpisodeResults(reward, none, np.full((1, len(episodes)), 200))


def test_ranked_by_return_the_keeper_keeps_the_best_mean_return_where_nothing_succeeds(tmp_path):
    returns = [-900, -400, -700, -400, -1200]
    by_return = ValidatedBest(20_000, V, "generation", by="return")
    kept = [by_return.check(ReturnEvaluator(returns[g : g + 1]), g, g, {"g": g}) for g in range(5)]
    assert kept == [True, True, False, True, False]  # the later one on a tie, as by successes
    assert by_return.best_state == {"g": 3} and by_return.summary()["kept_mean_return"] == -400
    assert [r["mean_return"] for r in by_return.rows] == returns
    # ranked by successes, every candidate ties at 0 and the last one is returned
    by_successes = ValidatedBest(20_000, V, "generation")
    for g in range(5):
        by_successes.check(ReturnEvaluator(returns[g : g + 1]), g, g, {"g": g})
    assert by_successes.best_state == {"g": 4} and by_successes.summary()["by"] == "successes"
    path = tmp_path / STATE_FILE
    by_return.save(path)
    back = ValidatedBest.load(path, 20_000, V, "generation", upto=None, by="return")
    assert back.rows == by_return.rows and back.best_state == {"g": 3}
    with pytest.raises(CheckpointError, match="ranks candidates by return, not successes"):
        ValidatedBest.load(path, 20_000, V, "generation", upto=None)
    with pytest.raises(ConfigError, match="validation_score='best'"):
        ValidatedBest(20_000, V, "generation", by="best")
    with pytest.raises(ConfigError, match="evaluation.validation_score='best'"):
        from_dict(GrnConfig, {"evaluation": {"validation_score": "best"}})


@pytest.mark.parametrize("seed", [TEST.first, TEST.first + 12_345, 5, 2_000_000])
def test_validation_seeds_outside_the_validation_range_are_refused(seed):
    with pytest.raises(SeedSplitError, match="evaluation.validation_seed"):
        ValidatedBest(seed, V, "generation")
    with pytest.raises(ConfigError, match=f"evaluation.validation_seed={seed} .*SPEC §6"):
        from_dict(GrnConfig, {"evaluation": {"validation_seed": seed}})


def test_candidates_are_spread_over_the_step_budget_or_need_every_steps():
    assert candidate_every(13_500, 15, None) == 900 and candidate_every(24, 3, None) == 8
    assert candidate_every(None, 15, 700) == 700
    with pytest.raises(ConfigError, match="keep.every_steps"):
        candidate_every(None, 15, None)
    from evodevo.baselines.kuka_config import KukaBaselineConfig

    minutes = {"keep": {"rule": "validated"}, "budget": {"minutes": 5}}
    with pytest.raises(ConfigError, match="keep.every_steps"):  # at load, before any training
        from_dict(KukaBaselineConfig, {**minutes, "method": "td3"})
    assert from_dict(KukaBaselineConfig, {**minutes, "method": "neat"}).keep.rule == "validated"


# -- the GRN --------------------------------------------------------------------------------
def test_the_grn_returns_the_validated_best_and_trains_as_with_last(tmp_path):
    summary = evolve_run(grn_config(seed=0), tmp_path / "validated", progress=False)
    rows = validation_rows(tmp_path / "validated")
    assert [r["at"] for r in rows] == [0, 1, 2, 3] and all(r["episodes"] == V for r in rows)
    kept = kept_index(rows)
    assert kept != len(rows) - 1  # this seed's last generation's best is not the kept one
    assert summary["return_rule"]["kept_at"] == kept == rows[-1]["kept_at"]
    assert summary["validation_episodes"] == 4 * V
    assert summary["episodes_run"] == 4 * 4 * 3  # the training budget alone
    # the returned genome scores the kept candidate's successes on the same episodes
    from evodevo.grn.evaluation import load_run

    loaded = load_run(tmp_path / "validated")
    with Evaluator(loaded.config, loaded.encoder) as ev:
        res = ev.evaluate([loaded.genome], validation_episodes(20_000, V))
    assert int(res.success.sum()) == rows[kept]["successes"]
    # selection is untouched: the same trajectory as keep: last
    evolve_run(grn_config(seed=0, keep="last"), tmp_path / "last", progress=False)
    assert history(tmp_path / "validated") == history(tmp_path / "last")
    a = np.load(tmp_path / "validated" / "best_genome.npz")
    b = np.load(tmp_path / "last" / "best_genome.npz")
    assert any(a[k].tobytes() != b[k].tobytes() for k in a.files if k != "__meta__")


def test_the_grn_ranked_by_return_keeps_the_best_mean_validation_return(tmp_path):
    cfg = fake_config(
        seed=0,
        evolution=VALIDATED,
        evaluation={"episodes": 3, "validation_episodes": V, "validation_score": "return"},
    )
    summary = evolve_run(cfg, tmp_path / "run", progress=False)
    with open(tmp_path / "run" / "validation.csv") as fh:
        returns = [float(r["mean_return"]) for r in csv.DictReader(fh)]
    kept = max(i for i, r in enumerate(returns) if r == max(returns))
    assert summary["return_rule"]["by"] == "return" and summary["return_rule"]["kept_at"] == kept
    assert summary["return_rule"]["kept_mean_return"] == pytest.approx(returns[kept])


def _same_genome(a, b) -> bool:
    x, y = np.load(a / "best_genome.npz"), np.load(b / "best_genome.npz")
    return all(x[k].tobytes() == y[k].tobytes() for k in x.files if k != "__meta__")


def test_a_killed_grn_run_resumes_with_the_same_returned_genome(tmp_path, monkeypatch):
    from evodevo.grn import evolution

    cfg = grn_config(seed=0)
    full = evolve_run(cfg, tmp_path / "full", progress=False)
    # killed between two candidates (after generation 0's checkpoint)
    with pytest.raises(_Stop):
        evolve_run(cfg, tmp_path / "cut", callbacks=[_StopAfterFirst()], progress=False)
    cut = evolve_run(cfg, tmp_path / "cut", resume=True, progress=False)
    # killed between the validation state and the checkpoint of generation 1: it is redone
    original, calls = evolution.save_arrays, []

    def killed_at_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise Killed
        return original(*args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(evolution, "save_arrays", killed_at_second)
        with pytest.raises(Killed):
            evolve_run(cfg, tmp_path / "mid", progress=False)
    mid = evolve_run(cfg, tmp_path / "mid", resume=True, progress=False)
    for run, summary in (("cut", cut), ("mid", mid)):
        assert validation_rows(tmp_path / run) == validation_rows(tmp_path / "full")
        assert summary["return_rule"] == {
            **full["return_rule"], "validation_s": summary["return_rule"]["validation_s"]
        }  # fmt: skip
        assert _same_genome(tmp_path / run, tmp_path / "full")


def test_keep_validated_and_final_pick_contradict_each_other():
    with pytest.raises(ConfigError, match="keep=validated and final_pick_episodes"):
        fake_config(
            evolution={"keep": "validated", "elite_fraction": 0.5, "final_pick_episodes": 4}
        )


# -- the rule in a table --------------------------------------------------------------------
def test_the_rule_is_read_from_the_saved_config():
    grn = {"kind": "grn", "config": {"evolution": {"keep": "last"}}}
    assert rule_of(grn) == "last" and describe_rule(grn) == "last (last generation's best)"
    pick = {"kind": "grn", "config": {"evolution": {"keep": "last", "final_pick_episodes": 8}}}
    assert rule_of(pick) == "final pick" and "8 training episodes" in describe_rule(pick)
    old = {"kind": "baseline", "config": {"method": "td3"}}  # written before keep existed
    assert rule_of(old) == "last" and describe_rule(old) == "last (the final model)"
    neat = {"kind": "baseline", "config": {"method": "neat", "keep": {"rule": "validated"}}}
    assert rule_of(neat) == "validated"
    assert describe_rule(neat, {"return_rule": {"candidates": 3}}) == (
        "validated (best of 3 candidates on 20 validation episodes)"
    )
    assert rule_of({"kind": "baseline", "config": {"method": "random"}}) == "untrained"


# -- NEAT, PPO and TD3 (and the GRN) through the same keeper --------------------------------
TINY = f"""\
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
  generations: 3
evaluation:
  lockstep: 2
  validation_episodes: {V}
env:
  id: {FAKE_ID}
"""
SCRIPT = {"grn": {0: 1, 1: 3, 2: 0, 3: 2}, "neat": {0: 1, 1: 3, 2: 0}}
"""Validation successes by candidate position: the second candidate is kept, not the last."""
SCRIPT["ppo"] = SCRIPT["td3"] = {8: 1, 16: 3, 24: 0}


@pytest.fixture
def scripted(monkeypatch):
    """Score every candidate for real, but count ``SCRIPT``'s successes; record what ran.

    Returns (script, candidates the keeper scored with their episodes, episodes of every
    evaluator call)."""
    script: dict[int, int] = {}
    scored: list[tuple[object, list[Episode]]] = []
    evaluated: list[list[Episode]] = []
    score, offer, evaluate = ValidatedBest.score, ValidatedBest.offer, Evaluator.evaluate

    def spy_score(self, evaluator, candidate, config=None):
        scored.append((candidate, list(self.episodes)))
        return score(self, evaluator, candidate, config)

    def scripted_offer(self, at, successes, state, env_steps=0, seconds=0.0, mean_return=0.0):
        return offer(self, at, script.get(at, successes), state, env_steps, seconds, mean_return)

    def spy_evaluate(self, genomes, episodes, **kw):
        evaluated.append(list(episodes))
        return evaluate(self, genomes, episodes, **kw)

    monkeypatch.setattr(ValidatedBest, "score", spy_score)
    monkeypatch.setattr(ValidatedBest, "offer", scripted_offer)
    monkeypatch.setattr(Evaluator, "evaluate", spy_evaluate)
    return script, scored, evaluated


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return path


def train_baseline(method, tiny, out, *extra):
    """`evodevo baselines kuka` with the rule chosen through --set; returns the summary."""
    from typer.testing import CliRunner

    from evodevo.cli.baselines import app

    args = ["kuka", "--method", method, "--config", tiny, "--out", out, "--quiet"]
    args += ["--set", "keep.rule=validated", "--set", "keep.candidates=3", *extra]
    if method != "neat":
        args += ["--budget-steps", 24]
    res = CliRunner().invoke(app, [str(a) for a in args], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    return json.loads((out / "summary.json").read_text())


def _sb3_weights(algo, path):
    from evodevo.baselines.policies import load_sb3

    return {k: v.clone() for k, v in load_sb3(algo, path).state_dict().items()}


@pytest.mark.parametrize("learner", ["grn", "neat", "ppo", "td3"])
def test_every_learner_returns_the_candidate_with_the_most_validation_successes(
    learner, tmp_path, tiny, scripted
):
    script, scored, evaluated = scripted
    script.update(SCRIPT[learner])
    out = tmp_path / learner
    if learner == "grn":
        summary = evolve_run(grn_config(seed=0), out, progress=False)
    else:
        summary = train_baseline(learner, tiny, out)
        saved = json.loads((out / "config.json").read_text())["config"]
        assert saved["keep"]["rule"] == "validated"  # --set reached the config
    at = sorted(script)
    rows = validation_rows(out)
    assert [r["at"] for r in rows] == at and [r["successes"] for r in rows] == list(script.values())
    assert {r["kept_at"] for r in rows[1:]} == {at[1]} and summary["return_rule"]["kept_at"] == at[
        1
    ]
    assert summary["validation_episodes"] == len(at) * V  # counted apart from training
    # the same episodes for every candidate and every learner: training objects, validation seeds
    want = validation_episodes(20_000, V)
    assert len(scored) == len(at) and all(eps == want for _, eps in scored)
    assert sum(eps == want for eps in evaluated) == len(at)
    assert not any(e.test_objects for eps in evaluated for e in eps)
    assert not any(e.seed == derive(TEST.first, i) for e in want for i in range(V))
    # the returned model is the kept candidate, not the last one
    if learner in ("ppo", "td3"):
        kept = out / "checkpoints" / f"candidate_{at[1]}_steps.safetensors"
        assert (out / "model.safetensors").read_bytes() == kept.read_bytes()
        assert not list((out / "checkpoints").glob("candidate_8_*"))  # superseded: deleted
        a = _sb3_weights(learner, out / "model.safetensors")
        b = _sb3_weights(learner, out / "last_model.safetensors")
        assert any(not a[k].equal(b[k]) for k in a)
    elif learner == "neat":
        from evodevo.baselines.policies import NeatNet

        net = NeatNet.load(out / "best_genome.json", out / "neat.ini")
        assert net.behaviour_key()[1:] == scored[1][0].behaviour_key()[1:]
    else:
        genome = scored[1][0]
        returned = np.load(out / "best_genome.npz")
        assert all(returned[k].tobytes() == v.tobytes() for k, v in genome.arrays().items())


def test_a_killed_ppo_run_resumes_with_the_same_returned_model(
    tmp_path, tiny, scripted, monkeypatch
):
    """Killed at step 20 (after candidate 16 and checkpoint 16), and killed between the
    validation state of step 16 and its checkpoint (the run goes back to checkpoint 8 and
    validates candidate 16 again): no candidate is counted twice and the kept one is returned."""
    from evodevo.baselines import sb3_files, sb3_kuka

    script = scripted[0]
    script.update(SCRIPT["ppo"])
    full = train_baseline("ppo", tiny, tmp_path / "full")
    steps, checkpoint = sb3_kuka.BudgetCallback._on_step, sb3_files.SafeCheckpointCallback._on_step

    def killed_at_20(self):
        if self.num_timesteps == 20:
            raise Killed
        return steps(self)

    def killed_at_checkpoint_16(self):
        if self.num_timesteps == 16:
            raise Killed
        return checkpoint(self)

    kills = {
        "cut": (sb3_kuka.BudgetCallback, killed_at_20),
        "mid": (sb3_files.SafeCheckpointCallback, killed_at_checkpoint_16),
    }
    for name, (callback, killed) in kills.items():
        with monkeypatch.context() as m:
            m.setattr(callback, "_on_step", killed)
            with pytest.raises(Killed):
                train_baseline("ppo", tiny, tmp_path / name)
        # both left candidate 16's row: "mid" drops it on resume (its checkpoint is missing)
        assert [r["at"] for r in validation_rows(tmp_path / name)] == [8, 16]
        summary = train_baseline("ppo", tiny, tmp_path / name, "--resume")
        rows = validation_rows(tmp_path / name)
        assert [r["at"] for r in rows] == [8, 16, 24] and rows[-1]["kept_at"] == 16
        assert summary["validation_episodes"] == 3 * V and summary["return_rule"]["kept_at"] == 16
        kept = tmp_path / name / "checkpoints" / "candidate_16_steps.safetensors"
        assert (tmp_path / name / "model.safetensors").read_bytes() == kept.read_bytes()
    # killed after the kept candidate: training before it is the full run's, so is the model
    a = _sb3_weights("ppo", tmp_path / "cut" / "model.safetensors")
    b = _sb3_weights("ppo", tmp_path / "full" / "model.safetensors")
    assert a.keys() == b.keys() and all(a[k].equal(b[k]) for k in a)
    assert full["return_rule"]["kept_at"] == 16


def test_a_killed_neat_run_resumes_with_the_same_returned_genome(
    tmp_path, tiny, scripted, monkeypatch
):
    from evodevo.baselines import neat_kuka

    scripted[0].update(SCRIPT["neat"])
    train_baseline("neat", tiny, tmp_path / "full")
    original = neat_kuka.RunReporter.end_generation

    def killed_after_first(self, config, population, species_set):
        original(self, config, population, species_set)
        raise Killed

    with monkeypatch.context() as m:
        m.setattr(neat_kuka.RunReporter, "end_generation", killed_after_first)
        with pytest.raises(Killed):
            train_baseline("neat", tiny, tmp_path / "cut")
    assert [r["at"] for r in validation_rows(tmp_path / "cut")] == [0]
    train_baseline("neat", tiny, tmp_path / "cut", "--resume")
    assert validation_rows(tmp_path / "cut") == validation_rows(tmp_path / "full")
    a = json.loads((tmp_path / "cut" / "best_genome.json").read_text())
    b = json.loads((tmp_path / "full" / "best_genome.json").read_text())
    assert a == b


def test_the_cli_refuses_a_validation_seed_in_the_test_range_and_an_unknown_rule(tmp_path, tiny):
    with pytest.raises(ConfigError, match="evaluation.validation_seed=1000000 reads the locked"):
        train_baseline("ppo", tiny, tmp_path / "a", "--set", "evaluation.validation_seed=1000000")
    with pytest.raises(ConfigError, match="keep.rule must be one of"):
        train_baseline("ppo", tiny, tmp_path / "b", "--set", "keep.rule=best")


def test_table_4_2_states_each_learners_rule_and_the_test_range(tmp_path):
    from test_baselines_table import fixture_run

    from evodevo.baselines.table_4_2 import build_table, markdown

    validated = {"evolution": {"keep": "validated"}, "evaluation": {"validation_episodes": V}}
    grn = fixture_run(tmp_path, "grn", "grn", {"seed": 0, **validated}, 60.0, 100, 5, 10, [])
    ppo_cfg = {"seed": 0, "method": "ppo", "keep": {"rule": "validated"}, **validated}
    ppo = fixture_run(tmp_path, "ppo", "baseline", ppo_cfg, 60.0, 100, 4, 10, [])
    zero = fixture_run(tmp_path, "zero", "baseline", {"method": "zero"}, 0.0, 0, 3, 10, [])
    for run, candidates in ((grn, 15), (ppo, 16)):
        summary = json.loads((run / "summary.json").read_text())
        summary |= {
            "validation_episodes": candidates * V,
            "return_rule": {"candidates": candidates},
        }
        (run / "summary.json").write_text(json.dumps(summary))
    for ev in (grn, ppo, zero):  # tested on the locked test range
        result = json.loads((ev / "eval_test_0.json").read_text()) | {"test_seed": TEST.first}
        (ev / "eval_test_0.json").write_text(json.dumps(result))
    table, runs = build_table([grn, ppo, zero])
    md = markdown(table, runs, 0.5)
    assert f"test seed {TEST.first} (test range)" in md
    assert "Return rule: validated for every trained learner" in md
    assert f"the same {V} clean training-object episodes with seeds derive(20000, i)" in md
    assert f"| grn | 1 (0) | validated (best of 15 candidates on {V} validation episodes) |" in md
    assert f"| ppo | 1 (0) | validated (best of 16 candidates on {V} validation episodes) |" in md
    assert "| zero | 1 (0) | untrained |" in md
    assert [r.validation_episodes for r in table] == [15 * V, 16 * V, 0]
    # a learner returned by another rule is named, and the table says the rules differ
    config = json.loads((ppo / "config.json").read_text())
    config["config"]["keep"]["rule"] = "last"
    (ppo / "config.json").write_text(json.dumps(config))
    md = markdown(*build_table([grn, ppo, zero]), 0.5)
    assert "Return rules differ between learners (last, validated" in md
    assert "| ppo | 1 (0) | last (the final model) |" in md


def test_the_reproduce_reports_grn_tables_state_the_rule_and_the_test_range(tmp_path):
    from test_reproduce import _fixture

    from evodevo.reproduce.report import write_report

    cfg = _fixture(tmp_path)
    plain = tmp_path / "grn" / "plain_s0"
    test = json.loads((plain / "repro_test_noisy.json").read_text()) | {"test_seed": TEST.first}
    (plain / "repro_test_noisy.json").write_text(json.dumps(test))
    config = {"kind": "grn", "config": {"evolution": {"keep": "record"}}}
    (plain / "config.json").write_text(json.dumps(config))
    blind = {"kind": "grn", "config": {"evolution": {"keep": "last"}, "sensors": {"blind": True}}}
    (tmp_path / "grn" / "blind_s0" / "config.json").write_text(json.dumps(blind))
    md = write_report(tmp_path, cfg).read_text()
    assert f"Test episodes: first seed {TEST.first} (test range). Return rule: record" in md
    assert "| 30.0 % [" in md and "| record (lifetime champion) |" in md
    assert "| GRN (plain, pooled over seeds) | 80.0 % [" in md
    assert "blind GRN (no vision), seed 0 | 60.0 % [" in md
    assert "| last (last generation's best) |" in md and "| untrained |" in md
