"""``evodevo compare``: comparison tables across methods (thesis Table 4.2 for Kuka, an
extended Table 3.2/3.5 for BIARM and its continual-learning baselines).

User errors raise :class:`~evodevo.errors.EvodevoError`, printed by the top-level CLI as one line.
"""

from __future__ import annotations

from pathlib import Path

import typer

from evodevo.baselines.table_4_2 import write_table
from evodevo.errors import EvodevoError
from evodevo.neuromod.compare import write_continual_table

__all__ = ["app"]

app = typer.Typer(
    help="Comparison tables across methods (thesis Tables 3.2/3.5 and 4.2).",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@app.callback()
def _group() -> None:
    """Comparison tables across methods (thesis Tables 3.2/3.5 and 4.2)."""


@app.command()
def kuka(
    run_dirs: list[Path] = typer.Argument(
        ..., help="Tested runs of `grn evolve`/`baselines kuka`."
    ),
    out: Path = typer.Option(..., "--out", help="Folder for table_4_2.md/.csv (created)."),
    objects: str = typer.Option("test", help="Which test result to read: test or train objects."),
    target: float = typer.Option(0.5, help="Success whose first reach is the time to target."),
) -> None:
    """Thesis Table 4.2 from tested run directories: Markdown and CSV, thesis numbers beside.

    Each method's return rule (read from its runs' config.json: evolution.keep, keep.rule) and
    validation episodes are columns; the caption names the test's seed range and says whether
    every learner returns its model by the same rule (SPEC §6).
    """
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    write_table(list(run_dirs), out, objects, target)
    typer.echo((out / "table_4_2.md").read_text().rstrip())


@app.command()
def biarm(
    run_dirs: list[Path] = typer.Argument(
        ..., help="Finished `biarm train` run directories and/or `biarm compare` folders."
    ),
    out: Path = typer.Option(..., "--out", help="Folder for table_continual.md/.csv (created)."),
) -> None:
    """Extended Tables 3.2/3.5: every variant's final return, retention and forgetting (Eq. 1.4).

    One row per variant and task: final return mean ± std with a 95 % bootstrap interval over
    seeds, initial return, retention, the forgetting measure of Eq. 1.4, and the thesis'
    numbers in their own columns; seeds and budget stated above the table.
    """
    md = write_continual_table(list(run_dirs), out)
    typer.echo(md.read_text().rstrip())


@app.command()
def experiment(
    spec: Path = typer.Argument(
        ..., help="YAML registration of the experiment (e.g. docs/results/claims/g1.yaml)."
    ),
    out: Path | None = typer.Option(
        None, "--out", help="Folder for the tables (default: <root>/<name>)."
    ),
) -> None:
    """Decide a pre-registered success-rate experiment from its runs' test files (SPEC §6).

    Reads each arm's result file per registered seed (missing runs are skipped), compares
    the arms paired by seed (exact sign-flip test, bootstrap interval, Holm over the decision,
    margin δ) and writes table.md, comparisons.csv, runs.csv and runs.png. The claim reads
    "pending" until every arm of the decision has all its registered runs.
    """
    from evodevo.evidence.experiment_table import write_experiment

    md = write_experiment(spec, out)
    typer.echo(md.read_text().rstrip())
    typer.echo(f"wrote {md.parent}")
