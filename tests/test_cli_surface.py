"""the CLI's surface -- defaults visible in plain-text help, ``--version``, one
meaning per option name, old names kept as deprecated aliases."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from evodevo import __version__
from evodevo.cli import app
from evodevo.errors import EvodevoError

runner = CliRunner()


def _commands() -> Iterator[tuple[list[str], Any]]:
    """``(path, click command)`` of every leaf command."""

    def walk(cmd: Any, path: list[str]) -> Iterator[tuple[list[str], Any]]:
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                yield from walk(sub, [*path, name])
        else:
            yield path, cmd

    yield from walk(typer.main.get_command(app), [])


COMMANDS = list(_commands())


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_version():
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.output.strip() == f"evodevo {__version__}"


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=" ".join)
def test_help_keeps_brackets_and_has_no_rst(path):
    cmd = dict((tuple(p), c) for p, c in COMMANDS)[tuple(path)]
    res = runner.invoke(app, [*path, "--help"], terminal_width=200)
    assert res.exit_code == 0, res.output
    text = _flat(res.output)
    assert "``" not in text
    for param in cmd.params:
        help_text = getattr(param, "help", None) or ""
        if getattr(param, "hidden", False):
            continue
        for bracket in re.findall(r"\[[^\]]+\]", help_text):  # e.g. "[40]", "[evaluation...]"
            assert _flat(bracket) in text, (path, bracket)


def test_one_meaning_per_option_name():
    shown: dict[str, list[tuple[str, str]]] = {}
    for path, cmd in COMMANDS:
        for p in cmd.params:
            if getattr(p, "param_type_name", "") == "option" and not p.hidden:
                for opt in p.opts:
                    shown.setdefault(opt, []).append((" ".join(path), p.help or ""))
    # --episodes is training episodes, --seed a run seed; the test counterparts have their own
    assert [c for c, _ in shown["--episodes"]] == ["grn evolve"]
    assert all("Run seed" in h for _, h in shown["--seed"]), shown["--seed"]
    for opt in ("--test-episodes", "--test-seed"):
        assert {c for c, _ in shown[opt]} == {
            "grn evaluate",
            "grn baselines",
            "grn ablate",
            "baselines evaluate",
        }


def test_deprecated_alias_prints_one_notice(tmp_path):
    missing = str(tmp_path / "missing")
    res = runner.invoke(app, ["grn", "evaluate", missing, "--episodes", "3"])
    assert "warning: --episodes is deprecated here; use --test-episodes" in res.output
    assert isinstance(res.exception, EvodevoError) and "does not exist" in str(res.exception)
    res = runner.invoke(app, ["grn", "evaluate", missing, "--seed", "3", "--test-seed", "4"])
    assert "give --test-seed only" in str(res.exception)
    res = runner.invoke(app, ["reproduce", "--seed", "-2", "--out", missing])
    assert "--seed is deprecated" in res.output and "--seed-offset -2" in str(res.exception)
