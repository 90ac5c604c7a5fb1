"""Checkpoints after every task and every N episodes within a task, and resume (SPEC §1, §6).

Two kinds of file live in ``checkpoints/``:

* ``task{i}.safetensors`` after task i finished: the column stack up to column i (so every
  finished column is on disk), the modules, their states and novelty, and the per-task results
  so far. Every per-task random stream is derived from ``(seed, task index)``, so resuming after
  a finished task needs nothing else.
* ``task{i}_ep{k}.safetensors`` after the first k episodes of task i (every
  ``checkpoint_every`` episodes, and when SIGINT/SIGTERM asks the run to stop): additionally the
  trainable column's Adam state, its target network and gradient-step counter, the replay
  buffer (the filled rows of the preallocated array, position and size), epsilon, the step
  counters, and the states of the two random streams that are live inside a task: the
  exploration/replay Generator and the environment's ``np_random`` (Gymnasium environments draw
  all their randomness from it, so restoring it reproduces every later ``reset()``). Only the
  newest mid-task file is kept.

Every file is a :mod:`evodevo.safe_io` state file of kind :data:`FORMAT` (tensors and arrays
as safetensors, everything else — results, counters, RNG states — as JSON in its header),
written atomically, so a kill during a write leaves the previous checkpoint intact and reading
one never runs code from it. A corrupt, truncated or foreign file raises
:class:`~evodevo.errors.CheckpointError` naming the file and what to do; so does a checkpoint
of the old pickle-based format (``task{i}.pt``), which is never opened (convert trusted runs
with ``scripts/convert_safe_run_files.py``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evodevo.errors import CheckpointError
from evodevo.safe_io import load_state, refuse_legacy, save_state

__all__ = [
    "FORMAT",
    "ResumePoint",
    "save_checkpoint",
    "save_partial_checkpoint",
    "load_checkpoint",
    "latest_checkpoint",
    "latest_resume_point",
]

#: Kind of every BIARM checkpoint (:func:`evodevo.safe_io.save_state`).
FORMAT = "evodevo-biarm"
SUFFIX = ".safetensors"
_TASK = re.compile(r"^task(\d+)\.safetensors$")
_PARTIAL = re.compile(r"^task(\d+)_ep(\d+)\.safetensors$")
#: Checkpoints of the old pickle-based format: refused, never opened.
_LEGACY = ("task*.pt",)


@dataclass(frozen=True)
class ResumePoint:
    """Where a run continues: after ``episodes`` episodes of task ``task`` (None: task done)."""

    task: int
    episodes: int | None
    path: Path

    @property
    def finished_task(self) -> bool:
        return self.episodes is None


def _write(path: Path, payload: dict[str, Any]) -> Path:
    save_state(path, FORMAT, payload)
    return path


def _partials(folder: Path) -> list[tuple[int, int, Path]]:
    if not folder.is_dir():
        return []
    refuse_legacy(folder, *_LEGACY)
    return sorted(
        (int(m.group(1)), int(m.group(2)), p)
        for p in folder.iterdir()
        if (m := _PARTIAL.match(p.name))
    )


def save_checkpoint(folder: Path, task_index: int, payload: dict[str, Any]) -> Path:
    """Atomically write ``payload`` as ``folder/task{task_index}.safetensors`` (task finished).

    Mid-task files of this or earlier tasks are removed afterwards (they are superseded).
    """
    folder = Path(folder)
    path = _write(folder / f"task{task_index}{SUFFIX}", payload)
    for task, _, p in _partials(folder):
        if task <= task_index:
            p.unlink(missing_ok=True)
    return path


def save_partial_checkpoint(
    folder: Path, task_index: int, episodes: int, payload: dict[str, Any]
) -> Path:
    """Atomically write ``folder/task{i}_ep{k}.safetensors`` after ``k`` episodes of task ``i``.

    The previous mid-task file is removed only after the new one is complete.
    """
    folder = Path(folder)
    path = _write(folder / f"task{task_index}_ep{episodes}{SUFFIX}", payload)
    for _, _, p in _partials(folder):
        if p != path:
            p.unlink(missing_ok=True)
    return path


def load_checkpoint(path: Path) -> dict[str, Any]:
    """Load a checkpoint written by :func:`save_checkpoint` or :func:`save_partial_checkpoint`."""
    path = Path(path)
    hint = (
        "delete it to resume from the checkpoint before it (or the start of the run), "
        "or start again in a new --out"
    )
    data = load_state(path, FORMAT, "checkpoint", hint)
    if "agent" not in data or not isinstance(data["agent"], dict):
        raise CheckpointError(
            f"{str(path)!r} is not a BIARM checkpoint (written by something else); {hint}"
        )
    return data


def latest_checkpoint(folder: Path) -> tuple[int, Path] | None:
    """``(task index, path)`` of the last finished task, or None."""
    folder = Path(folder)
    if not folder.is_dir():
        return None
    refuse_legacy(folder, *_LEGACY)
    found = [(int(m.group(1)), p) for p in folder.iterdir() if (m := _TASK.match(p.name))]
    return max(found) if found else None


def latest_resume_point(folder: Path) -> ResumePoint | None:
    """The newest checkpoint, finished-task or mid-task, or None when there is none."""
    done = latest_checkpoint(folder)
    best = ResumePoint(done[0], None, done[1]) if done is not None else None
    for task, episodes, p in _partials(Path(folder)):
        if (
            best is None
            or task > best.task
            or (task == best.task and best.episodes is not None and episodes > best.episodes)
        ):
            best = ResumePoint(task, episodes, p)
    return best
