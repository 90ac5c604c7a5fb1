"""docs/cli.md and docs/configuration.md are generated from the code and must be current."""

from __future__ import annotations

from pathlib import Path

import pytest

from evodevo.cli import app
from evodevo.cli.reference import cli_markdown, config_markdown

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.mark.parametrize(
    ("name", "render", "command"),
    [
        ("cli.md", lambda: cli_markdown(app), "evodevo reference cli > docs/cli.md"),
        ("configuration.md", config_markdown, "evodevo reference config > docs/configuration.md"),
    ],
)
def test_reference_page_is_current(name, render, command):
    assert (DOCS / name).read_text() == render(), f"docs/{name} is stale; run `{command}`"
