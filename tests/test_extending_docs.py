"""every example of docs/extending.md runs as written (tiny budgets, fast envs only).

The fenced blocks are taken in document order and run in one empty folder with a ``configs/``
link to the repository's: a block whose first line is ``# file: NAME`` is written to ``NAME``;
other ``python`` blocks are run with this interpreter, ``bash`` blocks that call evodevo with
bash (this venv's ``bin/`` first on PATH).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "extending.md"
FENCE = re.compile(r"^```(\w+)\n(.*?)^```$", re.S | re.M)
FILE_LINE = re.compile(r"^# file: (\S+)\n")


@dataclass
class Block:
    lang: str
    code: str
    line: int

    @property
    def file(self) -> str | None:
        m = FILE_LINE.match(self.code)
        return m.group(1) if m else None


def _blocks() -> list[Block]:
    text = DOC.read_text()
    return [
        Block(m.group(1), m.group(2), text.count("\n", 0, m.start()) + 1)
        for m in FENCE.finditer(text)
    ]


def test_blocks_are_parsed():
    blocks = _blocks()
    langs = {b.lang for b in blocks}
    assert {"python", "bash", "yaml"} <= langs
    files = [b.file for b in blocks if b.file]
    assert {"my_envs.py", "linear_ctrl.py", "my_tasks.yaml", "line_grn.yaml"} <= set(files)
    assert not any("Kuka" in b.code for b in blocks), "keep the Kuka env out of these examples"


def test_every_example_of_extending_md_runs(tmp_path):
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    env.pop("PYTHONPATH", None)  # the examples set it where they need it
    ran = 0
    for i, block in enumerate(_blocks()):
        where = f"docs/extending.md line {block.line} ({block.lang})"
        if block.file is not None:
            (tmp_path / block.file).write_text(block.code)
            continue
        if block.lang == "python":
            script = tmp_path / f"_block_{i}.py"
            script.write_text(block.code)
            cmd = [sys.executable, str(script)]
        elif block.lang == "bash" and "evodevo" in block.code:
            cmd = ["bash", "-euo", "pipefail", "-c", block.code]
        else:
            continue
        proc = subprocess.run(
            cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
        )
        if proc.returncode != 0:
            pytest.fail(f"{where} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
        ran += 1
    assert ran >= 8
    assert (tmp_path / "runs" / "pendulum_linear" / "best_genome.npz").is_file()


def test_extending_md_is_linked():
    assert "docs/extending.md" in (ROOT / "README.md").read_text()
    assert "extending.md" in (ROOT / "docs" / "architecture.md").read_text()
    assert "extending.md" in (ROOT / "docs" / "grn.md").read_text()


def test_unimportable_env_module_is_a_clear_error():
    from evodevo.errors import EvodevoError
    from evodevo.grn.evaluator import make_env

    with pytest.raises(EvodevoError, match="no_such_module_xyz.*PYTHONPATH"):
        make_env("no_such_module_xyz:Line-v0")
