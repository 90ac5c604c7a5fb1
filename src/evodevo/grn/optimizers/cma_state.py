"""The state of a ``cma.CMAEvolutionStrategy`` as JSON plus arrays, never a pickle.

``cma`` can pickle its strategy, but a run folder must not hold a pickle (STYLE.md: anything
somebody may hand you is data). :func:`dump_state` walks the strategy's own attributes, and
those of the ``cma`` objects it holds (the sampler with the covariance matrix and its
eigen-decomposition, the step-size adaptation with its path, the recombination parameters, the
fitness history), and writes every *data* value: numeric arrays go to a dict of arrays (saved
in the run's ``.npz``), numbers, strings, ``None``, ranges and lists, tuples and dicts of them
(with number, string or tuple keys: the archives of asked and injected solutions, whose
mirrored samples ``tell`` weighs differently) to a JSON tree. Functions, options, the logger and
the timer are left out; the options are rebuilt from the run's config. Any other value it
cannot write is an error when the checkpoint is written, never a silently incomplete state.

:func:`restore_state` writes such a tree back into a *freshly constructed* strategy made with
the same options, attribute by attribute. It only ever assigns data — a number, a string, a
numeric array (read with ``allow_pickle=False``), ``None`` or a container of these — and only to
an attribute whose current value is data of a compatible kind (or that a run creates lazily and
the class does not define): nothing in the file names a type to build or a function to call, so
loading a planted file can fail but cannot run code. The strategy's type and the ``cma``
version must be those that wrote the state; anything else is a
:class:`~evodevo.errors.CheckpointError` saying so. That a restored strategy continues exactly
like the uninterrupted one is tested (``tests/test_grn_optimizers.py``).

>>> import cma, numpy as np
>>> rng = np.random.default_rng(0)
>>> opts = {"popsize": 6, "seed": np.nan, "verbose": -9, "randn": lambda *s: rng.standard_normal(s)}
>>> es = cma.CMAEvolutionStrategy(np.zeros(3), 1.0, opts)
>>> es.tell(X := es.ask(), [float(x @ x) for x in X])
>>> tree, arrays = dump_state(es)
>>> fresh = cma.CMAEvolutionStrategy(np.zeros(3), 1.0, opts)
>>> restore_state(fresh, tree, arrays)
>>> bool(np.array_equal(fresh.mean, es.mean)), bool(fresh.sigma == es.sigma)
(True, True)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from evodevo.errors import CheckpointError

__all__ = ["dump_state", "restore_state", "SKIPPED_ATTRIBUTES", "SKIPPED_TYPES"]

SKIPPED_ATTRIBUTES = frozenset(
    {
        "opts",
        "inopts",
        "inputargs",
        "logger",
        "timer",
        "callbackstop",
        "RoundIntegerVariables.params",
    }
)
"""Attributes never saved, by name or ``Class.name``: options (rebuilt from the config, and
holding callables), the logger, the wall-clock timer, the integer-variable settings (options)."""
SKIPPED_TYPES = frozenset({"CMAOptions"})
"""``cma`` types never saved: options."""
_NUMERIC = "biuf"
_SCALARS = (bool, int, float, str, type(None))


class _Skip:
    """Marker of a value that is not data."""


_SKIP = _Skip()


def _is_cma(value: Any) -> bool:
    module = type(value).__module__
    return module == "cma" or module.startswith("cma.")


def _encode(value: Any, path: str, arrays: dict[str, np.ndarray], seen: dict[int, str]) -> Any:
    """The JSON node of ``value`` (arrays into ``arrays``), or ``_SKIP`` if it is not data."""
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in _NUMERIC:
            return _SKIP
        if id(value) in seen:  # the same array under two names stays one array
            return {"alias": seen[id(value)]}
        seen[id(value)] = path
        arrays[path] = np.array(value, copy=True)
        return {"array": path}
    if isinstance(value, np.generic):
        if value.dtype.kind not in _NUMERIC:
            return _SKIP
        return {"scalar": value.dtype.str, "value": value.item()}
    if isinstance(value, _SCALARS):
        return {"value": value}
    if isinstance(value, (list, tuple)) and type(value) in (list, tuple):
        items = [_encode(v, f"{path}[{i}]", arrays, seen) for i, v in enumerate(value)]
        if any(i is _SKIP for i in items):
            return _SKIP
        return {"tuple" if isinstance(value, tuple) else "list": items}
    if type(value) is range:
        return {"range": [value.start, value.stop, value.step]}
    if type(value) is dict and all(isinstance(k, str) for k in value):
        entries = {k: _encode(v, f"{path}[{k}]", arrays, seen) for k, v in value.items()}
        if any(v is _SKIP for v in entries.values()):
            return _SKIP
        return {"dict": entries}
    if type(value) is dict:  # number or tuple keys (solution archives, memos)
        pairs = [
            [_encode(k, f"{path}<key>", arrays, seen), _encode(v, f"{path}[{k!r}]", arrays, seen)]
            for k, v in value.items()
        ]
        if any(k is _SKIP or v is _SKIP or "array" in k for k, v in pairs):
            return _SKIP
        return {"items": pairs}
    if _is_cma(value) and type(value).__name__ in SKIPPED_TYPES:
        return _SKIP
    if _is_cma(value) and hasattr(value, "__dict__"):
        if id(value) in seen:
            return {"alias_object": seen[id(value)]}
        seen[id(value)] = path
        return {"object": type(value).__qualname__, "attrs": _attributes(value, path, arrays, seen)}
    if callable(value):  # functions, methods, classes: parts of the options, not state
        return _SKIP
    raise CheckpointError(
        f"CMA-ES state: {path} is a {type(value).__qualname__}, which evodevo cannot save as "
        "data; this cma version keeps state evodevo does not know (use the cma version in "
        "pyproject.toml)"
    )


def _attributes(
    obj: Any, path: str, arrays: dict[str, np.ndarray], seen: dict[int, str]
) -> dict[str, Any]:
    out = {}
    cls = type(obj).__name__
    for name, value in vars(obj).items():
        if name in SKIPPED_ATTRIBUTES or f"{cls}.{name}" in SKIPPED_ATTRIBUTES:
            continue
        node = _encode(value, f"{path}.{name}", arrays, seen)
        if node is _SKIP and not callable(value) and not _is_cma(value):
            raise CheckpointError(
                f"CMA-ES state: {path}.{name} holds a function or an object among its data; "
                "evodevo cannot save it (use the cma version in pyproject.toml)"
            )
        if node is not _SKIP:
            out[name] = node
    return out


def dump_state(es: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The data state of a ``cma`` strategy: (JSON tree, arrays by path).

    Args:
        es: a ``cma.CMAEvolutionStrategy`` (or any ``cma`` object).
    """
    arrays: dict[str, np.ndarray] = {}
    seen: dict[int, str] = {id(es): "es"}
    tree = {"object": type(es).__qualname__, "attrs": _attributes(es, "es", arrays, seen)}
    return tree, arrays


