"""The reports' Markdown as one HTML file: headings, tables, lists, and the PNG figures inlined
as data URIs (so ``report.html`` can be sent or opened on its own).

Figures are inlined until their encoded size reaches ``inline_budget`` bytes (4 MB by default,
so a report with many grids stays a file that a repository and an e-mail accept); the figures
past the budget are linked by their path relative to the report, and the page says how many."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

__all__ = ["INLINE_BUDGET_BYTES", "markdown_to_html"]

INLINE_BUDGET_BYTES = 4_000_000
"""Default cap on the base64 bytes of inlined figures in one HTML report."""

_IMG = re.compile(r"!\[([^\]]*)\]\(([^)]+)\)")


def _inline(text: str) -> str:
    t = html.escape(text)
    t = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", t)


def markdown_to_html(md: str, base: Path, inline_budget: int = INLINE_BUDGET_BYTES) -> str:
    """HTML for the Markdown subset the reports use (headings, tables, lists, images).

    Images are inlined in document order while the sum of their base64 sizes stays within
    ``inline_budget`` bytes; later ones are linked (``src`` relative to ``base``).
    """
    if inline_budget < 0:
        raise ValueError(f"inline_budget must be >= 0 bytes, got {inline_budget}")
    out = [
        '<!doctype html><meta charset="utf-8"><title>evodevo report</title>',
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
        "img{max-width:100%}</style>",
    ]
    table: list[list[str]] = []
    in_list = False
    inlined = 0
    linked = 0

    def flush_table() -> None:
        if table:
            out.append("<table>")
            for i, row in enumerate(table):
                tag = "th" if i == 0 else "td"
                out.append("<tr>" + "".join(f"<{tag}>{_inline(c)}</{tag}>" for c in row) + "</tr>")
            out.append("</table>")
            table.clear()

    for line in md.splitlines():
        s = line.strip()
        if s.startswith("|"):
            cells = [c.strip() for c in s.strip("|").split("|")]
            if not all(set(c) <= set("-: ") for c in cells):
                table.append(cells)
            continue
        flush_table()
        if in_list and not s.startswith("- "):
            out.append("</ul>")
            in_list = False
        if not s:
            continue
        m = _IMG.fullmatch(s)
        if m:
            p = base / m.group(2)
            if p.is_file():
                alt = html.escape(m.group(1))
                data = base64.b64encode(p.read_bytes()).decode()
                if inlined + len(data) <= inline_budget:
                    inlined += len(data)
                    out.append(f'<p><img alt="{alt}" src="data:image/png;base64,{data}"></p>')
                else:
                    linked += 1
                    src = html.escape(m.group(2), quote=True)
                    out.append(f'<p><a href="{src}"><img alt="{alt}" src="{src}"></a></p>')
            continue
        if s.startswith("#"):
            level = len(s) - len(s.lstrip("#"))
            out.append(f"<h{level}>{_inline(s[level:].strip())}</h{level}>")
        elif s.startswith("- "):
            if not in_list:
                out.append("<ul>")
                in_list = True
            out.append(f"<li>{_inline(s[2:])}</li>")
        else:
            out.append(f"<p>{_inline(s)}</p>")
    flush_table()
    if in_list:
        out.append("</ul>")
    if linked:
        out.append(
            f"<p><i>{linked} figure(s) past the {inline_budget / 1e6:.1f} MB inline budget are "
            "linked, not embedded: open this file from its folder to see them.</i></p>"
        )
    return "\n".join(out) + "\n"
