"""A pre-registered experiment, decided from its runs' result files (SPEC §6).

The experiments of ``docs/results/claims.md`` each compare a few arms, trained with the same
run seeds, by one score per run: the success on the same locked-range test episodes (G1-G6) or
a number of a BIARM run (E2-E4). Their registration (arms, runs, margin δ, the comparisons that
decide and the claim they decide) is written down before the runs; this module reads it from a
YAML file, reads the runs' result files (:mod:`~evodevo.evidence.result_files`) and decides it;
:mod:`~evodevo.evidence.experiment_table` writes the tables, so the verdict is redrawn from the
committed files by one command (``evodevo compare experiment SPEC.yaml``).

The spec, e.g. ``docs/results/claims/g1.yaml``::

    name: G1
    title: Does gene regulation help on today's grasping task?
    root: regulation            # the runs' folder, relative to the spec file
    seeds: 0-7                  # the registered run seeds of every arm
    delta: 5                    # δ in success points
    arms:                       # name: result file of seed {seed} (JSON of `grn evaluate --json`)
      grn: grn_s{seed}/test_locked.json
      noreg: noreg_s{seed}/test_locked.json
    decision: [grn - noreg, grn - linear]   # the Holm family that decides
    beside: [grn - mlp]                     # reported, each alone, outside the decision
    claim: higher               # what "supported" means (below)

With ``metric: success`` (the default), a result file is what ``grn evaluate`` /
``baselines evaluate`` write with ``--json``
(``successes``, ``episodes``, ``test_seed``, ``objects``); ``file.json#clean`` reads its
``clean`` part (the noise-free test of a noisy evaluation). A run's score is
``100 × successes / episodes``. Every file of an experiment must come from the same test
episodes (objects, first seed, count), or the experiment refuses.

An untrained reference policy tested once on the same episodes is an arm whose file has no
``{seed}``: e.g. ``turn: baselines_locked.json#baselines.turn`` (a ``grn baselines`` file);
its one score stands beside every run seed.

With ``metric: value`` each arm names a number inside a JSON file by a key path
(:func:`~evodevo.evidence.result_files.lookup`), e.g. a BIARM run's final return on one task, and δ is given as ``delta`` or
as ``delta_task`` (the task's return margin, :func:`evodevo.evidence.normalise.return_margin`)::

    metric: value
    delta_task: LunarLander-v3
    test_key: eval_seeds        # every run must have been tested on the same seeds
    arms:
      biarm: v1/runs/biarm__s{seed}/summary.json#tasks[env_id=LunarLander-v3].final_return

Each comparison ``a - b`` is paired by seed (:func:`evodevo.evidence.verdict.compare`: exact
sign-flip test, bootstrap interval of the mean difference, δ), Holm-corrected over
``decision``. The claim is read from the decision's verdicts:

* ``higher`` — **supported** when every comparison is "different" with ``a`` higher;
  **refuted** when any is "equivalent within δ" or "different" with ``b`` higher;
* ``higher_by_delta`` — as ``higher``, but supported only when every mean difference is also
  larger than δ (the registrations that say "above ... by more than δ");
* ``equivalent`` — **supported** when every comparison is "equivalent within δ"; **refuted**
  when any is "different" with ``|mean difference| > δ``;
* otherwise **inconclusive**. ``claim_on`` reads the claim on some of the decision's
  comparisons only, ``claim_groups`` once per named group of them (the Holm family stays the
  whole decision). Until every arm of a comparison has all its registered runs the
  reading is **pending (k of n runs)**, with the numbers so far.

A design can make "supported" impossible before any run: with ``n`` runs the exact sign-flip
test cannot go below ``2 / 2**n``, and Holm multiplies the family's smallest p by the number
of comparisons ``m``, so no claim that needs "different" can be supported when
``m * 2 / 2**n >= 0.05`` (6 runs and 3 comparisons: 0.094).
:attr:`ExperimentSpec.smallest_decision_p` is that floor; the table states it, and a reading
whose design cannot support its claim says so.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from evodevo.config import doc, from_dict, read_yaml
from evodevo.errors import ConfigError, EvodevoError
from evodevo.evidence.aggregate import AGGREGATES, DEFAULT_REPS, interval_estimates
from evodevo.evidence.normalise import SUCCESS_RATE_MARGIN
from evodevo.evidence.paired import smallest_sign_flip_p
from evodevo.evidence.result_files import read_success, read_value
from evodevo.evidence.verdict import (
    ALPHA,
    DIFFERENT,
    EQUIVALENT,
    Comparison,
    compare,
    holm_table,
)
from evodevo.seeding import parse_seeds
from evodevo.stats import rate

__all__ = [
    "ExperimentSpec",
    "ArmScores",
    "ExperimentResult",
    "load_experiment",
    "read_arms",
    "decide_experiment",
]

Claim = Literal["higher", "higher_by_delta", "equivalent", "none"]


@dataclass
class ExperimentSpec:
    """The registration of one experiment (module docstring; SPEC §6)."""

    name: str = doc("", "Short name, as in claims.md (G1).")
    title: str = doc("", "The question the experiment answers.")
    root: str = doc(".", "Folder of the runs, relative to the spec file.")
    seeds: str = doc("", "Registered run seeds of every arm (e.g. 0-7).")
    metric: Literal["success", "value"] = doc(
        "success", "success: 100 x successes / episodes of each file; value: a number in it."
    )
    delta: float | None = doc(
        None, "Equivalence margin δ in the metric's units (success: default 5 points)."
    )
    delta_task: str | None = doc(
        None, "Instead of delta: the return margin of this task (evidence.normalise)."
    )
    test_key: str | None = doc(
        None, "value metric: a key path whose value every file must share (e.g. eval_seeds)."
    )
    arms: dict[str, str] = doc({}, "Arm name -> result file of seed {seed} (optionally #path).")
    decision: list[str] = doc([], "Comparisons 'a - b' that decide, Holm-corrected together.")
    beside: list[str] = doc([], "Comparisons reported outside the decision, each alone.")
    claim_on: list[str] = doc(
        [], "The decision's comparisons the claim is read from (default: all of them)."
    )
    claim_groups: dict[str, list[str]] = doc(
        {}, "Instead of claim_on: one reading per named group of the decision's comparisons."
    )
    claim: Claim = doc(
        "higher", "What the decision supports: a higher (by more than δ), or a within δ of b."
    )
    target: float | None = doc(None, "A goal for an arm's pooled success, in points (or none).")
    run_columns: dict[str, str] = doc(
        {},
        "Descriptive columns beside the arm table: label -> FILE#key.path in each run's folder "
        "(the folder of the arm's result file), e.g. 'training wall time (s)': "
        "summary.json#wall_s; mean [min, max] over the runs that have it. Decides nothing.",
    )
    reps: int = doc(DEFAULT_REPS, "Bootstrap resamples of every interval.")

    def validate(self) -> None:
        if not self.name:
            raise ConfigError("name: give the experiment's short name (e.g. G1)")
        if not self.arms:
            raise ConfigError("arms: name at least two arms and their result files")
        for arm, template in self.arms.items():
            if "{seed}" not in template and self.metric != "success":
                raise ConfigError(
                    f"arms.{arm}: {template!r} has no {{seed}}; write the result file of seed "
                    "{seed}, e.g. runs/biarm__s{seed}/summary.json#tasks[0].final_return"
                )
        if not self.decision:
            raise ConfigError("decision: name at least one comparison 'a - b'")
        for key in ("decision", "beside", "claim_on"):
            for item in getattr(self, key):
                self.pair(item, key)
        decided = {self.pair(t) for t in self.decision}
        if self.claim_on and self.claim_groups:
            raise ConfigError("claim_on and claim_groups: give one of them, not both")
        groups = {f"claim_groups.{g}": items for g, items in self.claim_groups.items()}
        for key, items in {"claim_on": self.claim_on, **groups}.items():
            for item in items:
                if self.pair(item, key) not in decided:
                    raise ConfigError(f"{key}: {item!r} is not one of the decision's comparisons")
            if key != "claim_on" and not items:
                raise ConfigError(f"{key}: name at least one comparison of the decision")
        if self.delta is not None and self.delta_task is not None:
            raise ConfigError("delta and delta_task: give one of them, not both")
        if self.metric == "value":
            if self.delta is None and self.delta_task is None:
                raise ConfigError("delta: a value metric needs delta or delta_task")
            for arm, template in self.arms.items():
                if "#" not in template:
                    raise ConfigError(
                        f"arms.{arm}: {template!r} names no value; write FILE#key.path, e.g. "
                        "runs/biarm__s{seed}/summary.json#tasks[env_id=LunarLander-v3].final_return"
                    )
        if self.delta is not None and not self.delta > 0:
            raise ConfigError(f"delta: {self.delta} must be > 0")
        if self.reps < 1:
            raise ConfigError(f"reps: {self.reps} must be >= 1")
        for label, where in self.run_columns.items():
            file, _, key = where.partition("#")
            if not file or not key or "{seed}" in where or "/" in file:
                raise ConfigError(
                    f"run_columns.{label}: {where!r} must be FILE#key.path inside a run's "
                    "folder, e.g. summary.json#wall_s"
                )
        try:
            parse_seeds(self.seeds, "seeds")
        except EvodevoError as exc:
            raise ConfigError(str(exc)) from None

    @property
    def margin(self) -> float:
        """δ in the metric's units: ``delta``, the return margin of ``delta_task``, or 5 points."""
        if self.delta is not None:
            return float(self.delta)
        if self.delta_task is not None:
            from evodevo.evidence.normalise import return_margin, task_scale

            return float(return_margin(task_scale(self.delta_task)))
        return 100 * SUCCESS_RATE_MARGIN

    @property
    def smallest_decision_p(self) -> float:
        """The smallest Holm-adjusted p the registered runs can reach: ``m * 2 / 2**n`` for
        ``m`` comparisons in the decision and ``n`` run seeds (module docstring)."""
        n = len(parse_seeds(self.seeds, "seeds"))
        return min(1.0, len(self.decision) * smallest_sign_flip_p(n))

    @property
    def can_support(self) -> bool:
        """Whether the registered runs can read "supported" at all (claims that need
        "different" need :attr:`smallest_decision_p` below 0.05)."""
        return self.claim not in ("higher", "higher_by_delta") or self.smallest_decision_p < ALPHA

    @property
    def unit(self) -> str:
        """What the scores are, for the tables."""
        if self.metric == "success":
            return "success, points"
        return f"return, {self.delta_task}" if self.delta_task else "value"

    def pair(self, text: str, key: str = "decision") -> tuple[str, str]:
        """The arms ``(a, b)`` of comparison ``'a - b'``; an error naming the key otherwise."""
        parts = [p.strip() for p in text.split(" - ")]
        if len(parts) != 2 or not all(parts):
            raise ConfigError(f"{key}: {text!r} is not a comparison; write 'arm_a - arm_b'")
        for p in parts:
            if p not in self.arms:
                raise ConfigError(
                    f"{key}: {text!r} names arm {p!r}, which is not under arms "
                    f"(arms: {', '.join(self.arms)})"
                )
        return parts[0], parts[1]


