"""Property test: random malformed configs give a ConfigError, never a traceback."""

from __future__ import annotations

import dataclasses
import typing

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evodevo.config import from_dict
from evodevo.errors import ConfigError
from evodevo.grn.config import GrnConfig
from evodevo.neuromod.config import BiarmConfig
from evodevo.reproduce.budget import ReproduceConfig

CLASSES = [BiarmConfig, GrnConfig, ReproduceConfig]

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**6), max_value=10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _keys(cls: type, prefix: str = "") -> list[str]:
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        out.append(prefix + f.name)
        if dataclasses.is_dataclass(hints[f.name]):
            out += _keys(hints[f.name], prefix + f.name + ".")
    return out


def _set(data: dict, dotted: str, value: object) -> dict:
    node = data
    parts = dotted.split(".")
    for p in parts[:-1]:
        node = node.setdefault(p, {})
        if not isinstance(node, dict):
            return data
    node[parts[-1]] = value
    return data


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_malformed_configs_raise_config_error(cls, data):
    keys = _keys(cls) + ["not_a_key", "dqn.not_a_key"]
    cfg: dict = {}
    for _ in range(data.draw(st.integers(1, 3))):
        _set(cfg, data.draw(st.sampled_from(keys)), data.draw(values))
    try:
        from_dict(cls, cfg)
    except ConfigError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg.strip()


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_defaults_are_valid(cls):
    assert from_dict(cls, {}) == cls()
