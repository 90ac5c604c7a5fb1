"""A pre-registered success-rate experiment, decided from its runs' test files (SPEC §6).

The Kuka experiments of ``docs/results/claims.md`` (G1-G6) each compare a few arms, trained
with run seeds ``0..n-1``, by their success on the same locked-range test episodes. Their
registration (arms, runs, margin δ, the comparisons that decide and the claim they decide) is
written down before the runs; this module reads that registration from a YAML file and the
runs' test results, and writes the tables that decide it, so the verdict is redrawn from the
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

A result file is what ``grn evaluate`` / ``baselines evaluate`` write with ``--json``
(``successes``, ``episodes``, ``test_seed``, ``objects``); ``file.json#clean`` reads its
``clean`` part (the noise-free test of a noisy evaluation). A run's score is
``100 × successes / episodes``. Every file of an experiment must come from the same test
episodes (objects, first seed, count), or the experiment refuses.

Each comparison ``a - b`` is paired by seed (:func:`evodevo.evidence.verdict.compare`: exact
sign-flip test, bootstrap interval of the mean difference, δ), Holm-corrected over
``decision``. The claim is read from the decision's verdicts:

* ``higher`` — **supported** when every comparison is "different" with ``a`` higher;
  **refuted** when any is "equivalent within δ" or "different" with ``b`` higher;
* ``equivalent`` — **supported** when every comparison is "equivalent within δ"; **refuted**
  when any is "different" with ``|mean difference| > δ``;
* otherwise **inconclusive**. Until every arm of a comparison has all its registered runs the
  reading is **pending (k of n runs)**, with the numbers so far.
"""

from __future__ import annotations

import csv
import functools
import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from evodevo.config import doc, from_dict, read_yaml
from evodevo.errors import ConfigError, EvodevoError
from evodevo.evidence.aggregate import AGGREGATES, DEFAULT_REPS, interval_estimates
from evodevo.evidence.verdict import (
    DIFFERENT,
    EQUIVALENT,
    Comparison,
    compare,
    holm_table,
    to_markdown,
)
from evodevo.seed_split import range_label
from evodevo.seeding import parse_seeds
from evodevo.stats import rate

__all__ = [
    "ExperimentSpec",
    "ArmScores",
    "ExperimentResult",
    "load_experiment",
    "read_arms",
    "decide_experiment",
    "write_experiment",
]

Claim = Literal["higher", "equivalent", "none"]


@dataclass
class ExperimentSpec:
    """The registration of one success-rate experiment (module docstring; SPEC §6)."""

    name: str = doc("", "Short name, as in claims.md (G1).")
    title: str = doc("", "The question the experiment answers.")
    root: str = doc(".", "Folder of the runs, relative to the spec file.")
    seeds: str = doc("", "Registered run seeds of every arm (e.g. 0-7).")
    delta: float = doc(5.0, "Equivalence margin δ in success points, fixed before the runs.")
    arms: dict[str, str] = doc({}, "Arm name -> result file of seed {seed} (optionally #part).")
    decision: list[str] = doc([], "Comparisons 'a - b' that decide, Holm-corrected together.")
    beside: list[str] = doc([], "Comparisons reported outside the decision, each alone.")
    claim: Claim = doc("higher", "What the decision supports: a higher, or a within δ of b.")
    target: float | None = doc(None, "A goal for an arm's pooled success, in points (or none).")
    reps: int = doc(DEFAULT_REPS, "Bootstrap resamples of every interval.")

    def validate(self) -> None:
        if not self.name:
            raise ConfigError("name: give the experiment's short name (e.g. G1)")
        if not self.arms:
            raise ConfigError("arms: name at least two arms and their result files")
        for arm, template in self.arms.items():
            if "{seed}" not in template:
                raise ConfigError(
                    f"arms.{arm}: {template!r} has no {{seed}}; write the result file of seed "
                    "{seed}, e.g. grn_s{seed}/test_locked.json"
                )
        if not self.decision:
            raise ConfigError("decision: name at least one comparison 'a - b'")
        for key in ("decision", "beside"):
            for item in getattr(self, key):
                self.pair(item, key)
        if not self.delta > 0:
            raise ConfigError(f"delta: {self.delta} must be > 0 (points of success)")
        if self.reps < 1:
            raise ConfigError(f"reps: {self.reps} must be >= 1")
        try:
            parse_seeds(self.seeds, "seeds")
        except EvodevoError as exc:
            raise ConfigError(str(exc)) from None

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
    """The tested runs of one arm: per seed its successes of ``episodes`` test episodes."""

    name: str
    seeds: list[int] = field(default_factory=list)
    successes: list[int] = field(default_factory=list)
    episodes: list[int] = field(default_factory=list)

    def score(self, seed: int) -> float:
        """Success in points of the run of ``seed``."""
        i = self.seeds.index(seed)
        return 100.0 * self.successes[i] / self.episodes[i]