def load_experiment(path: str | Path) -> tuple[ExperimentSpec, Path]:
    """The spec in YAML file ``path`` and the folder of its runs."""
    p = Path(path)
    spec = from_dict(ExperimentSpec, read_yaml(p, "experiment spec"), "")
    return spec, (p.parent / spec.root)


@dataclass
class ArmScores:
    """The runs of one arm found so far: per seed its score (and, for the success metric, its
    successes of ``episodes`` test episodes)."""

    name: str
    seeds: list[int] = field(default_factory=list)
    values: list[float] = field(default_factory=list)
    reference: bool = False
    """An untrained policy tested once (a file without ``{seed}``): its one score stands
    beside every run seed; its successes and episodes are that one test's."""
    successes: list[int] = field(default_factory=list)
    episodes: list[int] = field(default_factory=list)
    columns: dict[str, dict[int, float]] = field(default_factory=dict)
    """``run_columns``: label -> {seed: value} of the runs whose file has it."""

    def score(self, seed: int) -> float:
        """The score of the run of ``seed`` (success in points, or the value read)."""
        return self.values[self.seeds.index(seed)]


def read_arms(spec: ExperimentSpec, root: Path) -> tuple[dict[str, ArmScores], tuple[Any, ...]]:
    """Every arm's runs among the registered seeds (missing files are skipped) and the identity
    of the test they share (success: ``(objects, first test seed, episodes)``; value: the
    ``test_key`` value, or ``()``)."""
    arms: dict[str, ArmScores] = {}
    tests: dict[tuple[Any, ...], str] = {}
    for name, template in spec.arms.items():
        file, _, part = template.partition("#")
        scores = ArmScores(name)
        if "{seed}" not in template:  # a reference tested once (success metric only)
            path = root / file
            if path.is_file():
                k, n, test = read_success(path, part or None)
                scores.reference = True
                scores.seeds = parse_seeds(spec.seeds, "seeds")
                scores.values = [100.0 * k / n] * len(scores.seeds)
                scores.successes, scores.episodes = [k], [n]
                tests.setdefault(test, str(path))
            arms[name] = scores
            continue
        for seed in parse_seeds(spec.seeds, "seeds"):
            path = root / file.format(seed=seed)
            if not path.is_file():
                continue
            if spec.metric == "success":
                k, n, test = read_success(path, part or None)
                scores.successes.append(k)
                scores.episodes.append(n)
                scores.values.append(100.0 * k / n)
            else:
                got = read_value(path, part.format(seed=seed), spec.test_key)
                if got is None:
                    continue
                value, test = got
                scores.values.append(value)
            scores.seeds.append(seed)
            tests.setdefault(test, str(path))
            for label, value in _run_columns(spec, path.parent).items():
                scores.columns.setdefault(label, {})[seed] = value
        arms[name] = scores
    if len(tests) > 1:
        listed = "; ".join(f"{t} in {p}" for t, p in tests.items())
        raise EvodevoError(
            f"the runs of {spec.name} were tested on different episodes ({listed}); test them "
            "all on the same episodes (objects, first seed and number)"
        )
    if not tests:
        first = next(iter(spec.arms.values())).partition("#")[0]
        example = first.format(seed=parse_seeds(spec.seeds, "seeds")[0])
        raise EvodevoError(
            f"no result file of {spec.name} exists yet under {str(root)!r} (e.g. {example}); "
            "run the experiment's runs first"
        )
    return arms, next(iter(tests))


