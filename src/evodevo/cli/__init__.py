"""The ``evodevo`` command line (Typer).

Sub-commands live in one file each: :mod:`evodevo.cli.biarm`, :mod:`evodevo.cli.grn`,
:mod:`evodevo.cli.reproduce`. User errors (:class:`~evodevo.errors.EvodevoError`, and an
``OSError`` on a path the user gave) print one line ``error: ...`` and exit with status 2,
without a traceback.
"""

from __future__ import annotations

import sys

import typer

from evodevo import __version__
from evodevo.cli import baselines, biarm, compare, grn, reference, reproduce
from evodevo.errors import EvodevoError

__all__ = ["app", "main"]

app = typer.Typer(
    name="evodevo",
    help="Evolutionary developmental robotics: BIARM and GRN controllers, with honest baselines.",
    no_args_is_help=True,
    rich_markup_mode=None,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _show_version(value: bool) -> None:
    if value:
        typer.echo(f"evodevo {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        is_eager=True,
        callback=_show_version,
        help="Print the version and exit.",
    ),
) -> None:
    """Evolutionary developmental robotics: BIARM and GRN controllers, with honest baselines."""


app.add_typer(biarm.app, name="biarm")
app.add_typer(grn.app, name="grn")
app.add_typer(baselines.app, name="baselines")
app.add_typer(compare.app, name="compare")
app.command("reproduce")(reproduce.reproduce)
app.add_typer(reference.app, name="reference")


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    try:
        app(args=argv, standalone_mode=True)
    except EvodevoError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:  # a path the user gave: one line, not a traceback
        if exc.filename is None:
            raise
        typer.echo(
            f"error: {exc.filename}: {exc.strerror or exc}; check the path and its permissions",
            err=True,
        )
        sys.exit(2)
