"""``python -m evodevo`` runs the CLI."""

from evodevo.cli import main

main()
