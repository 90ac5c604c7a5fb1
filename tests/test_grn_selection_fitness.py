"""Eq. 4.6 fitness, tournament selection and elitism (SPEC §2.4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evodevo.grn.fitness import fitness, fitness_matrix
from evodevo.grn.selection import elite_indices, rank, tournament


def test_fitness_hand_worked():
    # rewards 1,0,1,1: mean 0.75, std sqrt(0.1875), S = 0.75
    c = 1 / (1 + math.sqrt(0.1875))
    assert fitness([1, 0, 1, 1], [1, 0, 1, 1]) == pytest.approx(0.75 + 7.5 + 2 * c + 0.75)
    # all successes: 1 + 10 + 2 + min(1, 0.8) = 13.8
    assert fitness([1] * 10, [True] * 10) == pytest.approx(13.8)
    # all failures: 0 + 0 + 2 + 0
    assert fitness([0] * 10, [False] * 10) == pytest.approx(2.0)
    m = fitness_matrix(np.array([[1.0, 1.0], [0.0, 0.0]]), np.array([[True, True], [False, False]]))
    np.testing.assert_allclose(m, [13.8, 2.0])


def test_rank_and_elites_are_stable():
    f = np.array([1.0, 5.0, 5.0, 3.0])
    assert rank(f).tolist() == [1, 2, 3, 0]
    assert elite_indices(f, 2).tolist() == [1, 2]


def test_tournament_picks_the_fittest_entrant():
    f = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    rng = np.random.default_rng(0)
    picks = [tournament(f, 3, rng) for _ in range(500)]
    counts = np.bincount(picks, minlength=5)
    assert counts[0] == 0 and counts[1] == 0  # never the best of 3 distinct entrants
    # P(best = 4) = 1 - C(4,3)/C(5,3) = 0.6, P(best = 3) = 0.3, P(best = 2) = 0.1
    np.testing.assert_allclose(counts / 500, [0, 0, 0.1, 0.3, 0.6], atol=0.06)
    assert tournament(f, 10, rng) == 4  # larger than the population: everyone takes part
