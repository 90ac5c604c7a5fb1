"""A pre-registered experiment, decided from its runs' result files (SPEC §6).

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
(:func:`lookup`), e.g. a BIARM run's final return on one task, and δ is given as ``delta`` or
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
"""

from __future__ import annotations

import csv
import functools
import io
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from evodevo.config import doc, from_dict, read_yaml
from evodevo.errors import ConfigError, EvodevoError
from evodevo.evidence.aggregate import AGGREGATES, DEFAULT_REPS, interval_estimates
from evodevo.evidence.normalise import SUCCESS_RATE_MARGIN
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

    def score(self, seed: int) -> float:
        """The score of the run of ``seed`` (success in points, or the value read)."""
        return self.values[self.seeds.index(seed)]


class NoItem(KeyError):
    """A selector ``[key=value]`` matched no item (in a CSV file: that run has no row yet)."""


_SELECT = re.compile(r"^(?P<name>[^\[\]]*)(?:\[(?P<sel>[^\]]+)\])?$")


def lookup(data: Any, path: str) -> Any:
    """The value at key path ``path`` of parsed JSON ``data``.

    Segments are separated by dots; ``name[3]`` takes item 3 of a list and
    ``name[key=value]`` (or ``name[k1=v1,k2=v2]``) the one item whose keys have those values.
    A CSV file is read as the list of its rows, so ``[variant=biarm,seed=3].column`` is a cell.

    >>> lookup({"tasks": [{"env_id": "A", "r": 1}, {"env_id": "B", "r": 2}]}, "tasks[env_id=B].r")
    2
    """
    cur = data
    for seg in path.split("."):
        m = _SELECT.match(seg)
        if m is None:
            raise KeyError(f"{seg!r} is not a key ('name', 'name[3]' or 'name[key=value]')")
        if m["name"]:
            if not isinstance(cur, dict) or m["name"] not in cur:
                raise KeyError(f"no key {m['name']!r}")
            cur = cur[m["name"]]
        sel = m["sel"]
        if sel is None:
            continue
        if not isinstance(cur, list):
            raise KeyError(f"{seg!r} selects from {type(cur).__name__}, not a list")
        if "=" in sel:
            conds = [c.partition("=")[::2] for c in sel.split(",")]
            hits = [
                x for x in cur if isinstance(x, dict) and all(str(x.get(k)) == v for k, v in conds)
            ]
            if len(hits) != 1:
                what = " and ".join(f"{k} = {v}" for k, v in conds)
                err = NoItem if not hits else KeyError
                raise err(f"{len(hits)} items of {m['name'] or 'the list'} have {what}")
            cur = hits[0]
        else:
            try:
                cur = cur[int(sel)]
            except (ValueError, IndexError):
                raise KeyError(f"{seg!r}: no item {sel}") from None
    return cur


def _read_json(path: Path) -> Any:
    """The parsed JSON of ``path``; a ``.csv`` file as the list of its rows (dicts of text)."""
    try:
        if path.suffix == ".csv":
            with path.open(newline="") as f:
                return list(csv.DictReader(f))
        return json.loads(path.read_text())
    except (OSError, ValueError, csv.Error) as exc:
        raise EvodevoError(
            f"result file {str(path)!r} cannot be read as JSON ({exc}); rerun the test or run "
            "that writes it"
        ) from None


def _read_success(path: Path, part: str | None) -> tuple[int, int, tuple[Any, ...]]:
    """``(successes, episodes, the test's identity)`` of a test result file."""
    data = _read_json(path)
    if not isinstance(data, dict):
        raise EvodevoError(f"result file {str(path)!r} holds no test result (not a mapping)")
    try:
        src: Any = lookup(data, part) if part else data
    except KeyError:
        src = None
    facts = data.get("key", data)  # `grn baselines` files keep the episodes' facts under "key"
    if not isinstance(src, dict) or "successes" not in src or "episodes" not in facts:
        what = f"a {part!r} part with successes" if part else "successes and episodes"
        raise EvodevoError(f"result file {str(path)!r} has no {what}; is it a test result?")
    n = int(facts["episodes"])
    test = (str(facts.get("objects")), int(facts.get("test_seed", -1)), n)
    return int(src["successes"]), n, test