def _run_columns(spec: ExperimentSpec, run: Path) -> dict[str, float]:
    """The ``run_columns`` values of the run in folder ``run``; a file or key the run does not
    have leaves its column out."""
    found: dict[str, float] = {}
    for label, where in spec.run_columns.items():
        file, _, key = where.partition("#")
        if not (run / file).is_file():
            continue
        try:
            got = read_value(run / file, key, None)
        except EvodevoError:
            continue
        if got is not None:
            found[label] = got[0]
    return found


@dataclass
class ExperimentResult:
    """What :func:`decide_experiment` finds: arms, comparisons and the claim's reading."""

    spec: ExperimentSpec
    test: tuple[Any, ...]
    arms: dict[str, ArmScores]
    decision: list[Comparison]
    beside: list[Comparison]
    complete: bool
    reading: str
    runs_registered: int

    @functools.cached_property
    def arm_rows(self) -> list[dict[str, Any]]:
        """Per arm: runs, mean success over runs with its bootstrap interval, pooled rate."""
        scores = {
            n: np.array([a.score(s) for s in a.seeds])[:, None]
            for n, a in self.arms.items()
            if a.seeds
        }
        points, intervals = (
            interval_estimates(scores, AGGREGATES["Mean"], reps=self.spec.reps, seed=0)
            if scores
            else ({}, {})
        )
        rows = []
        for n, a in self.arms.items():
            pooled = rate(sum(a.successes), sum(a.episodes)) if a.successes else None
            row: dict[str, Any] = {
                "arm": n,
                "runs": "one test" if a.reference else len(a.seeds),
                "seeds": "(untrained)" if a.reference else ",".join(map(str, a.seeds)),
                "mean": float(points[n][0]) if n in points else None,
                "low": float(intervals[n][0, 0]) if n in intervals else None,
                "high": float(intervals[n][1, 0]) if n in intervals else None,
                "pooled_successes": sum(a.successes),
                "pooled_episodes": sum(a.episodes),
                "pooled": 100 * pooled.rate if pooled else None,
                "pooled_low": 100 * pooled.ci_low if pooled else None,
                "pooled_high": 100 * pooled.ci_high if pooled else None,
            }
            rows.append(row)
        return rows


