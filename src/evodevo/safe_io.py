"""Run files that can be opened without running code from them (SPEC §6: run data is re-read).

A run folder may come from somebody else, and opening it must never execute anything it holds
(STYLE.md, "What they avoid": any pickle in a file that somebody else may hand you). So every
file evodevo writes is JSON, an ``.npz`` read with ``allow_pickle=False``, or a safetensors
file — a JSON header plus raw tensor bytes — written by :func:`save_state`; nothing evodevo
writes needs unpickling to be read.

:func:`save_state` stores a nested state (dicts, lists, tuples, numbers, strings, ``None``,
PyTorch tensors, NumPy arrays and scalars: what ``state_dict()``, optimiser states and RNG
states are made of) as one safetensors file: every tensor and array is a tensor of the file,
and the nesting, with each tensor replaced by its name, is JSON in the header's metadata
together with the file's ``kind``. :func:`load_state` reads it back equal, or raises one
:class:`~evodevo.errors.CheckpointError` that names the file and says what to do, whether the
file is truncated, corrupt, of another kind, or a pickle (an old evodevo file or a planted
one). Writes are atomic (:func:`evodevo.runs.atomic_write_bytes`).

>>> import tempfile, torch
>>> from pathlib import Path
>>> path = Path(tempfile.mkdtemp()) / "state.safetensors"
>>> save_state(path, "example", {"w": torch.ones(2), "step": 3, "betas": (0.9, 0.999)})
>>> state = load_state(path, "example")
>>> state["w"].tolist(), state["step"], state["betas"]
([1.0, 1.0], 3, (0.9, 0.999))
"""

from __future__ import annotations

import importlib.machinery
import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save as safetensors_bytes

from evodevo.errors import CheckpointError
from evodevo.runs import atomic_write_bytes

__all__ = [
    "STATE_FORMAT",
    "CONVERT_SCRIPT",
    "save_state",
    "load_state",
    "load_torch_tensors",
    "legacy_error",
    "refuse_legacy",
    "describe_foreign",
    "check_import",
    "RUN_MARKERS",
]

#: ``format`` entry of the metadata of every state file evodevo writes.
STATE_FORMAT = "evodevo-state"
_VERSION = "1"
#: The one-off converter of run folders written before these formats (pickles).
CONVERT_SCRIPT = "scripts/convert_safe_run_files.py"

_TENSOR, _ARRAY, _SCALAR, _TUPLE, _ITEMS = (
    "__tensor__",
    "__ndarray__",
    "__npscalar__",
    "__tuple__",
    "__items__",
)
_MARKERS = frozenset((_TENSOR, _ARRAY, _SCALAR, _TUPLE, _ITEMS))
_SCALAR_KINDS = "biuf"  # NumPy scalar kinds a state may hold: bool, int, uint, float


class _Encoder:
    """Splits a nested state into JSON (the skeleton) and named tensors."""

    def __init__(self) -> None:
        self.tensors: dict[str, torch.Tensor] = {}

    def _store(self, t: torch.Tensor) -> str:
        name = str(len(self.tensors))
        # own, contiguous storage: safetensors refuses tensors that share memory
        self.tensors[name] = t.detach().to("cpu").contiguous().clone()
        return name

    def encode(self, obj: Any, where: str) -> Any:
        if obj is None or isinstance(obj, (bool, int, float, str)):
            return obj
        if isinstance(obj, torch.Tensor):
            return {_TENSOR: self._store(obj)}
        if isinstance(obj, np.ndarray):
            if obj.dtype.kind not in _SCALAR_KINDS:
                raise TypeError(f"cannot store the {obj.dtype} array at {where}")
            return {_ARRAY: self._store(torch.from_numpy(np.array(obj, copy=True)))}
        if isinstance(obj, np.generic):
            if obj.dtype.kind not in _SCALAR_KINDS:
                raise TypeError(f"cannot store the {obj.dtype} scalar at {where}")
            return {_SCALAR: [obj.dtype.str, obj.item()]}
        if isinstance(obj, tuple):
            return {_TUPLE: [self.encode(v, f"{where}[{i}]") for i, v in enumerate(obj)]}
        if isinstance(obj, list):
            return [self.encode(v, f"{where}[{i}]") for i, v in enumerate(obj)]
        if isinstance(obj, Mapping):
            if all(isinstance(k, str) and k not in _MARKERS for k in obj):
                return {k: self.encode(v, f"{where}/{k}") for k, v in obj.items()}
            return {
                _ITEMS: [
                    [self.encode(k, f"{where} key"), self.encode(v, f"{where}/{k}")]
                    for k, v in obj.items()
                ]
            }
        raise TypeError(f"cannot store a {type(obj).__name__} at {where} without pickling it")


