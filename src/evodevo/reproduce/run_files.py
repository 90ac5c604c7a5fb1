"""Reading the saved files of finished runs for the reproduction report: JSON
results, per-episode successes, and the paired per-episode comparison (SPEC §6)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from evodevo.stats import mcnemar_exact

__all__ = [
    "TRIVIAL_TITLES",
    "finished",
    "fmt_pair",
    "kuka_run_dir",
    "load_json",
    "paired",
    "pct",
    "successes",
]


def load_json(path: Path) -> dict[str, Any] | None:
    try:
        return dict(json.loads(path.read_text()))
    except (OSError, json.JSONDecodeError):
        return None


#: The trivial policies of SPEC §2.5 as the report names them.
TRIVIAL_TITLES = {
    "zero": "all-zero actions",
    "random": "uniform-random actions",
    "turn": "constant turn (dx = dy = 0, d-angle = −1)",
    "scripted": "scripted image-only pipeline (blob nearest the gripper, move over it, turn)",
}


def successes(path: Path, policy: str) -> list[int] | None:
    """Per-episode successes of ``policy`` in an ``*_episodes.csv`` file, in episode order."""
    try:
        with path.open() as fh:
            rows = [r for r in csv.DictReader(fh) if r["policy"] == policy]
    except (OSError, KeyError):
        return None
    if not rows:
        return None
    rows.sort(key=lambda r: int(r["episode"]))
    return [int(r["success"]) for r in rows]


def pct(r: dict[str, Any]) -> str:
    return f"{100 * r['success_rate']:.1f} % [{100 * r['ci_low']:.1f}, {100 * r['ci_high']:.1f}]"


def paired(a: list[int] | None, b: list[int] | None) -> tuple[float, float] | None:
    """(success of ``a`` − success of ``b``, exact McNemar p) for per-episode successes of the
    same episodes; None if either is missing or they are not the same episodes."""
    if a is None or b is None or len(a) != len(b):
        return None
    return (sum(a) - sum(b)) / len(a), mcnemar_exact(a, b)


def fmt_pair(pair: tuple[float, float] | None) -> str:
    """``+d.d (p = x)`` in points, else ``—``."""
    return "—" if pair is None else f"{100 * pair[0]:+.1f} (p = {pair[1]:.2g})"


def finished(path: Path) -> bool:
    """False for a ``summary.json`` that records ``"done": false`` (or, as NEAT runs before
    the flag was added, ``"stopped_by": "running"``), and for any output beside a
    ``grid.json`` (``biarm compare``'s list of requested runs) while one of those runs has no
    ``summary.json``: tables drawn from a partial grid by ``biarm report`` do not finish it."""
    grid = path.parent / "grid.json"
    if path.name != "summary.json" and grid.is_file():
        try:
            runs = json.loads(grid.read_text()).get("runs", [])
        except (OSError, ValueError, AttributeError):
            return False
        return all((path.parent / "runs" / str(n) / "summary.json").is_file() for n in runs)
    if path.name != "summary.json":
        return True
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False  # unreadable or half-written: run the step again (it resumes)
    if not isinstance(data, dict):
        return True
    return data.get("done") is not False and data.get("stopped_by") != "running"


def kuka_run_dir(out: Path, method: str, scale: float, seed: int) -> Path:
    """``OUT/kuka/{method}_x{scale}_s{seed}``."""
    return out / "kuka" / f"{method}_x{scale:g}_s{seed}"
