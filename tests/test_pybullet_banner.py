"""Workers and commands print no ``pybullet build time`` banner (PyBullet comes from
:mod:`evodevo.envs.bullet`)."""

from __future__ import annotations

import subprocess
import sys


def test_making_the_kuka_env_prints_no_banner() -> None:
    code = (
        "import gymnasium as gym, evodevo.envs\n"
        "env = gym.make('evodevo/KukaDiverseObject-v0')\n"
        "env.reset(seed=0)\n"
        "print('stepped')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "stepped" in res.stdout
    assert "pybullet build time" not in res.stdout + res.stderr


def test_a_plain_pybullet_import_does_print_it() -> None:
    """The check above can fail: PyBullet imported directly still prints the banner."""
    res = subprocess.run(
        [sys.executable, "-c", "import pybullet"], capture_output=True, text=True, timeout=60
    )
    assert "pybullet build time" in res.stdout + res.stderr