def _decode(obj: Any, tensors: Mapping[str, torch.Tensor]) -> Any:
    if isinstance(obj, list):
        return [_decode(v, tensors) for v in obj]
    if not isinstance(obj, dict):
        return obj
    marked = _MARKERS.intersection(obj)
    if not marked:
        return {k: _decode(v, tensors) for k, v in obj.items()}
    if len(obj) != 1:
        raise ValueError(f"a state entry mixes {sorted(marked)} with other keys")
    (tag, value) = next(iter(obj.items()))
    if tag == _TENSOR:
        return tensors[value]
    if tag == _ARRAY:
        return tensors[value].numpy()
    if tag == _SCALAR:
        dtype = np.dtype(str(value[0]))
        if dtype.kind not in _SCALAR_KINDS:
            raise ValueError(f"a scalar of dtype {dtype} is not a state value")
        return dtype.type(value[1])
    if tag == _TUPLE:
        return tuple(_decode(v, tensors) for v in value)
    pairs = [(_decode(k, tensors), _decode(v, tensors)) for k, v in value]
    return dict(pairs)


def describe_foreign(head: bytes) -> str | None:
    """What a file starting with ``head`` is, when it is a pickle-based format; else None.

    A safetensors file starts with its header's length (8 bytes, little-endian) and ``{``.

    >>> describe_foreign(b"\\x80\\x04\\x95")
    'a Python pickle'
    >>> describe_foreign(b"\\x80\\x00\\x00\\x00\\x00\\x00\\x00\\x00{") is None
    True
    """
    if len(head) >= 9 and head[8:9] == b"{":
        return None
    if head[:1] == b"\x80":
        return "a Python pickle"
    if head[:2] == b"\x1f\x8b":
        return "a gzip archive (as neat-python's pickled checkpoints)"
    if head[:4] == b"PK\x03\x04":
        return "a zip archive (as PyTorch's and Stable-Baselines3's pickled files)"
    return None


def legacy_error(
    path: str | Path, what: str = "a file in a pickle-based format"
) -> CheckpointError:
    """The error for a file in an old, pickle-based format (it is never opened)."""
    p = Path(path)
    folder = p.parent.parent if p.parent.name == "checkpoints" else p.parent
    return CheckpointError(
        f"{str(p)!r} is {what}, which evodevo no longer opens: unpickling a file can run any "
        "code it holds. If the run is your own, or you trust where it came from, convert it "
        f"once with `python {CONVERT_SCRIPT} {folder}`; otherwise delete the file"
    )


