"""Checkpoints after every finished task, and resume (SPEC §1; STYLE.md point 5).

``checkpoints/task{i}.pt`` holds the whole column stack up to column i (so every finished
column is on disk), the modules, their states and novelty, and the per-task results so far.
Every per-task random stream is derived from ``(seed, task index)``, so a resumed run continues
with exactly the numbers an uninterrupted run would produce. Written atomically
(``torch.save`` to memory, then :func:`evodevo.runs.atomic_write_bytes`).
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Any

import torch

from evodevo.errors import CheckpointError
from evodevo.runs import atomic_write_bytes

__all__ = ["save_checkpoint", "load_checkpoint", "latest_checkpoint"]

_NAME = re.compile(r"^task(\d+)\.pt$")


def save_checkpoint(folder: Path, task_index: int, payload: dict[str, Any]) -> Path:
    """Atomically write ``payload`` as ``folder/task{task_index}.pt``."""
    buf = io.BytesIO()
    torch.save(payload, buf)
    path = Path(folder) / f"task{task_index}.pt"
    atomic_write_bytes(path, buf.getvalue())
    return path


def load_checkpoint(path: Path) -> dict[str, Any]:
    """Load a checkpoint written by :func:`save_checkpoint`."""
    try:
        data = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as exc:  # corrupt or truncated file
        raise CheckpointError(
            f"checkpoint {str(path)!r} cannot be read ({exc}); delete it"
        ) from None
    if not isinstance(data, dict) or "agent" not in data:
        raise CheckpointError(f"{str(path)!r} is not a BIARM checkpoint")
    return data


def latest_checkpoint(folder: Path) -> tuple[int, Path] | None:
    """``(task index, path)`` of the last finished task, or None."""
    folder = Path(folder)
    if not folder.is_dir():
        return None
    found = [(int(m.group(1)), p) for p in folder.iterdir() if (m := _NAME.match(p.name))]
    return max(found) if found else None
