"""Comparisons between learners (SPEC §6): hand-worked tests, verdicts, seeded rliable intervals."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from rliable import library as rly
from rliable import metrics

from evodevo import stats
from evodevo.errors import EvodevoError
from evodevo.evidence import aggregate as agg
from evodevo.evidence import normalise as nrm
from evodevo.evidence import paired, profiles, verdict

REPS = 500  # the knob for fewer resamples; reports use agg.DEFAULT_REPS = 10,000


# --- paired tests -----------------------------------------------------------------------------


def test_sign_flip_five_positive_differences_give_the_smallest_p():
    assert paired.sign_flip_test([0.3, 1.0, 2.0, 0.1, 5.0]) == 0.0625
    assert paired.smallest_sign_flip_p(5) == 0.0625


def test_sign_flip_hand_worked_vector():
    # d = (1, 2, 3, -0.5), |sum| = 5.5. Of the 16 sign patterns only (+,+,+,-), (+,+,+,+) and
    # their negations reach |sum| >= 5.5 (6.5, 5.5); flipping 1, 2 or 3 drops it to <= 4.5.
    assert paired.sign_flip_test([1.0, 2.0, 3.0, -0.5]) == 4 / 16


def test_sign_flip_matches_brute_force_enumeration():
    d = np.random.default_rng(3).normal(0.3, 1.0, size=9)
    obs = abs(d.sum())
    hits = sum(
        abs(sum(s * v for s, v in zip(signs, d, strict=True))) >= obs - 1e-9
        for signs in itertools.product((1, -1), repeat=d.size)
    )
    assert paired.sign_flip_test(d) == pytest.approx(hits / 2**d.size, abs=1e-15)


def test_monte_carlo_sign_flip_is_seeded_and_close_to_exact(monkeypatch):
    d = np.random.default_rng(4).normal(0.4, 1.0, size=12)
    exact = paired.sign_flip_test(d)
    monkeypatch.setattr(paired, "MAX_EXACT_RUNS", 5)
    mc = paired.sign_flip_test(d, seed=1, n_resamples=40_000)
    assert mc == paired.sign_flip_test(d, seed=1, n_resamples=40_000)
    assert mc != paired.sign_flip_test(d, seed=2, n_resamples=40_000)
    assert abs(mc - exact) < 0.01


def test_wilcoxon_exact_and_its_minimum_runs():
    # 10 distinct positive differences: only the all-positive rank pattern and its mirror reach
    # the observed statistic, p = 2 / 2**10.
    assert paired.wilcoxon_test(np.arange(1.0, 11.0)) == pytest.approx(2 / 1024)
    with pytest.raises(ValueError, match="from 10 runs"):
        paired.wilcoxon_test([1.0] * 9)


def test_holm_is_the_one_in_stats_and_hand_worked():
    assert paired.holm is stats.holm
    # sorted 0.01, 0.03, 0.04 -> 3*0.01, max(0.03, 2*0.03), max(0.06, 1*0.04)
    assert paired.holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])


def test_smallest_p_runs_for_alpha_and_mde():
    assert paired.runs_for_alpha(0.05) == 6  # 2/32 = 0.0625 >= 0.05 > 2/64
    # (z_0.975 + z_0.8) / sqrt(10) = (1.959964 + 0.841621) / 3.162278
    assert paired.minimum_detectable_difference(1.0, 10) == pytest.approx(0.885939, abs=1e-6)
    assert paired.minimum_detectable_difference(2.0, 40) == pytest.approx(
        paired.minimum_detectable_difference(1.0, 10)
    )


def test_paired_difference_interval_holds_the_mean():
    d = np.random.default_rng(5).normal(1.0, 0.5, size=10)
    e = paired.paired_difference_interval(d, reps=REPS, seed=0)
    assert e.point == pytest.approx(d.mean())
    assert e.low < e.point < e.high


# --- normalisation and δ ----------------------------------------------------------------------


def test_normalisation_of_known_values():
    s = nrm.TaskScale("MountainCar-v0", -200.0, -110.0)
    # (R + 200) / 90; -90 is past the threshold, so above 1 (not clipped)
    assert s.normalise([-200.0, -110.0, -155.0, -90.0]).tolist() == pytest.approx(
        [0.0, 1.0, 0.5, 110 / 90]
    )
    assert s.delta == pytest.approx(9.0)
    assert nrm.return_margin(s, normalised=True) == 0.1
    assert nrm.SUCCESS_RATE_MARGIN == 0.05


def test_default_tasks_use_the_gymnasium_thresholds_and_stored_random_returns():
    solved = {"CartPole-v1": 475.0, "Acrobot-v1": -100.0, "MountainCar-v0": -110.0}
    solved["LunarLander-v3"] = 200.0
    for env_id, r_solved in solved.items():
        s = nrm.task_scale(env_id)
        assert s.solved_return == r_solved
        assert s.random_return == nrm.RANDOM_RETURNS[env_id]


def test_stored_random_returns_are_what_the_function_measures():
    # the full stored measurement of the two fast tasks (CartPole 1000 episodes; MountainCar's
    # random policy never reaches the flag, so 100 episodes already give exactly -200)
    assert round(nrm.measure_random_return("CartPole-v1"), 3) == nrm.RANDOM_RETURNS["CartPole-v1"]
    assert nrm.measure_random_return("MountainCar-v0", 100) == nrm.RANDOM_RETURNS["MountainCar-v0"]


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # CartPole-v0 is an old version
def test_unknown_task_is_measured_on_demand_or_given():
    s = nrm.task_scale("CartPole-v0", episodes=20)
    assert s.random_return == nrm.measure_random_return("CartPole-v0", 20)
    assert s.solved_return == 195.0
    with pytest.raises(EvodevoError, match="no reward_threshold"):
        nrm.task_scale("Pendulum-v1", random_return=-1200.0)
    assert nrm.task_scale("Pendulum-v1", random_return=-1200.0, solved=-200.0).span == 1000.0
    with pytest.raises(EvodevoError, match="must exceed"):
        nrm.TaskScale("x", 10.0, 5.0)


def test_normalise_returns_matrix_shape_is_checked():
    scales = [nrm.TaskScale("a", 0.0, 10.0), nrm.TaskScale("b", -100.0, 0.0)]
    assert nrm.normalise_returns([[5.0, -50.0]], scales).tolist() == [[0.5, 0.5]]
    with pytest.raises(EvodevoError, match="do not match"):
        nrm.normalise_returns([[5.0, -50.0, 1.0]], scales)


# --- rliable aggregates -----------------------------------------------------------------------


def _scores(shift: float = 0.0, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.5 + shift, 0.2, size=(10, 4))


def test_iqm_interval_contains_the_iqm_and_is_reproducible():
    s = {"a": _scores()}
    a1 = agg.aggregate_scores(s, reps=REPS, seed=7)
    a2 = agg.aggregate_scores(s, reps=REPS, seed=7)
    iqm = a1.estimate("a", "IQM")
    assert iqm.point == pytest.approx(metrics.aggregate_iqm(s["a"]))
    assert iqm.low < iqm.point < iqm.high
    assert a1.estimate("a", "IQM") == a2.estimate("a", "IQM")
    assert a1.estimate("a", "Mean") == a2.estimate("a", "Mean")
    assert agg.aggregate_scores(s, reps=REPS, seed=8).estimate("a", "IQM") != iqm


def test_the_bootstrap_leaves_the_global_rng_alone():
    before = np.random.get_state()[1].copy()
    agg.aggregate_scores({"a": _scores()}, reps=50, seed=1)
    assert np.array_equal(np.random.get_state()[1], before)


def test_seeded_bootstrap_reproduces_rliable_given_its_global_draws():
    # rliable draws its indices from the global RNG; handed a RandomState in that state, ours
    # gives rliable's interval to the last bit, so only the source of randomness differs.
    x = _scores()

    def func(s):
        return np.array([metrics.aggregate_iqm(s)])

    saved = np.random.get_state()
    try:
        np.random.seed(11)
        _, theirs = rly.get_interval_estimates({"a": x}, func, reps=300)
    finally:
        np.random.set_state(saved)
    _, ours = agg.interval_estimates({"a": x}, func, reps=300, seed=np.random.RandomState(11))
    assert np.array_equal(theirs["a"], ours["a"])


def test_probability_of_improvement_of_a_dominating_learner():
    s = {"x": _scores(shift=10.0), "y": _scores(seed=1)}
    poi = agg.probability_of_improvement(s, [("x", "y"), ("y", "x")], reps=REPS, seed=0)
    assert poi[("x", "y")].point == 1.0 and poi[("x", "y")].low > 0.99
    assert poi[("y", "x")].point == 0.0 and poi[("y", "x")].high < 0.01
    with pytest.raises(KeyError, match="'z'"):
        agg.probability_of_improvement(s, [("x", "z")], reps=10)


def test_performance_profile_is_a_decreasing_fraction():
    taus = np.linspace(0.0, 1.0, 11)
    p = agg.performance_profiles({"a": _scores()}, taus, reps=100, seed=0)
    prof = p.profiles["a"]
    assert prof[0] == pytest.approx(np.mean(_scores() > 0.0))
    assert np.all(np.diff(prof) <= 0)
    assert np.all(p.intervals["a"][0] <= prof + 1e-12)
    assert np.all(prof <= p.intervals["a"][1] + 1e-12)


def test_scores_must_be_a_runs_by_tasks_matrix():
    with pytest.raises(ValueError, match="runs x tasks"):
        agg.aggregate_scores({"a": np.ones(5)}, reps=10)
    with pytest.raises(ValueError, match="NaN"):
        agg.aggregate_scores({"a": np.array([[1.0], [np.nan]])}, reps=10)


# --- verdicts ---------------------------------------------------------------------------------


def test_clear_difference_reads_different():
    rng = np.random.default_rng(0)
    b = rng.normal(0.3, 0.05, size=10)
    c = verdict.compare("A", b + 0.5 + rng.normal(0, 0.05, 10), "B", b, delta=0.1, reps=REPS)
    assert c.verdict == verdict.DIFFERENT and c.runs_needed is None
    assert c.p == pytest.approx(2 / 1024) and c.low > 0


def test_tiny_differences_with_many_runs_read_equivalent():
    rng = np.random.default_rng(1)
    b = rng.normal(0.5, 0.2, size=40)
    c = verdict.compare("A", b + rng.normal(0, 0.01, 40), "B", b, delta=0.1, reps=REPS)
    assert c.verdict == verdict.EQUIVALENT
    assert c.low >= -0.1 and c.high <= 0.1


def test_few_noisy_runs_read_inconclusive_with_the_runs_a_decision_needs():
    c = verdict.compare("A", [0.9, 0.2, 0.6], "B", [0.6, 0.4, 0.5], delta=0.1, reps=REPS)
    assert c.verdict == verdict.INCONCLUSIVE
    assert c.runs_needed is not None and c.runs_needed > c.n
    assert c.runs_needed == verdict.runs_needed(c.mean_diff, c.std_diff, 0.1, 3)


def test_runs_needed_hand_worked():
    # equivalence route: (1.959964 * 1 / (0.5 - 0)) ** 2 = 15.37 -> 16 runs
    assert verdict.runs_needed(0.0, 1.0, delta=0.5, n=5) == 16
    # difference route: (2.801585 * 1 / 1) ** 2 = 7.85 -> 8 runs (equivalence impossible)
    assert verdict.runs_needed(1.0, 1.0, delta=0.5, n=5) == 8
    # no noise: the sign-flip test alone needs 6 runs at alpha 0.05, 7 at 0.05 / 3
    assert verdict.runs_needed(1.0, 0.0, delta=0.5, n=2) == 6
    assert verdict.runs_needed(1.0, 0.0, delta=0.5, n=2, family_size=3) == 7
    # never fewer than one more run than we have
    assert verdict.runs_needed(1.0, 0.0, delta=0.5, n=9) == 10


def test_holm_over_a_table_can_turn_different_into_inconclusive():
    win = verdict.compare(
        "A", [1.0, 1.2, 1.1, 1.3, 0.9, 1.0], "B", [0.0] * 6, 0.1, reps=REPS, task="CartPole-v1"
    )
    assert win.p == pytest.approx(1 / 32) and win.verdict == verdict.DIFFERENT
    null = verdict.compare("C", [0.1, -0.1] * 3, "B", [0.0] * 6, 0.1, reps=REPS)
    table = verdict.holm_table([win, null, null])
    assert table[0].p_adj == pytest.approx(3 / 32)
    assert table[0].verdict == verdict.INCONCLUSIVE
    assert table[0].runs_needed == 7  # 2 / 2**7 < 0.05 / 3
    md = verdict.to_markdown(table)
    assert md.count("\n") == 4 and "needs ≈ 7 runs" in md
    assert md.splitlines()[2].startswith("| CartPole-v1 | A − B | 6 | 1.08 [")
    assert md.splitlines()[2].count("|") == verdict.Comparison.HEADER.splitlines()[0].count("|")


def test_decide_rules_and_bad_input():
    assert verdict.decide(0.01, 0.05, 0.001, delta=0.1) == verdict.DIFFERENT  # wins over equiv.
    assert verdict.decide(0.01, 0.05, 0.2, delta=0.1) == verdict.EQUIVALENT
    assert verdict.decide(-0.2, 0.05, 0.2, delta=0.1) == verdict.INCONCLUSIVE
    # a small p is not enough: the interval must exclude 0 as well
    assert verdict.decide(-0.05, 0.3, 0.01, delta=0.1) == verdict.INCONCLUSIVE
    with pytest.raises(ValueError, match="delta"):
        verdict.decide(0.0, 0.1, 0.5, delta=0.0)
    with pytest.raises(ValueError, match="same training seeds"):
        verdict.compare("A", [1.0, 2.0], "B", [1.0], delta=0.1)


# --- figures ----------------------------------------------------------------------------------


def test_figures_are_written_from_the_arrays(tmp_path):
    s = {"a": _scores(), "b": _scores(shift=0.2, seed=2)}
    p = agg.performance_profiles(s, np.linspace(0.0, 1.2, 13), reps=50, seed=0)
    out = profiles.plot_performance_profiles(p, tmp_path / "fig" / "profile.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    a = agg.aggregate_scores(s, reps=50, seed=0)
    out = profiles.plot_interval_estimates(
        a.points, a.intervals, a.metric_names, tmp_path / "iqm.pdf"
    )
    assert out.read_bytes()[:4] == b"%PDF"
    with pytest.raises(ValueError, match="do not match"):
        profiles.plot_interval_estimates(a.points, a.intervals, ["IQM"], tmp_path / "x.png")
