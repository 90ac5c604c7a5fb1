"""README's results section holds the current answers only (SPEC §6; issue 40): at most 15
rows, each stating its runs and which seed range its numbers come from, and every results page
opens with its answer."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _results_rows() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text.split("\n## Results", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ")]
    return rows[1:]  # the header; the |---| line does not start with "| "


def test_readme_results_table_has_at_most_15_rows_each_with_its_range_and_runs():
    rows = _results_rows()
    assert 1 <= len(rows) <= 15, f"README's results table has {len(rows)} rows (at most 15)"
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == 6, (
            f"a results row needs 6 cells (what, figure, runs, range, thesis, page): {row[:80]}"
        )
        what, _, runs, seeds, _, _ = cells
        assert runs, f"row {what[:60]!r} does not say how many runs"
        assert re.search(r"validation range|locked test range|same", seeds), (
            f"row {what[:60]!r} does not say which seed range its numbers come from"
        )


def test_every_results_page_opens_with_its_answer():
    pages = sorted((ROOT / "docs" / "results").glob("*.md"))
    assert pages
    for page in pages:
        if page.name in {"history.md", "claims.md", "make_run.md"}:
            continue  # the history log; the claims table; make run's own description
        headings = [line for line in page.read_text().splitlines() if line.startswith("## ")]
        assert headings and headings[0] == "## The answer", (
            f"{page.relative_to(ROOT)} must open with '## The answer' (its first section is "
            f"{headings[0] if headings else 'missing'!r})"
        )
