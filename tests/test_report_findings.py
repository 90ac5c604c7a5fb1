"""The reproduction report opens with its findings (one line per method), then the coverage."""

from __future__ import annotations

import json
from pathlib import Path

from evodevo.config import from_dict
from evodevo.reproduce.budget import ReproduceConfig, preset
from evodevo.reproduce.findings import findings
from evodevo.reproduce.report import write_report

THESIS = Path(__file__).resolve().parents[1] / "docs" / "results" / "thesis"


def test_findings_read_the_committed_thesis_runs() -> None:
    """The headline numbers equal those docs/results quotes from the same committed run files."""
    cfg = from_dict(ReproduceConfig, json.loads((THESIS / "config.json").read_text())["config"])
    text = "\n".join(findings(THESIS, cfg))
    assert text.startswith("## Findings")
    assert "as listed under Coverage" in text  # thesis-as-run is not the thesis preset
    biarm, grn, kuka = (line for line in text.splitlines() if line.startswith("- **"))
    assert "protocol `v1`" in biarm and "seeds 0-4" in biarm
    assert "biarm 106.2 / -87.0 / -200.0 / 231.7 (5 runs)" in biarm
    assert "pnn 142.4 / -91.7 / -184.3 / -69.6 (5 runs)" in biarm
    assert "evaluation seeds 10000-10019 (validation range)" in biarm
    assert "plain 43.5 / 54.5 / 51.0 % on seeds 0 / 1 / 2 (pooled 49.7 % [45.7, 53.7])" in grn
    assert "constant turn action gets 52.5 %" in grn and "validation range" in grn
    assert "PPO 41.5 % [36.8, 46.4] (2 runs)" in kuka and "TD3 51.2 % [46.4, 56.1]" in kuka


def test_quick_report_opens_with_findings_then_coverage(tmp_path: Path) -> None:
    md = write_report(tmp_path, preset("quick")).read_text()
    assert md.index("## Findings") < md.index("## Coverage against the full protocol")
    assert "**smoke-budget numbers**" in md
    assert "- no part of the budget has finished yet" in md
