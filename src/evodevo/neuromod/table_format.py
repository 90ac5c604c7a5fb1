"""Text of the BIARM tables: Markdown and CSV rows, seed ranges, variant order (SPEC §6).

>>> format_seeds([0, 1, 2, 3, 4, 7])
'0-4, 7'
>>> print(md_table(["a", "b"], [["1", "2"]]), end="")
| a | b |
|---|---|
| 1 | 2 |
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from typing import Any

from evodevo.neuromod.variants import VARIANTS

__all__ = ["pm", "md_table", "csv_text", "format_seeds", "variant_order", "table_markdown"]


def pm(mean: float, std: float, digits: int = 2) -> str:
    """``mean ± std`` with ``digits`` decimals."""
    return f"{mean:.{digits}f} ± {std:.{digits}f}"


def md_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table of a header and rows of cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def csv_text(header: list[str], rows: list[list[Any]]) -> str:
    """CSV text of a header and rows."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


def format_seeds(seeds: Sequence[int]) -> str:
    """Seeds as compact ranges: ``[0, 1, 2, 3, 4, 7]`` -> ``"0-4, 7"``."""
    parts: list[str] = []
    ordered = sorted(set(int(s) for s in seeds))
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        parts.append(str(ordered[i]) if j == i else f"{ordered[i]}-{ordered[j]}")
        i = j + 1
    return ", ".join(parts)


def variant_order(runs: Mapping[str, Any]) -> list[str]:
    """Known variants in their table order, then any other name found, sorted."""
    known = [v for v in VARIANTS if v in runs]
    return known + sorted(v for v in runs if v not in VARIANTS)


def table_markdown(caption: str, header: list[str], rows: list[list[str]]) -> str:
    """A table under its one-line caption."""
    return f"{caption}\n\n" + md_table(header, rows)
