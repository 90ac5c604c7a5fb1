"""Griffe extension for the docs site: bare ``>>>`` examples in docstrings become code blocks.

evodevo's docstrings carry short doctests in their running text (Gymnasium style), which
pytest runs as they are. Markdown would read them as paragraphs (and ``x[0][1]`` as a
reference link), so before a docstring is rendered every run of lines that starts at column 0
with ``>>>`` and goes on to the next blank line is fenced as ``pycon``. Indented examples (those
inside a Google ``Examples:`` section) and lines inside existing fences are left alone.
"""

from __future__ import annotations

from typing import Any

import griffe

FENCE = "```"


def fence_doctests(text: str) -> str:
    """``text`` with each column-0 doctest run wrapped in a ``pycon`` fence."""
    out: list[str] = []
    in_fence = in_doctest = False
    for line in text.splitlines():
        if in_doctest and not line.strip():
            out.append(FENCE)
            in_doctest = False
        if not in_doctest and line.lstrip().startswith(FENCE):
            in_fence = not in_fence
        elif not in_fence and not in_doctest and line.startswith(">>>"):
            out.append(FENCE + "pycon")
            in_doctest = True
        out.append(line)
    if in_doctest:
        out.append(FENCE)
    return "\n".join(out)


class DoctestBlocks(griffe.Extension):
    """Fences the bare doctests of every loaded object's docstring."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None and ">>>" in obj.docstring.value:
            obj.docstring.value = fence_doctests(obj.docstring.value)
