"""``evodevo reproduce``: one command that reruns both methods and writes a report."""

from __future__ import annotations

from pathlib import Path

import typer

from evodevo.cli.common import check_seed, renamed
from evodevo.parallel import set_single_thread
from evodevo.reproduce import run_reproduce

__all__ = ["reproduce"]


def reproduce(
    out: Path = typer.Option(..., "--out", help="Run directory for the report and all sub-runs."),
    budget: str = typer.Option(
        "quick",
        help="quick (every step at a tiny budget; measured times in docs/results/make_run.md) "
        "or thesis (the full protocol).",
    ),
    config: Path | None = typer.Option(None, "--config", help="YAML budget replacing the preset."),
    seed_offset: int = typer.Option(0, help="Offset added to every seed of the budget."),
    workers: int | None = typer.Option(None, help="Worker processes per step [budget's, 2]."),
    report_only: bool = typer.Option(
        False, "--report-only", help="Only rewrite the report from saved runs."
    ),
    only: list[str] | None = typer.Option(
        None,
        "--only",
        help="Run only the steps whose names match these patterns (repeatable or comma-"
        "separated, e.g. 'kuka-*-td3-x5-s0'); the report still covers the whole budget.",
    ),
    show_plan: bool = typer.Option(
        False,
        "--plan",
        help="List the steps with their status (done, in progress, to do); run none.",
    ),
    old_seed: int | None = typer.Option(
        None, "--seed", hidden=True, help="Deprecated name of --seed-offset."
    ),
    set_: list[str] | None = typer.Option(
        None,
        "--set",
        help="Override a budget key, e.g. --set grn.population=8 or --set biarm.seeds=0-1 "
        "(repeatable; after the preset or --config; unknown keys are an error).",
    ),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar over the steps (stderr)."),
) -> None:
    """Rerun BIARM and the GRN protocol at a budget (resumable) and write OUT/report.md and .html."""
    seed = renamed("--seed", "--seed-offset", old_seed, seed_offset or None) or 0
    set_single_thread()
    check_seed("--seed-offset", seed)
    run_reproduce(
        budget=budget,
        out=out,
        seed=seed,
        workers=workers,
        config=config,
        report_only=report_only,
        only=only,
        show_plan=show_plan,
        quiet=quiet,
        sets=set_,
    )