def _read_result(path: Path, part: str | None) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise EvodevoError(
            f"result file {str(path)!r} cannot be read as JSON ({exc}); rerun its test "
            "(`evodevo grn evaluate RUN --json > FILE`)"
        ) from None
    if not isinstance(data, dict):
        raise EvodevoError(f"result file {str(path)!r} holds no test result (not a mapping)")
    src: Any = data.get(part) if part else data
    if not isinstance(src, dict) or "successes" not in src or "episodes" not in data:
        what = f"a {part!r} part with successes" if part else "successes and episodes"
        raise EvodevoError(f"result file {str(path)!r} has no {what}; is it a test result?")
    return {
        "successes": int(src["successes"]),
        "episodes": int(data["episodes"]),
        "test": (str(data.get("objects")), int(data.get("test_seed", -1)), int(data["episodes"])),
    }


def read_arms(
    spec: ExperimentSpec, root: Path
) -> tuple[dict[str, ArmScores], tuple[str, int, int]]:
    """Every arm's tested runs among the registered seeds (missing runs are skipped), and the
    test they share: ``(objects, first test seed, episodes)``."""
    arms: dict[str, ArmScores] = {}
    tests: dict[tuple[str, int, int], str] = {}
    for name, template in spec.arms.items():
        file, _, part = template.partition("#")
        scores = ArmScores(name)
        for seed in parse_seeds(spec.seeds, "seeds"):
            path = root / file.format(seed=seed)
            if not path.is_file():
                continue
            res = _read_result(path, part or None)
            scores.seeds.append(seed)
            scores.successes.append(res["successes"])
            scores.episodes.append(res["episodes"])
            tests.setdefault(res["test"], str(path))
        arms[name] = scores
    if len(tests) > 1:
        listed = "; ".join(f"{t} in {p}" for t, p in tests.items())
        raise EvodevoError(
            f"the runs of {spec.name} were tested on different episodes ({listed}); test them "
            "all on the same objects, first seed and number of episodes"
        )
    if not tests:
        raise EvodevoError(
            f"no result file of {spec.name} exists yet under {str(root)!r} (e.g. "
            f"{next(iter(spec.arms.values())).format(seed=parse_seeds(spec.seeds, 'seeds')[0])})"
        )
    return arms, next(iter(tests))


@dataclass
class ExperimentResult:
    """What :func:`decide_experiment` finds: arms, comparisons and the claim's reading."""

    spec: ExperimentSpec
    test: tuple[str, int, int]
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
            pooled = rate(sum(a.successes), sum(a.episodes)) if a.seeds else None
            row: dict[str, Any] = {
                "arm": n,
                "runs": len(a.seeds),
                "seeds": ",".join(map(str, a.seeds)),
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
        delta=spec.delta,
        reps=spec.reps,
        task="success, points",
    )


def _reading(claim: Claim, comps: Sequence[Comparison]) -> str:
    if claim == "none":
        return "; ".join(f"{c.a} − {c.b}: {c.verdict}" for c in comps)
    if claim == "higher":
        if all(c.verdict == DIFFERENT and c.mean_diff > 0 for c in comps):
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
    have = min(len(arms[a].seeds) for a in in_decision)
    complete = len(decision) == len(spec.decision) and all(
        len(arms[a].seeds) == n_reg for a in in_decision
    )
    if complete:
        reading = _reading(spec.claim, decision)
    else:
        reading = f"pending ({have} of {n_reg} runs in every arm of the decision)"
    return ExperimentResult(spec, test, arms, decision, beside, complete, reading, n_reg)


def _range_words(label: str) -> str:
    """``"the locked test range"`` for a caption (SPEC §6), else the range's name."""
    if label == "test":
        return "the locked test range"
    return label if label == "outside the split" else f"the {label} range"


