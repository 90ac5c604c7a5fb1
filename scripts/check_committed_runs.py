"""Check that every run committed under ``docs/results`` still loads and reports the same numbers.

    python scripts/check_committed_runs.py [--episodes 4] [--root docs/results] [--skip-grids]

Run it after a change to the run layer, the loaders or the evaluator (it is what "every
committed run under docs/results still loads and reports the same numbers" means in practice):

* **GRN and Kuka-baseline runs** (``config.json`` of kind ``grn`` or ``baseline``): the run is
  loaded by :func:`evodevo.grn.evaluation.load_run` (as ``grn evaluate`` loads it) and by
  :func:`evodevo.load`; then, for every saved clean test (``eval_<objects>_<noise>_episodes.csv``
  without a ``--set`` suffix), the first ``--episodes`` episodes of the saved champion are run
  again on their saved seeds and must give the saved reward, success and step count. A test
  saved before the settled-scene cache (commit 1632364, 2026-12-03) that replays exactly with
  ``env.kwargs.scene_cache: false`` is listed as a note, not a failure.
* **BIARM runs** (kind ``biarm``): each column loads through :func:`evodevo.load`.
* **BIARM grids** (folders with ``runs/`` of BIARM runs and a ``report.md``): ``biarm report``
  re-draws the tables into a copy of the folder (figures off), and every committed table
  (``table_*.md`` and ``table_*.csv``) must hold the same rows as the one drawn now (captions
  are prose and may gain words; ``report.md`` itself is left out: it gains the sections of
  tables added since, e.g. the final-return verdicts).

Nothing is written into ``docs/results``. Exit status 1 when any check fails, with one line
per failure; a summary line at the end.
"""

from __future__ import annotations

import argparse
import csv
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import evodevo
import evodevo.baselines  # noqa: F401  (registers the baselines' run loader and controllers)
from evodevo.grn.evaluation import load_run
from evodevo.grn.evaluator import Episode, Evaluator
from evodevo.neuromod.compare import write_report
from evodevo.runs import read_json

EVAL_FILE = re.compile(r"^eval_(test|train)_([0-9.e-]+)_episodes\.csv$")


def _kind(folder: Path) -> str | None:
    try:
        return str(read_json(folder / "config.json").get("kind"))
    except Exception:  # noqa: BLE001 - an unreadable config is reported by the loaders
        return None


#: The environment before the settled-scene cache (commit 1632364, 2026-12-03): a test saved
#: before it replays exactly with the cache off (docs/kuka_env.md, "Settled-scene cache").
PRE_CACHE = {"env": {"kwargs": {"scene_cache": False}}}


def _replay(loaded: Any, rows: list[dict[str, str]]) -> list[str]:
    """Replay the saved episodes ``rows`` with a loaded run; the differences from what was saved."""
    eps = [
        Episode(int(r["seed"]), noisy=False, test_objects=r["test_objects"] == "1") for r in rows
    ]
    with Evaluator(loaded.config, loaded.encoder, workers=1) as ev:
        res = ev.evaluate([loaded.genome], eps)
    got = (res.reward[0], res.success[0].astype(int), res.steps[0])
    want = tuple(np.array([float(r[k]) for r in rows]) for k in ("reward", "success", "steps"))
    return [
        f"{name} {list(np.asarray(g, float))} != saved {list(w)}"
        for name, g, w in zip(("reward", "success", "steps"), got, want, strict=True)
        if not np.allclose(np.asarray(g, float), w, atol=1e-9)
    ]


def check_grn(folder: Path, episodes: int, notes: list[str]) -> list[str]:
    """Load a GRN or baseline run and replay the first saved test episodes; a test that only
    the environment before the settled-scene cache reproduces is a note, not a failure."""
    problems: list[str] = []
    loaded = load_run(folder)
    evodevo.load(folder)
    for path in sorted(folder.glob("eval_*_episodes.csv")):
        m = EVAL_FILE.match(path.name)
        if m is None or float(m.group(2)) != 0.0:
            continue  # a --set test (suffixed) or a noisy one: its settings are not replayed
        with path.open() as fh:
            rows = [r for r in csv.DictReader(fh) if r["policy"] == "genome"][:episodes]
        if not rows:
            continue
        diffs = _replay(loaded, rows)
        if diffs and not _replay(load_run(folder, overrides=PRE_CACHE), rows):
            notes.append(
                f"{path}: saved before the settled-scene cache (replays exactly with "
                "--set env.kwargs.scene_cache=false)"
            )
        else:
            problems += [f"{path}: {d}" for d in diffs]
    return problems