def _compare(
    spec: ExperimentSpec, arms: Mapping[str, ArmScores], text: str, key: str
) -> Comparison | None:
    a, b = spec.pair(text, key)
    shared = [s for s in arms[a].seeds if s in arms[b].seeds]
    if len(shared) < 2:
        return None
    return compare(
        a,
        [arms[a].score(s) for s in shared],
        b,
        [arms[b].score(s) for s in shared],
        delta=spec.margin,
        reps=spec.reps,
        task=spec.unit,
    )


def _reading(claim: Claim, comps: Sequence[Comparison]) -> str:
    if claim == "none":
        return "; ".join(f"{c.a} − {c.b}: {c.verdict}" for c in comps)
    if claim in ("higher", "higher_by_delta"):
        floor = 0.0 if claim == "higher" else comps[0].delta
        if all(c.verdict == DIFFERENT and c.mean_diff > floor for c in comps):
            return "supported"
        if any(
            c.verdict == EQUIVALENT or (c.verdict == DIFFERENT and c.mean_diff < 0) for c in comps
        ):
            return "refuted"
        return "inconclusive"
    if all(c.verdict == EQUIVALENT for c in comps):
        return "supported"
    if any(c.verdict == DIFFERENT and abs(c.mean_diff) > c.delta for c in comps):
        return "refuted"
    return "inconclusive"


