"""``evodevo grn``: placeholder app, filled in by the grn package work."""

import typer

app = typer.Typer(help="grn commands", no_args_is_help=True)
