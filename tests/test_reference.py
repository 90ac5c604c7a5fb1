"""Reference pages generated from the code cover every command and config key."""

from __future__ import annotations

import typer

from evodevo.cli import app
from evodevo.cli.reference import cli_markdown, config_markdown


def _leaf_commands(cmd, path):
    if hasattr(cmd, "list_commands"):
        ctx = cmd.context_class(cmd)
        for name in cmd.list_commands(ctx):
            yield from _leaf_commands(cmd.get_command(ctx, name), [*path, name])
    else:
        yield " ".join(path)


def test_cli_reference_lists_every_command_and_option():
    md = cli_markdown(app)
    root = typer.main.get_command(app)
    leaves = list(_leaf_commands(root, ["evodevo"]))
    assert "evodevo biarm train" in leaves and "evodevo grn evolve" in leaves
    for leaf in leaves:
        assert f"`{leaf}`" in md
    assert "`--episodes-scale`" in md and "[default: 0]" in md


def test_config_reference_lists_keys_with_defaults():
    md = config_markdown()
    assert "| `dqn.lr` | `0.001` |" in md
    assert "| `grn.population` | `12` |" in md
    assert "## GRN" in md
