"""``evolution.keep: record``: the returned genome is the champion by lifetime success record
(SPEC §2.4 leaves the returned genome open; the thesis keeps the last generation's best).
On the cheap fake env."""

from __future__ import annotations

import numpy as np
import pytest
from test_grn_evaluator import _Stop, _StopAfterFirst, fake_config, history, record_evaluations

from evodevo.errors import ConfigError
from evodevo.grn.controller import make_controller
from evodevo.grn.encoder import Encoder
from evodevo.grn.evaluator import Evaluator, genome_key
from evodevo.grn.evolution import Evolution, evolve_run
from evodevo.stats import wilson_interval

RECORD = {"population": 5, "elite_fraction": 0.4, "generations": 4, "early_stop": False}


def _key(g) -> str:
    return genome_key(g)[1]  # type: ignore[index]


def test_records_accumulate_every_generation_and_the_champion_is_returned(tmp_path):
    cfg = fake_config(seed=1, evolution={**RECORD, "keep": "record"})
    with Evaluator(cfg, Encoder.from_seed(0)) as ev:
        evo = Evolution(cfg, make_controller(cfg, ev.n_actions), ev)
        recorded = record_evaluations(ev)
        evo.run()
    calls = [(genomes, res.success) for genomes, _, res in recorded]
    want: dict[str, list[int]] = {}
    for genomes, success in calls:  # each distinct genome once per generation
        firsts = {}
        for i, g in enumerate(genomes):
            firsts.setdefault(_key(g), i)
        for k, i in firsts.items():
            rec = want.setdefault(k, [0, 0])
            rec[0] += int(success[i].sum())
            rec[1] += success.shape[1]
    assert evo.records == want
    assert max(n for _, n in want.values()) > 3  # some elite was evaluated more than once
    champ = evo.champion_key
    assert champ is not None and evo.best_genome is evo.champion
    assert _key(evo.champion) == champ
    bound = wilson_interval(*want[champ])[0]
    last_generation = {_key(g) for g in calls[-1][0]}
    assert all(wilson_interval(*want[k])[0] <= bound for k in last_generation)
    # selection is untouched: the same trajectory as keep: last
    evolve_run(cfg, tmp_path / "record", progress=False)
    last = fake_config(seed=1, evolution=RECORD)
    evolve_run(last, tmp_path / "last", progress=False)
    assert history(tmp_path / "record") == history(tmp_path / "last")


def test_clones_share_one_record_and_the_champion_changes_only_when_beaten():
    cfg = fake_config(evolution={**RECORD, "keep": "record"})
    ctrl = make_controller(cfg, 3)
    rng = np.random.default_rng(0)
    g, h = ctrl.init_genome(rng), ctrl.init_genome(rng)
    clone = ctrl.genome_from_arrays(g.arrays())
    evo = Evolution.__new__(Evolution)
    evo.records, evo.champion, evo.champion_key = {}, None, None
    evo.population = [g, clone, h]
    evo.update_records(np.array([[1, 1, 1], [1, 1, 1], [0, 0, 0]], bool), np.array([0, 1, 2]))
    assert evo.records == {_key(g): [3, 3], _key(h): [0, 3]}  # the clone counted once
    assert evo.champion is g
    # g fails 3, h wins 3: both at 3 of 6; a tie keeps the champion
    evo.update_records(np.array([[0, 0, 0], [0, 0, 0], [1, 1, 1]], bool), np.array([2, 0, 1]))
    assert evo.records[_key(g)] == evo.records[_key(h)] == [3, 6] and evo.champion is g
    evo.update_records(np.array([[0, 0, 0], [0, 0, 0], [1, 1, 1]], bool), np.array([2, 0, 1]))
    assert evo.champion is h and evo.champion_record() == {
        "successes": 6, "episodes": 9, "lower_bound": wilson_interval(6, 9)[0],
    }  # fmt: skip


def test_an_interrupted_record_run_resumes_with_its_records(tmp_path):
    import json

    cfg = fake_config(evolution={**RECORD, "generations": 3, "keep": "record"})
    full = evolve_run(cfg, tmp_path / "full", progress=False)
    with pytest.raises(_Stop):
        evolve_run(cfg, tmp_path / "cut", callbacks=[_StopAfterFirst()], progress=False)
    cut = evolve_run(cfg, tmp_path / "cut", resume=True, progress=False)
    assert cut["champion"] == full["champion"] and full["kept"] == "record"
    a = np.load(tmp_path / "full" / "best_genome.npz")
    b = np.load(tmp_path / "cut" / "best_genome.npz")
    assert all(a[k].tobytes() == b[k].tobytes() for k in a.files if k != "__meta__")
    assert json.loads((tmp_path / "full" / "summary.json").read_text())["champion"]["episodes"] >= 3


def test_keep_values_are_checked():
    with pytest.raises(ConfigError, match="evolution.keep must be one of"):
        fake_config(evolution={"keep": "best"})
    with pytest.raises(ConfigError, match="keep=record and final_pick_episodes"):
        fake_config(evolution={"keep": "record", "elite_fraction": 0.5, "final_pick_episodes": 4})
