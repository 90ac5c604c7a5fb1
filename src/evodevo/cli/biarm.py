"""``evodevo biarm``: placeholder app, filled in by the biarm package work."""

import typer

app = typer.Typer(help="biarm commands", no_args_is_help=True)