def check_biarm(folder: Path) -> list[str]:
    """Load every column of a finished BIARM run that was committed with its checkpoints; a run
    committed without them (its numbers are in its CSVs and summary), an SB3-DQN run (not a
    policy of evodevo.load) or an unfinished one has its run files read instead."""
    saved = read_json(folder / "config.json")["config"]
    summary = folder / "summary.json"
    if not summary.is_file():
        return []  # in progress: resumed by the code that started it
    read_json(summary)
    with (folder / "metrics.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        return [f"{folder}: metrics.csv has no rows"]
    has_weights = any((folder / "checkpoints").glob("task*.safetensors"))
    if saved.get("variant") == "sb3-dqn" or not has_weights:
        return []
    for i in range(max(1, len(saved.get("tasks") or []))):
        evodevo.load(folder, task=i)
    return []


def _numbers(path: Path, where: Path, folder: Path) -> list[str]:
    """What a table says: its rows (Markdown: the ``|`` lines; CSV: every line), with the
    folder it was drawn in written as the committed folder; captions are prose and may gain
    words (e.g. the name of the seed range) without changing a number."""
    text = path.read_text().replace(str(where.resolve()), str(folder.resolve()))
    text = text.replace(str(where), str(folder))
    lines = text.splitlines()
    return [ln for ln in lines if ln.startswith("|")] if path.suffix == ".md" else lines


def check_grid(folder: Path) -> list[str]:
    """Re-draw a BIARM grid's tables in a copy and compare them with the committed ones."""
    problems: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / folder.name
        shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("*.safetensors", "*.pt"))
        write_report(copy, figures=False)
        for old in sorted(folder.glob("table_*.md")) + sorted(folder.glob("table_*.csv")):
            new = copy / old.name
            if not new.is_file():
                problems.append(f"{old}: not written again by biarm report")
            elif _numbers(new, copy, folder) != _numbers(old, folder, folder):
                problems.append(f"{old}: biarm report writes it differently now")
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=Path("docs/results"))
    ap.add_argument("--episodes", type=int, default=4, help="saved test episodes replayed per run")
    ap.add_argument("--skip-grids", action="store_true", help="do not re-draw BIARM grids")
    args = ap.parse_args(argv)
    failures: list[str] = []
    notes: list[str] = []
    counts: dict[str, int] = {}
    t0 = time.perf_counter()
    for cfg in sorted(args.root.rglob("config.json")):
        folder = cfg.parent
        kind = _kind(folder)
        check: Any = {
            "grn": lambda f: check_grn(f, args.episodes, notes),
            "baseline": lambda f: check_grn(f, args.episodes, notes),
            "biarm": check_biarm,
        }.get(kind or "")
        if check is None:
            continue
        try:
            failures += check(folder)
        except Exception as exc:  # noqa: BLE001 - every failure is reported, the rest go on
            failures.append(f"{folder}: {type(exc).__name__}: {exc}")
        counts[str(kind)] = counts.get(str(kind), 0) + 1
        print(f"checked {kind} {folder}", file=sys.stderr)
    if not args.skip_grids:
        for report in sorted(args.root.rglob("report.md")):
            folder = report.parent
            if not (folder / "runs").is_dir() or not any(
                _kind(r) == "biarm" for r in (folder / "runs").iterdir()
            ):
                continue
            try:
                failures += check_grid(folder)
            except Exception as exc:  # noqa: BLE001
                failures.append(f"{folder}: {type(exc).__name__}: {exc}")
            counts["grid"] = counts.get("grid", 0) + 1
            print(f"checked grid {folder}", file=sys.stderr)
    for line in notes:
        print(f"NOTE {line}")
    for line in failures:
        print(f"FAIL {line}")
    print(
        f"{sum(counts.values())} folders checked ({', '.join(f'{v} {k}' for k, v in sorted(counts.items()))}) "
        f"in {time.perf_counter() - t0:.0f} s: {len(failures)} failure(s), {len(notes)} note(s)"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
