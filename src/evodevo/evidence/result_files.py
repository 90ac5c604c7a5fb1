"""Reading a number out of a run's result file, for the experiments of SPEC §6.

A result file is JSON (a test result of ``grn evaluate --json``, a ``grn baselines`` file, a
BIARM run's ``summary.json``) or a CSV table (``table_run_scores.csv``), read as the list of its
rows. :func:`lookup` follows a key path into it; :func:`read_success` and :func:`read_value`
return what :mod:`evodevo.evidence.experiment` compares.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError

__all__ = ["NoItem", "lookup", "read_result", "read_success", "read_value"]


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


def read_result(path: Path) -> Any:
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


def read_success(path: Path, part: str | None) -> tuple[int, int, tuple[Any, ...]]:
    """``(successes, episodes, the test's identity)`` of a test result file."""
    data = read_result(path)
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


def read_value(path: Path, key: str, test_key: str | None) -> tuple[float, tuple[Any, ...]] | None:
    """``(the number at key, the test's identity)`` of a result file; ``None`` when the file is a
    CSV table without that run's row (not written yet)."""
    data = read_result(path)
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