def _hashable_data(key: Any) -> bool:
    if isinstance(key, tuple):
        return all(_hashable_data(k) for k in key)
    return isinstance(key, (*_SCALARS, np.generic)) and not isinstance(key, np.ndarray)


def _is_data(value: Any) -> bool:
    return isinstance(value, (np.ndarray, np.generic, *_SCALARS, list, tuple, dict, range)) and (
        not _is_cma(value) or type(value) in (list, tuple, dict)
    )


def _kind(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, np.ndarray):
        return "array"
    if isinstance(value, (bool, int, float, np.number, np.bool_)):
        return "number"
    if isinstance(value, str):
        return "str"
    if isinstance(value, (list, tuple, range)):
        return "sequence"
    if isinstance(value, dict):
        return "dict"
    return "other"


def _decode(node: Any, arrays: Mapping[str, np.ndarray], restored: dict[str, Any], at: str) -> Any:
    if not isinstance(node, dict) or len(node) not in (1, 2):
        raise CheckpointError(f"CMA-ES state: {at} is not a state entry")
    if "array" in node:
        key = node["array"]
        a = arrays.get(key) if isinstance(key, str) else None
        if a is None or not isinstance(a, np.ndarray) or a.dtype.kind not in _NUMERIC:
            raise CheckpointError(f"CMA-ES state: {at} names the array {key!r}, which is missing")
        value = np.array(a, copy=True)
        restored[key] = value
        return value
    if "alias" in node:
        if node["alias"] not in restored:
            raise CheckpointError(f"CMA-ES state: {at} repeats an unknown array {node['alias']!r}")
        return restored[node["alias"]]
    if "scalar" in node:
        dtype = np.dtype(str(node["scalar"]))
        if dtype.kind not in _NUMERIC or not isinstance(node.get("value"), (bool, int, float)):
            raise CheckpointError(f"CMA-ES state: {at} is not a number")
        return dtype.type(node["value"])
    if "value" in node:
        if not isinstance(node["value"], _SCALARS):
            raise CheckpointError(f"CMA-ES state: {at} is not a plain value")
        return node["value"]
    if "range" in node:
        bounds = node["range"]
        if not (isinstance(bounds, list) and len(bounds) == 3):
            raise CheckpointError(f"CMA-ES state: {at} is not a range")
        if not all(isinstance(b, int) and not isinstance(b, bool) for b in bounds):
            raise CheckpointError(f"CMA-ES state: {at} is not a range")
        return range(*bounds)
    for tag, kind in (("list", list), ("tuple", tuple)):
        if tag in node and isinstance(node[tag], list):
            items = [_decode(v, arrays, restored, f"{at}[{i}]") for i, v in enumerate(node[tag])]
            return kind(items)
    if "dict" in node and isinstance(node["dict"], dict):
        return {str(k): _decode(v, arrays, restored, f"{at}[{k}]") for k, v in node["dict"].items()}
    if "items" in node and isinstance(node["items"], list):
        out: dict[Any, Any] = {}
        for pair in node["items"]:
            if not (isinstance(pair, list) and len(pair) == 2):
                raise CheckpointError(f"CMA-ES state: {at} holds a malformed entry")
            key = _decode(pair[0], arrays, restored, f"{at}<key>")
            if not _hashable_data(key):
                raise CheckpointError(f"CMA-ES state: {at} has a key that is not a plain value")
            out[key] = _decode(pair[1], arrays, restored, f"{at}[{key!r}]")
        return out
    raise CheckpointError(f"CMA-ES state: {at} has an unknown entry {sorted(node)!r}")