def decide_experiment(spec: ExperimentSpec, root: Path) -> ExperimentResult:
    """Read the runs of ``spec`` under ``root`` and decide it (module docstring)."""
    arms, test = read_arms(spec, root)
    n_reg = len(parse_seeds(spec.seeds, "seeds"))
    found = [c for t in spec.decision if (c := _compare(spec, arms, t, "decision")) is not None]
    decision = holm_table(found) if found else []
    beside = [c for t in spec.beside if (c := _compare(spec, arms, t, "beside")) is not None]
    in_decision = {a for t in spec.decision for a in spec.pair(t)}
    complete = len(decision) == len(spec.decision) and all(
        len(arms[a].seeds) == n_reg for a in in_decision
    )
    if complete:
        groups = spec.claim_groups or {"": spec.claim_on}
        found_readings = []
        for group, items in groups.items():
            on = {spec.pair(t) for t in items}
            r = _reading(spec.claim, [c for c in decision if not on or (c.a, c.b) in on])
            found_readings.append(f"{group}: {r}" if group else r)
        reading = "; ".join(found_readings)
    else:
        counts = ", ".join(f"{a} {len(arms[a].seeds)}" for a in spec.arms if a in in_decision)
        reading = f"pending (runs so far of the {n_reg} registered per arm: {counts})"
    if not spec.can_support:
        reading += (
            f" — this design cannot read 'supported': with {n_reg} runs and "
            f"{len(spec.decision)} comparison(s) under Holm the smallest attainable p is "
            f"{spec.smallest_decision_p:.3g} ≥ {ALPHA:g}"
        )
    return ExperimentResult(spec, test, arms, decision, beside, complete, reading, n_reg)
