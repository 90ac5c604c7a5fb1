"""The documentation site (mkdocs.yml) builds with ``mkdocs build --strict``.

Strict mode turns every broken link or anchor between pages, every page missing from the
navigation and every docstring griffe cannot parse into a failure. The site carries the
Markdown pages, their figures and the API reference, never run folders or large files.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("mkdocs", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("mkdocstrings_handlers.python")

ROOT = Path(__file__).resolve().parents[1]
#: The build takes 10-20 s on the 2-core machine under load; this bounds a hung one.
TIMEOUT_S = 120
#: The largest file the site may carry (the search index is about 1.2 MB).
MAX_FILE_BYTES = 3 * 1024 * 1024


def test_mkdocs_build_strict(tmp_path: Path) -> None:
    site = tmp_path / "site"
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    t0 = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mkdocs",
            "build",
            "--strict",
            "-q",
            "-f",
            "mkdocs.yml",
            "-d",
            str(site),
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    assert elapsed < TIMEOUT_S
    files = [p for p in site.rglob("*") if p.is_file()]
    assert (site / "results").is_dir()
    leaked = [
        p
        for p in (site / "results").rglob("*")
        if p.is_file() and "runs" in p.relative_to(site / "results").parts[:-1]
    ]
    assert not leaked, f"run folders leaked into the site: {leaked[:5]}"
    big = [(p, p.stat().st_size) for p in files if p.stat().st_size > MAX_FILE_BYTES]
    assert not big, f"files too large for the site: {big}"
    for page in ("neuromod", "grn", "envs", "baselines", "evidence", "seed_split", "stats", "runs"):
        html = (site / "api" / page / "index.html").read_text()
        assert f"evodevo.{page}" in html
    assert (site / "results" / "history" / "index.html").is_file()
