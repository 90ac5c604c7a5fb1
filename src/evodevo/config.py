"""Typed configuration objects loaded from YAML (STYLE.md point 1).

Every experiment has one ``@dataclass`` config whose fields carry defaults (the thesis'
settings, SPEC.md) and a one-line doc in ``field(metadata={"doc": ...})``. :func:`load_config`
builds one from a YAML file and/or a dict of overrides; unknown keys, wrong types and values
rejected by a dataclass' ``validate()`` raise :class:`~evodevo.errors.ConfigError` naming the key.

>>> from dataclasses import dataclass
>>> @dataclass
... class C:
...     lr: float = 1e-3
>>> from_dict(C, {"lr": 0.5}).lr
0.5
"""

from __future__ import annotations

import copy
import dataclasses
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, Union, get_args, get_origin

import yaml

from evodevo.errors import ConfigError

__all__ = [
    "doc",
    "from_dict",
    "load_config",
    "merge",
    "to_dict",
    "describe",
    "replace",
    "parse_sets",
    "resolve",
    "read_yaml",
]

T = TypeVar("T")


def doc(default: Any = dataclasses.MISSING, text: str = "", **kw: Any) -> Any:
    """A dataclass field with a default and a one-line documentation string."""
    if isinstance(default, (list, dict, set)) or (
        dataclasses.is_dataclass(default) and not isinstance(default, type)
    ):
        value = default
        return dataclasses.field(
            default_factory=lambda: copy.deepcopy(value), metadata={"doc": text}, **kw
        )
    return dataclasses.field(default=default, metadata={"doc": text}, **kw)


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def _coerce(value: Any, tp: Any, where: str) -> Any:
    """Convert a YAML value to the annotated type, or raise ConfigError naming ``where``."""
    origin = get_origin(tp)
    if tp is Any:
        return value
    if origin is Union or origin is types.UnionType:
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(value, arg, where)
            except ConfigError as exc:
                errors.append(str(exc))
        raise ConfigError(f"{where}: {value!r} is not a valid value ({'; '.join(errors)})")
    if origin is Literal:
        allowed = get_args(tp)
        if value not in allowed:
            raise ConfigError(f"{where}: {value!r} is not accepted; choose one of {list(allowed)}")
        return value
    if dataclasses.is_dataclass(tp):
        if isinstance(value, tp):  # type: ignore[arg-type]
            return value
        if not isinstance(value, Mapping):
            raise ConfigError(
                f"{where}: expected a mapping of {_type_name(tp)} fields, got {value!r}"
            )
        return from_dict(tp, value, where)  # type: ignore[arg-type]
    if origin in (list, tuple):
        if isinstance(value, str) and origin is list:
            value = [v.strip() for v in value.split(",") if v.strip()]
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        args = get_args(tp)
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise ConfigError(f"{where}: expected {len(args)} values, got {len(value)}")
            return tuple(
                _coerce(v, a, f"{where}[{i}]")
                for i, (v, a) in enumerate(zip(value, args, strict=True))
            )
        item = args[0] if args else Any
        out = [_coerce(v, item, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(out) if origin is tuple else out
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    if tp is int:
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or float(value) != int(value)
        ):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return int(value)
    if tp is float:
        if isinstance(value, bool):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        try:
            return float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"{where}: expected a number, got {value!r}") from None
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected text, got {value!r}")
        return value
    if origin is dict or tp is dict:
        if not isinstance(value, Mapping):
            raise ConfigError(f"{where}: expected a mapping, got {value!r}")
        return dict(value)
    return value


def from_dict(cls: type[T], data: Mapping[str, Any], where: str = "") -> T:
    """Build dataclass ``cls`` from ``data``; unknown keys and bad values raise ConfigError."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where or cls.__name__}: expected a mapping, got {data!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(fields))
    if unknown:
        prefix = f"{where}." if where else ""
        raise ConfigError(
            f"unknown config key {prefix}{unknown[0]!s}; accepted keys here: {', '.join(sorted(fields))}"
        )
    kwargs = {}
    for name, value in data.items():
        key = f"{where}.{name}" if where else name
        kwargs[name] = _coerce(value, hints[name], key)
        if name == "seed" or name.endswith("_seed"):
            _check_seed(key, kwargs[name])
    try:
        obj = cls(**kwargs)
    except TypeError as exc:
        raise ConfigError(f"{where or cls.__name__}: {exc}") from None
    validate = getattr(obj, "validate", None)
    if callable(validate):
        try:
            validate()
        except ConfigError as exc:
            raise ConfigError(f"{where + ': ' if where else ''}{exc}") from None
    return obj


def load_config(
    cls: type[T], path: str | Path | None = None, overrides: Mapping[str, Any] | None = None
) -> T:
    """Load ``cls`` from a YAML file (optional) and then apply ``overrides`` (nested dicts merge)."""
    data = read_yaml(path) if path is not None else {}
    if overrides:
        data = merge(data, overrides)
    return from_dict(cls, data)


def read_yaml(path: str | Path, what: str = "config file") -> dict[str, Any]:
    """The mapping in YAML file ``path`` (empty file: ``{}``); one clear error otherwise."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{what} {str(p)!r} does not exist; pass an existing YAML file")
    try:
        loaded = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"{what} {str(p)!r} is not valid YAML: {_yaml_error(exc)}") from None
    if loaded is None:
        return {}
    if not isinstance(loaded, Mapping):
        raise ConfigError(
            f"{what} {str(p)!r} must hold a mapping of keys, got {type(loaded).__name__}"
        )
    return dict(loaded)


