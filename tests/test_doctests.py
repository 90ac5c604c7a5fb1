"""The examples in the package's docstrings run and give what they say (``>>>`` lines)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import evodevo

MODULES = sorted(
    m.name
    for m in pkgutil.walk_packages(evodevo.__path__, "evodevo.")
    if not m.name.endswith("__main__")
)


def _with_examples(name: str) -> bool:
    try:
        mod = importlib.import_module(name)
    except ImportError:  # an optional extra (e.g. ray) that is not installed
        return False
    return bool(doctest.DocTestFinder().find(mod)) and any(
        t.examples for t in doctest.DocTestFinder().find(mod)
    )


@pytest.mark.parametrize("name", [m for m in MODULES if _with_examples(m)])
def test_docstring_examples(name: str) -> None:
    mod = importlib.import_module(name)
    res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0, f"{res.failed} of {res.attempted} docstring examples of {name} failed"
