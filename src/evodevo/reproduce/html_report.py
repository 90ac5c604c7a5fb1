"""The reports' Markdown as one self-contained HTML file: headings, tables, lists, and the
PNG figures inlined as data URIs (so ``report.html`` can be sent or opened on its own)."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

__all__ = ["markdown_to_html"]

_IMG = re.compile(r"!\[([^\]]*)\]\(([^)]+)\)")


def _inline(text: str) -> str:
    t = html.escape(text)
    t = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", t)


def markdown_to_html(md: str, base: Path) -> str:
    """HTML for the Markdown subset the reports use (headings, tables, lists, images inline)."""
    out = [
        '<!doctype html><meta charset="utf-8"><title>evodevo report</title>',
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
        "img{max-width:100%}</style>",
    ]
    table: list[list[str]] = []
    in_list = False

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
                data = base64.b64encode(p.read_bytes()).decode()
                out.append(
                    f'<p><img alt="{html.escape(m.group(1))}" src="data:image/png;base64,{data}"></p>'
                )
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
    return "\n".join(out) + "\n"
