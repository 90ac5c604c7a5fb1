"""Run directories (STYLE.md point 2): resolved config, metrics CSV, summary, checkpoints.

Every write of a file that a later step reads back goes through :func:`atomic_write_bytes`
(temporary file + ``os.replace``), so a kill during a write never leaves a half-written file.

>>> import tempfile
>>> run = RunDir(tempfile.mkdtemp())
>>> run.write_summary({"ok": 1})
>>> run.read_summary()["ok"]
1
"""

from __future__ import annotations

import csv
import io
import json
import os
import platform
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from evodevo.errors import CheckpointError, EvodevoError

__all__ = [
    "RunDir",
    "make_dir",
    "run_kind",
    "atomic_write_bytes",
    "atomic_write_with",
    "atomic_write_text",
    "write_json",
    "read_json",
    "machine_info",
    "current_umask",
]


def current_umask() -> int:
    """This process' file-mode creation mask (read without changing it where the OS allows)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)  # elsewhere: set and restore (not thread-safe, but brief)
    os.umask(mask)
    return mask


def atomic_write_with(path: str | Path, write: Callable[[BinaryIO], object]) -> None:
    """Let ``write`` fill a temporary file in ``path``'s folder, then rename it to ``path``.

    For files too large to build in memory first (a TD3 replay buffer); a kill during the
    write leaves the previous ``path`` intact. The file gets the mode an ordinary
    ``open(path, "w")`` would (0666 minus the umask), not ``mkstemp``'s 0600, so collaborators
    on shared storage can read the run.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~current_umask())
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same folder and an atomic rename
    (:func:`atomic_write_with`)."""
    atomic_write_with(path, lambda fh: fh.write(data))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Text version of :func:`atomic_write_bytes`."""
    atomic_write_bytes(path, text.encode())


def _json_default(o: Any) -> Any:
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_json(path: str | Path, obj: Any) -> None:
    """Atomically write ``obj`` as indented JSON."""
    atomic_write_text(path, json.dumps(obj, indent=2, default=_json_default) + "\n")


def read_json(path: str | Path) -> Any:
    """Read JSON, raising :class:`CheckpointError` with the path on a missing or corrupt file."""
    p = Path(path)
    if not p.is_file():
        raise CheckpointError(f"{str(p)!r} does not exist; is this the right run directory?")
    try:
        return json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise CheckpointError(f"{str(p)!r} is corrupt ({exc}); delete it or re-run") from None


def machine_info() -> dict[str, Any]:
    """The machine a number was measured on (SPEC §6: every table names its machine)."""
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
    }


def make_dir(path: str | Path, what: str = "--out") -> Path:
    """Create folder ``path`` (and its parents), or raise one clear :class:`EvodevoError`
    naming it, when it cannot be created (a file in the way, no permission, a full disk)."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise EvodevoError(
            f"{what} {str(p)!r} cannot be created ({exc.strerror or exc}); choose a folder "
            "you can write to"
        ) from None
    return p


def run_kind(path: str | Path) -> str | None:
    """The ``kind`` a run folder's ``config.json`` records (``"biarm"``, ``"grn"``, ...), or
    None when the folder holds no readable run config."""
    p = Path(path) / "config.json"
    if not p.is_file():
        return None
    try:
        kind = read_json(p).get("kind")
    except (OSError, ValueError, AttributeError):
        return None
    return str(kind) if kind is not None else None


def _first_difference(a: Any, b: Any, path: str) -> tuple[str, Any, Any] | None:
    """The first dotted key at which nested mappings ``a`` and ``b`` differ, with both values."""
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        for k in sorted(set(a) | set(b), key=str):
            found = _first_difference(a.get(k), b.get(k), f"{path}.{k}")
            if found is not None:
                return found
        return None
    return None if a == b else (path, a, b)


class RunDir:
    """One run's folder: ``config.json``, ``*.csv`` metrics, ``summary.json``, ``checkpoints/``."""

    def __init__(self, path: str | Path, create: bool = True) -> None:
        self.path = Path(path)
        if create:
            make_dir(self.path)
        elif not self.path.is_dir():
            raise EvodevoError(f"run directory {str(self.path)!r} does not exist")

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    @property
    def checkpoints(self) -> Path:
        p = self.path / "checkpoints"
        p.mkdir(exist_ok=True)
        return p

    def check_same_config(
        self,
        mine: Mapping[str, Any],
        keys: Sequence[str],
        theirs: Mapping[str, Any],
        hint: str = "",
    ) -> None:
        """``--resume``: refuse to continue when a key of the saved config (``theirs``, as the
        method reads it from ``config.json``) differs from this run's (``mine``); the error
        names the first differing key (dotted) and both values, then ``hint``."""
        for key in keys:
            where = _first_difference(theirs.get(key), mine.get(key), key)
            if where is not None:
                path, old, new = where
                raise CheckpointError(
                    f"--resume: the saved config differs from this run's at {path}: {old!r} in "
                    f"{str(self.path / 'config.json')!r}, {new!r} now; use the same options or "
                    f"another --out{hint}"
                )

    def write_config(self, config: Mapping[str, Any], kind: str) -> None:
        """Save the resolved config with the run's kind, machine and start time."""
        write_json(
            self.path / "config.json",
            {
                "kind": kind,
                "config": dict(config),
                "machine": machine_info(),
                "created": time.time(),
            },
        )

    def read_config(self) -> dict[str, Any]:
        return dict(read_json(self.path / "config.json"))

    def write_summary(self, summary: Mapping[str, Any]) -> None:
        write_json(self.path / "summary.json", dict(summary))

    def read_summary(self) -> dict[str, Any]:
        return dict(read_json(self.path / "summary.json"))

    def write_csv(
        self, name: str, rows: Sequence[Mapping[str, Any]], fields: Sequence[str] | None = None
    ) -> None:
        """Atomically (re)write a whole CSV file from ``rows``."""
        buf = io.StringIO()
        cols = list(fields) if fields is not None else (list(rows[0].keys()) if rows else [])
        w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
        atomic_write_text(self.path / name, buf.getvalue())

    def read_csv(self, name: str) -> list[dict[str, str]]:
        p = self.path / name
        if not p.is_file():
            raise CheckpointError(f"{str(p)!r} does not exist; is this the right run directory?")
        with p.open() as fh:
            return list(csv.DictReader(fh))


class CsvAppender:
    """Append rows to a CSV file (header written once); flushed after every row.

    Used for long per-episode logs; on resume the file is truncated to the rows already
    covered by the checkpoint by rewriting it through :meth:`RunDir.write_csv`.
    """

    def __init__(self, path: str | Path, fields: Sequence[str]) -> None:
        self.path = Path(path)
        self.fields = list(fields)
        new = not self.path.exists() or self.path.stat().st_size == 0
        self._fh = self.path.open("a", newline="")
        self._w = csv.DictWriter(self._fh, fieldnames=self.fields, extrasaction="ignore")
        if new:
            self._w.writeheader()
            self._fh.flush()

    def write(self, row: Mapping[str, Any]) -> None:
        self._w.writerow(row)
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> CsvAppender:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ += ["CsvAppender"]
