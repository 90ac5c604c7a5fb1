"""Reading the saved files of finished runs for the reproduction report: JSON
results, per-episode successes, and the paired per-episode comparison (SPEC §6)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from evodevo.stats import mcnemar_exact

__all__ = ["TRIVIAL_TITLES", "fmt_pair", "load_json", "paired", "pct", "successes"]


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