def _restore_into(
    obj: Any,
    attrs: Any,
    arrays: Mapping[str, np.ndarray],
    restored: dict[str, Any],
    path: str,
) -> None:
    if not isinstance(attrs, dict):
        raise CheckpointError(f"CMA-ES state: {path} holds no attributes")
    own = vars(obj)
    for name, node in attrs.items():
        at = f"{path}.{name}"
        if not isinstance(name, str) or name.startswith("__") or name in SKIPPED_ATTRIBUTES:
            raise CheckpointError(f"CMA-ES state: {at} may not be restored")
        current = own.get(name, _SKIP)
        if current is _SKIP and hasattr(type(obj), name):
            raise CheckpointError(f"CMA-ES state: {at} would hide a method or property")
        if isinstance(node, dict) and "object" in node:
            if (
                current is _SKIP
                or not _is_cma(current)
                or type(current).__qualname__ != node.get("object")
            ):
                have = type(current).__qualname__ if current is not _SKIP else "nothing"
                raise CheckpointError(
                    f"CMA-ES state: {at} was a {node.get('object')!r}, this strategy has {have}; "
                    "the state was written with other CMA-ES options or another cma version"
                )
            _restore_into(current, node.get("attrs"), arrays, restored, at)
            continue
        if isinstance(node, dict) and "alias_object" in node:
            continue  # the fresh strategy already shares that object
        value = _decode(node, arrays, restored, at)
        if current is not _SKIP:
            if not _is_data(current) and current is not None:
                raise CheckpointError(f"CMA-ES state: {at} is not data in this strategy")
            old, new = _kind(current), _kind(value)
            if old != new and "none" not in (old, new):
                raise CheckpointError(f"CMA-ES state: {at} was a {old}, the file holds a {new}")
        own[name] = value


def restore_state(es: Any, tree: Any, arrays: Mapping[str, np.ndarray]) -> None:
    """Write a state from :func:`dump_state` into ``es``, a fresh strategy of the same options.

    Raises:
        CheckpointError: if the tree does not fit ``es`` (other options, other ``cma`` version,
            a damaged or planted file); ``es`` must then be discarded.
    """
    if not isinstance(tree, dict) or tree.get("object") != type(es).__qualname__:
        raise CheckpointError(
            f"CMA-ES state: the file holds a {tree.get('object') if isinstance(tree, dict) else tree!r}, "
            f"not a {type(es).__qualname__}"
        )
    _restore_into(es, tree.get("attrs"), arrays, {}, "es")
    if "timer" not in vars(es):  # made by the first ask; wall-clock bookkeeping, not state
        from cma.utilities.utils import ElapsedWCTime  # cma is imported on use (cmaes._cma)

        es.timer = ElapsedWCTime()
