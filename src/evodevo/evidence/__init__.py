"""Comparisons between learners, with the training run as the unit (SPEC §6).

* :mod:`~evodevo.evidence.normalise` — returns to [0, 1] per task (random policy → 0, solved
  threshold → 1) and the margin δ;
* :mod:`~evodevo.evidence.aggregate` — IQM, mean, probability of improvement and performance
  profiles over runs × tasks with seeded stratified-bootstrap intervals (rliable);
* :mod:`~evodevo.evidence.paired` — paired run-level tests on seeds (exact sign-flip, Wilcoxon),
  Holm, the smallest p and the minimum detectable difference of n runs;
* :mod:`~evodevo.evidence.verdict` — "different", "equivalent within δ" or "inconclusive",
  with the runs a decision needs;
* :mod:`~evodevo.evidence.profiles` — the figures, from the same arrays as the tables;
* :mod:`~evodevo.evidence.experiment` — a pre-registered experiment from a YAML file, decided
  from its runs' result files (:mod:`~evodevo.evidence.result_files`), with its tables
  (:mod:`~evodevo.evidence.experiment_table`; ``evodevo compare experiment``).

Statistics of one run's episodes (Wilson, McNemar, bootstrap of a run's mean) stay in
:mod:`evodevo.stats`; they never compare learners.
"""

from evodevo.evidence.aggregate import (
    DEFAULT_REPS,
    Aggregates,
    Estimate,
    Profiles,
    aggregate_scores,
    interval_estimates,
    performance_profiles,
    probability_of_improvement,
)
from evodevo.evidence.normalise import (
    RANDOM_RETURNS,
    RETURN_MARGIN_FRACTION,
    SUCCESS_RATE_MARGIN,
    TaskScale,
    measure_random_return,
    normalise_returns,
    return_margin,
    task_scale,
)
from evodevo.evidence.paired import (
    holm,
    minimum_detectable_difference,
    paired_difference_interval,
    sign_flip_test,
    smallest_sign_flip_p,
    wilcoxon_test,
)
from evodevo.evidence.profiles import plot_interval_estimates, plot_performance_profiles
from evodevo.evidence.verdict import Comparison, compare, decide, holm_table, runs_needed

__all__ = [
    "DEFAULT_REPS",
    "Aggregates",
    "Estimate",
    "Profiles",
    "aggregate_scores",
    "interval_estimates",
    "performance_profiles",
    "probability_of_improvement",
    "RANDOM_RETURNS",
    "RETURN_MARGIN_FRACTION",
    "SUCCESS_RATE_MARGIN",
    "TaskScale",
    "measure_random_return",
    "normalise_returns",
    "return_margin",
    "task_scale",
    "holm",
    "minimum_detectable_difference",
    "paired_difference_interval",
    "sign_flip_test",
    "smallest_sign_flip_p",
    "wilcoxon_test",
    "plot_interval_estimates",
    "plot_performance_profiles",
    "Comparison",
    "compare",
    "decide",
    "holm_table",
    "runs_needed",
]
