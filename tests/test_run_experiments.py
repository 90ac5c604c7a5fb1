"""The claims queue (docs/results/claims/run_experiments.sh): its locks and its experiment list.

Two lanes of the queue may run at once; a lock per run keeps them off each other's runs. These
tests source the script (which then only defines its functions) and never train anything.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "docs" / "results" / "claims" / "run_experiments.sh"

pytestmark = pytest.mark.skipif(
    shutil.which("flock") is None or shutil.which("git") is None, reason="needs flock and git"
)


def _bash(code: str, locks: Path) -> subprocess.CompletedProcess[str]:
    """Source the script, point its locks at LOCKS and run CODE."""
    script = f'source "{SCRIPT}"; locks="{locks}"; set +e; {code}'
    return subprocess.run(
        ["bash", "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=60
    )


def test_the_script_parses():
    proc = subprocess.run(["bash", "-n", str(SCRIPT)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_a_free_lock_runs_the_command_and_a_held_one_skips_it(tmp_path):
    free = _bash("with_lock a/run_s0 echo ran", tmp_path)
    assert free.returncode == 0, free.stderr
    assert free.stdout.strip() == "ran"
    assert (tmp_path / "a_run_s0.lock").is_file()

    held = _bash(
        f'( flock 9; with_lock a/run_s0 echo ran; echo "rc=$?" ) 9>"{tmp_path}/a_run_s0.lock"',
        tmp_path,
    )
    assert held.returncode == 0, held.stderr
    assert "ran" not in held.stdout.replace("rc=", "")
    assert "skipped, the other lane holds it: a/run_s0" in held.stdout
    assert "rc=0" in held.stdout


def test_a_failing_command_under_a_lock_fails_the_caller(tmp_path):
    proc = _bash('with_lock k false; echo "rc=$?"', tmp_path)
    assert "rc=1" in proc.stdout


def test_compare_locks_its_output_folder(tmp_path):
    """Two lanes never run ``biarm compare`` into one folder at once (it rewrites its tables)."""
    proc = _bash(
        f'( flock 9; compare SRC --variants pnn --seeds 0-1 --out x/v1/ ) 9>"{tmp_path}/x_v1.lock"',
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert "skipped, the other lane holds it: x/v1" in proc.stdout


def test_every_queued_experiment_is_a_function_and_every_decision_has_its_file():
    text = SCRIPT.read_text()
    default = re.search(r'"\$\{@:-([A-Z0-9 ]+)\}"', text)
    assert default is not None
    names = default.group(1).split()
    assert {"E1", "G3", "E3B"} <= set(names)
    proc = subprocess.run(
        ["bash", "-c", f'source "{SCRIPT}"; declare -F {" ".join(n.lower() for n in names)}'],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    decided = set(re.findall(r"^\s*decide (\w+)$", text, flags=re.M))
    assert {"g1", "g3", "e2"} <= decided
    for name in decided:
        assert (SCRIPT.parent / f"{name}.yaml").is_file(), name


def test_prune_drops_resume_only_files_of_finished_runs_only(tmp_path):
    """PRUNE keeps what a finished run's tables read and everything of an unfinished run."""

    def run(name: str, summary: str | None, files: list[str]) -> Path:
        folder = tmp_path / name
        (folder / "checkpoints").mkdir(parents=True)
        if summary is not None:
            (folder / "summary.json").write_text(summary)
        for f in files:
            (folder / "checkpoints" / f).write_bytes(b"x")
        return folder / "checkpoints"

    grn = run("grn_s0", '{"done": true}', ["checkpoint.npz", "validation.safetensors"])
    going = run("grn_s1", '{"done": false}', ["checkpoint.npz", "validation.safetensors"])
    ppo = run(
        "ppo_s0",
        '{"method": "ppo"}',
        [
            "rl_model_12000_steps.safetensors",
            "candidate_12779_steps.safetensors",
            "validation.safetensors",
            "clock.json",
        ],
    )
    neat = run(
        "neat_s0",
        '{"done": true}',
        ["neat-checkpoint-15.json", "neat_state.json", "validation.safetensors"],
    )
    biarm = run(
        "v1/runs/biarm__s0",
        "{}",
        [
            "task0.safetensors",
            "task1.safetensors",
            "task2.safetensors",
            "task3.safetensors",
            "task3_ep450.safetensors",
        ],
    )
    training = run("v1/runs/clamped__s0", None, ["task0.safetensors", "task1_ep50.safetensors"])

    proc = _bash(f'out="{tmp_path}"; py="{sys.executable}"; prune', tmp_path)
    assert proc.returncode == 0, proc.stderr
    left = {d.parent.name: sorted(p.name for p in d.iterdir()) for d in (grn, going, ppo, neat)}
    assert left == {
        "grn_s0": ["validation.safetensors"],
        "grn_s1": ["checkpoint.npz", "validation.safetensors"],
        "ppo_s0": ["clock.json", "validation.safetensors"],
        "neat_s0": ["validation.safetensors"],
    }
    assert sorted(p.name for p in biarm.iterdir()) == ["task3.safetensors"]
    assert sorted(p.name for p in training.iterdir()) == [
        "task0.safetensors",
        "task1_ep50.safetensors",
    ]
    assert proc.stdout.count("pruned ") == 9


def test_status_counts_each_experiments_runs_so_far(tmp_path):
    """STATUS reads the registrations and counts the result files that exist (nothing else)."""
    (tmp_path / "t1.yaml").write_text(
        "name: T1\nseeds: 0-3\narms: {a: 'a_s{seed}/r.json', b: 'b_s{seed}/r.json'}\n"
        "decision: [a - b]\n"
    )
    (tmp_path / "a_s1").mkdir()
    (tmp_path / "a_s1" / "r.json").write_text(
        '{"successes": 3, "episodes": 10, "objects": "test", "test_seed": 1000000}'
    )
    (tmp_path / "t2.yaml").write_text(
        "name: T2\nseeds: 0-1\narms: {a: 'x_s{seed}/r.json', b: 'y_s{seed}/r.json'}\n"
        "decision: [a - b]\n"
    )
    runs = tmp_path / "default" / "runs" / "pnn__s4"
    runs.mkdir(parents=True)
    (runs / "summary.json").write_text("{}")
    proc = _bash(f'out="{tmp_path}"; py="{sys.executable}"; status', tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "T1: 1 of 8 runs (a 1/4, b 0/4)" in lines
    assert "T2: 0 of 4 runs (a 0/2, b 0/2)" in lines
    assert "E1: 1 of 30 runs (pnn 1/10, biarm 0/10, single 0/10)" in lines