def parse_sets(items: typing.Iterable[str] | None) -> dict[str, Any]:
    """Nested overrides from ``--set key.sub=value`` options (values read as YAML).

    >>> parse_sets(["evolution.optimizer=cmaes", "genome.regulation=false"])
    {'evolution': {'optimizer': 'cmaes'}, 'genome': {'regulation': False}}
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, eq, value = item.partition("=")
        parts = [p.strip() for p in key.split(".")]
        if not eq or not all(parts):
            raise ConfigError(f"--set {item!r} must look like section.key=value")
        node = out
        for p in parts[:-1]:
            child = node.setdefault(p, {})
            if not isinstance(child, dict):
                raise ConfigError(f"--set {item!r}: {p!r} was already set to a value")
            node = child
        try:
            node[parts[-1]] = yaml.safe_load(value)
        except yaml.YAMLError as exc:
            raise ConfigError(
                f"--set {item!r}: the value is not valid YAML ({_yaml_error(exc)})"
            ) from None
    return out


def resolve(
    cls: type[T],
    preset: Mapping[str, Any] | None = None,
    path: str | Path | None = None,
    sets: typing.Iterable[str] | None = None,
    flags: Mapping[str, Any] | None = None,
) -> T:
    """The config every command runs with, in one order: the dataclass defaults, then a
    preset's overrides, then the ``--config`` file, then ``--set key=value``, then the
    command's own flags (nested dicts; None values are left out). Unknown keys and bad values
    fail here, naming the key.

    >>> from dataclasses import dataclass
    >>> @dataclass
    ... class C:
    ...     lr: float = 1e-3
    ...     batch: int = 64
    >>> resolve(C, preset={"lr": 0.1, "batch": 8}, sets=["lr=0.5"], flags={"batch": None})
    C(lr=0.5, batch=8)
    """
    data = merge(dict(preset or {}), read_yaml(path) if path is not None else {})
    data = merge(data, parse_sets(sets))
    data = merge(data, _without_none(flags or {}))
    return from_dict(cls, data)


def _without_none(flags: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in flags.items():
        if isinstance(v, Mapping):
            inner = _without_none(v)
            if inner:
                out[k] = inner
        elif v is not None:
            out[k] = v
    return out


def _yaml_error(exc: yaml.YAMLError) -> str:
    """One line of a YAML error: what is wrong and where (line and column, 1-based)."""
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    what = getattr(exc, "problem", None) or getattr(exc, "context", None) or str(exc)
    what = " ".join(str(what).split())
    if mark is None:
        return what
    return f"{what} at line {mark.line + 1}, column {mark.column + 1}"


def _check_seed(key: str, value: Any) -> None:
    """Seeds (fields named ``seed`` or ``*_seed``) are non-negative integers (NumPy's rule)."""
    if isinstance(value, int) and not isinstance(value, bool) and value < 0:
        raise ConfigError(f"{key}={value}: a seed must be >= 0")


def merge(base: Mapping[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    """``extra`` over ``base``, nested mappings merged key by key; an *empty* mapping in
    ``extra`` replaces the one in ``base`` (merging it would change nothing, so writing
    ``key: {}`` means "none", e.g. ``dqn.per_task: {}`` over a default with entries).

    >>> merge({"a": {"x": 1, "y": 2}, "b": {"z": 3}}, {"a": {"y": 5}, "b": {}})
    {'a': {'x': 1, 'y': 5}, 'b': {}}
    """
    out = dict(base)
    for k, v in extra.items():
        if isinstance(v, Mapping) and v and isinstance(out.get(k), Mapping):
            out[k] = merge(out[k], v)
        else:
            out[k] = v
    return out


def to_dict(cfg: Any) -> dict[str, Any]:
    """A JSON-ready dict of a config dataclass (tuples become lists)."""
    return typing.cast(dict[str, Any], _plain(dataclasses.asdict(cfg)))


def _plain(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


def replace(cfg: T, **changes: Any) -> T:
    """``dataclasses.replace`` followed by validation."""
    obj = dataclasses.replace(cfg, **changes)  # type: ignore[type-var]
    validate = getattr(obj, "validate", None)
    if callable(validate):
        validate()
    return obj


def describe(cls: type, prefix: str = "") -> list[tuple[str, str, str]]:
    """Rows ``(key, default, doc)`` for every field, nested sections flattened (for docs)."""
    rows: list[tuple[str, str, str]] = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        key = prefix + f.name
        tp = hints[f.name]
        if dataclasses.is_dataclass(tp):
            rows.extend(describe(tp, key + "."))  # type: ignore[arg-type]
            continue
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = "(required)"
        rows.append((key, repr(default), f.metadata.get("doc", "")))
    return rows