def _read_value(path: Path, key: str, test_key: str | None) -> tuple[float, tuple[Any, ...]] | None:
    """``(the number at key, the test's identity)`` of a result file; ``None`` when the file is a
    CSV table without that run's row (not written yet)."""
    data = _read_json(path)
    try:
        found = lookup(data, key)
    except NoItem as exc:
        if isinstance(data, list):
            return None
        raise EvodevoError(f"result file {str(path)!r}: {key!r} selects no item ({exc})") from None
    except KeyError as exc:
        raise EvodevoError(f"result file {str(path)!r}: {key!r} gives no number ({exc})") from None
    try:
        value = float(found)
        test = (json.dumps(lookup(data, test_key)),) if test_key else ()
    except (KeyError, TypeError, ValueError) as exc:
        raise EvodevoError(f"result file {str(path)!r}: {key!r} gives no number ({exc})") from None
    return value, test


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
                k, n, test = _read_success(path, part or None)
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
                k, n, test = _read_success(path, part or None)
                scores.successes.append(k)
                scores.episodes.append(n)
                scores.values.append(100.0 * k / n)
            else:
                got = _read_value(path, part.format(seed=seed), spec.test_key)
                if got is None:
                    continue
                value, test = got
                scores.values.append(value)
            scores.seeds.append(seed)
            tests.setdefault(test, str(path))
        arms[name] = scores
    if len(tests) > 1:
        listed = "; ".join(f"{t} in {p}" for t, p in tests.items())
        raise EvodevoError(
            f"the runs of {spec.name} were tested on different episodes ({listed}); test them "
            "all on the same episodes (objects, first seed and number)"
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
    have = min(len(arms[a].seeds) for a in in_decision)
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
        reading = f"pending ({have} of {n_reg} runs in every arm of the decision)"
    return ExperimentResult(spec, test, arms, decision, beside, complete, reading, n_reg)


def _range_words(label: str) -> str:
    """``"the locked test range"`` for a caption (SPEC §6), else the range's name."""
    if label == "test":
        return "the locked test range"
    return label if label == "outside the split" else f"the {label} range"


def _f(v: float | None, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def _test_words(res: ExperimentResult) -> str:
    if res.spec.metric == "success":
        objects, first, n = res.test
        return (
            f"Test: {n} episodes on {objects} objects, first seed {first} "
            f"({_range_words(range_label(first, n))})"
        )
    if res.spec.test_key:
        return f"Test: every run's {res.spec.test_key} is {res.test[0]}"
    return "Test: as each result file records it"


def markdown(res: ExperimentResult) -> str:
    """The experiment's tables: arms, the decision, the comparisons beside, and the reading."""
    spec = res.spec
    success = spec.metric == "success"
    units = "points" if success else "(units of the metric)"
    lines = [
        f"# {spec.name}. {spec.title}",
        "",
        f"{_test_words(res)}; registered run seeds {spec.seeds} ({res.runs_registered} per "
        f"arm); metric {spec.unit}; δ = {spec.margin:g} {units}; intervals are 95 % bootstrap "
        f"intervals over runs ({spec.reps} resamples).",
        "",
    ]
    target = f" pooled ≥ {spec.target:g} % |" if success and spec.target is not None else ""
    if success:
        lines += [
            "| arm | runs | seeds | mean success over runs [95 % CI] | pooled successes | "
            "pooled success [Wilson 95 %] |" + target,
            "|---|---:|---|---:|---:|---:|" + ("---|" if target else ""),
        ]
    else:
        lines += ["| arm | runs | seeds | mean over runs [95 % CI] |", "|---|---:|---|---:|"]
    digits = 1 if success else 2
    for r in res.arm_rows:
        row = (
            f"| {r['arm']} | {r['runs']} | {r['seeds'] or '—'} | {_f(r['mean'], digits)} "
            f"[{_f(r['low'], digits)}, {_f(r['high'], digits)}] |"
        )
        if success:
            row += (
                f" {r['pooled_successes']} / {r['pooled_episodes']} | {_f(r['pooled'])} "
                f"[{_f(r['pooled_low'])}, {_f(r['pooled_high'])}] |"
            )
        if target:
            reached = r["pooled"] is not None and r["pooled"] >= (spec.target or 0)
            row += " — |" if r["pooled"] is None else f" {'yes' if reached else 'no'} |"
        lines.append(row)
    lines += [
        "",
        "## The decision",
        "",
        f"Paired by run seed (A − B, {spec.unit}), exact sign-flip test, Holm over the "
        f"{len(spec.decision)} comparison(s) below.",
        "",
        to_markdown(res.decision, digits=digits)
        if res.decision
        else "(no comparison has 2 paired runs yet)",
        "",
        f"**Reading (claim: {spec.claim}"
        + (f", read on {', '.join(spec.claim_on)}" if spec.claim_on else "")
        + (
            ", read per group: "
            + "; ".join(f"{g} = {', '.join(items)}" for g, items in spec.claim_groups.items())
            if spec.claim_groups
            else ""
        )
        + f"): {res.reading}.**",
        "",
    ]
    if spec.beside:
        lines += [
            "## Beside the decision",
            "",
            "Each comparison alone (no correction; not part of the decision).",
            "",
            to_markdown(res.beside, digits=digits) if res.beside else "(no paired runs yet)",
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
    if spec.metric == "success":
        runs = [
            {"arm": a.name, "seed": s, "successes": k, "episodes": n, "success": v}
            for a in res.arms.values()
            for s, v, k, n in zip(
                [""] if a.reference else a.seeds, a.values, a.successes, a.episodes, strict=False
            )
        ]
    else:
        runs = [
            {"arm": a.name, "seed": s, "value": v}
            for a in res.arms.values()
            for s, v in zip(a.seeds, a.values, strict=True)
        ]
    atomic_write_text(folder / "runs.csv", _csv(runs))
    plot_run_scores(
        {
            a.name: {s: a.score(s) for s in a.seeds[: 1 if a.reference else None]}
            for a in res.arms.values()
        },
        {
            r["arm"]: (r["mean"], r["low"], r["high"])
            for r, a in zip(res.arm_rows, res.arms.values(), strict=True)
            if r["mean"] is not None and not a.reference
        },
        folder / "runs.png",
        ylabel="success on the test episodes (%)" if spec.metric == "success" else spec.unit,
        title=f"{spec.name}: each run (dots; an untrained reference: its one test) and the "
        "mean over runs [95 % CI]",
        target=spec.target if spec.metric == "success" else None,
    )
    return md
