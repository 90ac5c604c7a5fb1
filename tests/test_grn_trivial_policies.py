"""The trivial policies of SPEC §2.5 (all-zero, uniform random, constant turn) and the baseline
file that every evaluation reuses: policies added later are run, the ones present are kept."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_grn_evaluator import fake_config

from evodevo.errors import EvodevoError
from evodevo.grn.controller import BASELINES, make_policy
from evodevo.grn.evaluation import evaluate_baselines


def test_turn_policy_only_turns_the_gripper():
    pol = make_policy(fake_config(), 3, baseline="turn")
    a = pol.step(None, np.arange(4), None, np.zeros((4, 4)), [], np.zeros(4, bool))
    assert a.shape == (4, 3)
    assert np.array_equal(a, np.tile([0.0, 0.0, -1.0], (4, 1)))
    assert set(BASELINES) == {"zero", "random", "turn", "scripted", "scripted_memory"}


def test_baseline_file_is_completed_not_recomputed(tmp_path):
    cfg = fake_config()
    out = tmp_path / "baselines_test.json"
    first = evaluate_baselines(cfg, out, episodes=6, policies=["zero"])
    assert set(first["baselines"]) == {"zero"}
    # mark the stored zero result: if it were recomputed, the mark would be gone
    data = json.loads(out.read_text())
    data["baselines"]["zero"]["marker"] = 1
    out.write_text(json.dumps(data))
    full = evaluate_baselines(cfg, out, episodes=6)
    assert set(full["baselines"]) == {"zero", "random", "turn"}
    assert full["baselines"]["zero"]["marker"] == 1
    rows = (tmp_path / "baselines_test_episodes.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * 6
    # other episodes: nothing is reused
    other = evaluate_baselines(cfg, out, episodes=4, policies=["turn"])
    assert set(other["baselines"]) == {"turn"} and "marker" not in str(other)


def test_unknown_baseline_policy_is_a_clear_error(tmp_path):
    with pytest.raises(EvodevoError, match="'still'.*zero, random, turn"):
        evaluate_baselines(fake_config(), tmp_path / "b.json", episodes=2, policies=["still"])
