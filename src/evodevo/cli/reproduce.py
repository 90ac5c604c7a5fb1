"""``evodevo reproduce``: one command that reruns both methods and writes a report."""

from __future__ import annotations

from pathlib import Path

import typer


def reproduce(
    budget: str = typer.Option("quick", help="quick (minutes) or thesis (the full protocol)."),
    out: Path = typer.Option(..., help="Run directory for the report and all sub-runs."),
    seed: int = typer.Option(0, help="Base seed."),
    workers: int = typer.Option(2, help="Worker processes."),
) -> None:
    """Rerun BIARM and the GRN protocol at a budget and write DIR/report.md."""
    from evodevo.reproduce import run_reproduce

    run_reproduce(budget=budget, out=out, seed=seed, workers=workers)