def refuse_legacy(folder: str | Path, *patterns: str) -> None:
    """Raise :func:`legacy_error` for the first file in ``folder`` matching a glob pattern."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for pattern in patterns:
        for p in sorted(folder.glob(pattern)):
            raise legacy_error(p, "an evodevo file in the old pickle-based format")


def save_state(path: str | Path, kind: str, state: Mapping[str, Any]) -> None:
    """Atomically write ``state`` as a safetensors file of ``kind`` (see module docstring).

    Raises:
        TypeError: ``state`` holds a value that only pickle could store (a bug in the caller).
    """
    enc = _Encoder()
    skeleton = enc.encode(dict(state), kind)
    meta = {
        "format": STATE_FORMAT,
        "version": _VERSION,
        "kind": kind,
        "state": json.dumps(skeleton, allow_nan=True),
    }
    atomic_write_bytes(path, safetensors_bytes(enc.tensors, metadata=meta))


def _read(p: Path) -> tuple[dict[str, str], dict[str, torch.Tensor]]:
    with safe_open(str(p), framework="pt", device="cpu") as fh:  # type: ignore[no-untyped-call]
        meta = dict(fh.metadata() or {})
        tensors = {k: fh.get_tensor(k) for k in fh.keys()}  # noqa: SIM118 (not a dict)
    return meta, tensors


def load_state(path: str | Path, kind: str, what: str = "file", hint: str = "") -> dict[str, Any]:
    """Read a file written by :func:`save_state` with this ``kind``.

    Args:
        path: the file.
        kind: the kind it must hold.
        what: what the file is, for the error message (e.g. "checkpoint").
        hint: what the user can do when it cannot be read (appended to the error).

    Raises:
        CheckpointError: missing, truncated, corrupt, of another kind, or pickle-based.
    """
    p = Path(path)
    name = f"{what} {str(p)!r}"
    todo = f"; {hint}" if hint else ""
    if not p.is_file():
        raise CheckpointError(f"{name} does not exist{todo}")
    with p.open("rb") as fh:
        head = fh.read(9)
    foreign = describe_foreign(head)
    if foreign is not None:
        raise legacy_error(p, foreign)
    try:
        meta, tensors = _read(p)
    except Exception as exc:  # safetensors raises its own error type, and OSError
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise CheckpointError(
            f"{name} is corrupt or truncated, or not a safetensors file ({first}){todo}"
        ) from None
    if meta.get("format") != STATE_FORMAT or "state" not in meta:
        raise CheckpointError(f"{name} was not written by evodevo (no evodevo header){todo}")
    if meta.get("kind") != kind:
        raise CheckpointError(
            f"{name} holds a {meta.get('kind')!r} state, not a {kind!r} state{todo}"
        )
    if meta.get("version") != _VERSION:
        raise CheckpointError(
            f"{name} has format version {meta.get('version')!r}; this evodevo reads version "
            f"{_VERSION}{todo}"
        )
    try:
        state = _decode(json.loads(meta["state"]), tensors)
    except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
        raise CheckpointError(f"{name} has a corrupt header ({exc}){todo}") from None
    if not isinstance(state, dict):
        raise CheckpointError(f"{name} has a corrupt header (no state dictionary){todo}")
    return state


def load_torch_tensors(path: str | Path, what: str, hint: str = "") -> dict[str, torch.Tensor]:
    """A ``{name: tensor}`` file written by ``torch.save``, read with ``weights_only=True``.

    PyTorch's weights-only unpickler rebuilds tensors and plain containers and refuses
    anything else, so no code from the file runs; the result must be a flat dict of tensors.
    """
    p = Path(path)
    todo = f"; {hint}" if hint else ""
    if not p.is_file():
        raise CheckpointError(f"{str(p)!r} does not exist{todo}")
    try:
        state = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt or refused files
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise CheckpointError(f"{str(p)!r} is not a saved {what} ({first}){todo}") from None
    if not isinstance(state, dict) or not all(
        isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in state.items()
    ):
        raise CheckpointError(f"{str(p)!r} is not a saved {what} (no tensors by name){todo}")
    return dict(state)


RUN_MARKERS = ("config.json", "summary.json")
"""Files that make a folder a run folder (every run command writes both)."""


def check_import(target: str, what: str) -> None:
    """Refuse to import the module of ``target`` (``"module:attr"``, as a config's controller
    or a Gymnasium id names it) when its file lies inside a run folder.

    A config may name a module to import (a user's controller kind or environment,
    docs/extending.md); a config read from a run folder that somebody else made could name a
    module planted in that very folder, which the import would execute (when the folder is the
    working directory or on the Python path). The module is located without importing anything
    (:class:`importlib.machinery.PathFinder` reads ``sys.path``); a module already imported is
    not looked up again. ``what`` names the value in the error.

    Raises:
        CheckpointError: the module's file is inside a folder holding :data:`RUN_MARKERS`.
    """
    module = target.partition(":")[0]
    top = module.split(".")[0]
    if ":" not in target or not top or top in sys.modules:
        return
    spec = importlib.machinery.PathFinder.find_spec(top)
    if spec is None:
        return  # the import itself reports a missing module
    places = list(spec.submodule_search_locations or []) + ([spec.origin] if spec.origin else [])
    for place in places:
        for folder in Path(place).resolve().parents:
            if all((folder / m).is_file() for m in RUN_MARKERS):
                raise CheckpointError(
                    f"{what} {target!r} names module {top!r}, whose file {place!r} is inside the "
                    f"run folder {str(folder)!r}; evodevo never runs code from a run folder. "
                    "Install or move the module elsewhere (and put that on the Python path)"
                )
