"""``evodevo compare``: comparison tables across methods (thesis Table 4.2 for Kuka).

User errors raise :class:`~evodevo.errors.EvodevoError`, printed by the top-level CLI as one line.
"""

from __future__ import annotations

from pathlib import Path

import typer

from evodevo.errors import EvodevoError

__all__ = ["app"]

app = typer.Typer(help="Comparison tables across methods (thesis Table 4.2).", no_args_is_help=True)


@app.callback()
def _group() -> None:
    """Comparison tables across methods (thesis Table 4.2)."""


@app.command()
def kuka(
    run_dirs: list[Path] = typer.Argument(
        ..., help="Tested runs of `grn evolve`/`baselines kuka`."
    ),
    out: Path = typer.Option(..., "--out", help="Folder for table_4_2.md/.csv (created)."),
    objects: str = typer.Option("test", help="Which test result to read: test or train objects."),
    target: float = typer.Option(0.5, help="Success whose first reach is the time to target."),
) -> None:
    """Thesis Table 4.2 from tested run directories: Markdown and CSV, thesis numbers beside."""
    from evodevo.baselines.table_4_2 import write_table

    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    write_table(list(run_dirs), out, objects, target)
    typer.echo((out / "table_4_2.md").read_text().rstrip())