def _f(v: float | None, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def markdown(res: ExperimentResult) -> str:
    """The experiment's tables: arms, the decision, the comparisons beside, and the reading."""
    spec = res.spec
    objects, first, n = res.test
    lines = [
        f"# {spec.name}. {spec.title}",
        "",
        f"Test: {n} episodes on {objects} objects, first seed {first} "
        f"({_range_words(range_label(first, n))}); registered run seeds {spec.seeds} "
        f"({res.runs_registered} per arm); δ = {spec.delta:g} points; intervals are 95 % "
        f"bootstrap intervals over runs ({spec.reps} resamples).",
        "",
        "| arm | runs | seeds | mean success over runs [95 % CI] | pooled successes | pooled "
        "success [Wilson 95 %] |"
        + (f" pooled ≥ {spec.target:g} % |" if spec.target is not None else ""),
        "|---|---:|---|---:|---:|---:|" + ("---|" if spec.target is not None else ""),
    ]
    for r in res.arm_rows:
        row = (
            f"| {r['arm']} | {r['runs']} | {r['seeds'] or '—'} | {_f(r['mean'])} "
            f"[{_f(r['low'])}, {_f(r['high'])}] | {r['pooled_successes']} / "
            f"{r['pooled_episodes']} | {_f(r['pooled'])} [{_f(r['pooled_low'])}, "
            f"{_f(r['pooled_high'])}] |"
        )
        if spec.target is not None:
            row += (
                " — |"
                if r["pooled"] is None
                else f" {'yes' if r['pooled'] >= spec.target else 'no'} |"
            )
        lines.append(row)
    lines += [
        "",
        "## The decision",
        "",
        "Paired by run seed (A − B in success points), exact sign-flip test, Holm over the "
        f"{len(spec.decision)} comparison(s) below.",
        "",
        to_markdown(res.decision, digits=1)
        if res.decision
        else "(no comparison has 2 paired runs yet)",
        "",
        f"**Reading (claim: {spec.claim}): {res.reading}.**",
        "",
    ]
    if spec.beside:
        lines += [
            "## Beside the decision",
            "",
            "Each comparison alone (no correction; not part of the decision).",
            "",
            to_markdown(res.beside, digits=1) if res.beside else "(no paired runs yet)",
            "",
        ]
    return "\n".join(lines)


def _csv(rows: Sequence[Mapping[str, Any]]) -> str:
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()


def write_experiment(spec_path: str | Path, out: str | Path | None = None) -> Path:
    """Decide the experiment of ``spec_path`` and write ``OUT/table.md``, ``comparisons.csv``,
    ``runs.csv`` and ``runs.png`` (default OUT: ``<root>/<name>``); returns ``table.md``."""
    from evodevo.evidence.profiles import plot_run_scores
    from evodevo.runs import atomic_write_text

    spec, root = load_experiment(spec_path)
    res = decide_experiment(spec, root)
    folder = Path(out) if out is not None else root / spec.name.lower()
    folder.mkdir(parents=True, exist_ok=True)
    md = folder / "table.md"
    atomic_write_text(md, markdown(res) + "\n")
    comps = [
        {"family": fam, **{k: getattr(c, k) for k in ("a", "b", "n", "mean_diff", "low", "high",
         "std_diff", "p", "p_adj", "delta", "mde", "verdict", "runs_needed")}}
        for fam, cs in (("decision", res.decision), ("beside", res.beside))
        for c in cs
    ]  # fmt: skip
    atomic_write_text(folder / "comparisons.csv", _csv(comps))
    runs = [
        {"arm": a.name, "seed": s, "successes": k, "episodes": n, "success": 100.0 * k / n}
        for a in res.arms.values()
        for s, k, n in zip(a.seeds, a.successes, a.episodes, strict=True)
    ]
    atomic_write_text(folder / "runs.csv", _csv(runs))
    plot_run_scores(
        {a.name: {s: a.score(s) for s in a.seeds} for a in res.arms.values()},
        {r["arm"]: (r["mean"], r["low"], r["high"]) for r in res.arm_rows if r["mean"] is not None},
        folder / "runs.png",
        ylabel="success on the test episodes (%)",
        title=f"{spec.name}: each run (dots) and the mean over runs [95 % CI]",
        target=spec.target,
    )
    return md
