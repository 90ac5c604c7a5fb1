"""The resumable pipeline of ``evodevo reproduce``.

Each step is one ``evodevo`` CLI call run as a subprocess (the CLI is the contract, so the
pipeline does not depend on any package's internals). A step whose outputs exist is skipped, so
a killed ``reproduce`` continues where it stopped; interrupted evolutions resume from their own
checkpoints (``--resume``). Each step's output goes to the console and to ``OUT/logs/``.
"""

from __future__ import annotations

import fnmatch
import json
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evodevo.config import resolve, to_dict
from evodevo.errors import EvodevoError
from evodevo.neuromod.config import THESIS_TASKS, BiarmConfig
from evodevo.progress import StepBar
from evodevo.reproduce.budget import PRESETS, ReproduceConfig
from evodevo.reproduce.report import write_report
from evodevo.reproduce.run_files import finished, kuka_run_dir
from evodevo.runs import RunDir, atomic_write_text
from evodevo.seeding import parse_seeds

__all__ = ["Step", "plan", "run_reproduce", "run_step"]


@dataclass
class Step:
    """One CLI call: ``argv`` after ``evodevo``; done when every path in ``outputs`` exists and
    no output ``summary.json`` says ``"done": false`` (``grn evolve`` writes its summary after
    every generation, so an evolution stopped mid-way has one: it must resume, not count as
    finished)."""

    name: str
    argv: list[str]
    outputs: list[Path]
    capture_json: Path | None = None
    resume_if: Path | None = None
    extra: dict[str, str] = field(default_factory=dict)

    def done(self) -> bool:
        return all(p.exists() and finished(p) for p in self.outputs)


def _grn_runs(cfg: ReproduceConfig, out: Path) -> list[tuple[str, str, int, list[str]]]:
    """(label, controller, seed, extra evolve flags) of every GRN evolution."""
    g = cfg.grn
    # "vision" is the plain GRN with the default preset (blob front-end, substeps,
    # shaped training fitness); every other label runs the thesis preset (configs/grn.yaml).
    thesis = ["--preset", "thesis"]

    def flags(c: str) -> list[str]:
        return ["--preset", "vision"] if c == "vision" else ["--controller", c, *thesis]

    runs = [(c, c, s, flags(c)) for c in g.controllers for s in parse_seeds(g.seeds)]
    controls: list[tuple[str, str, int, list[str]]] = []
    if g.controls:
        for s in parse_seeds(g.control_seeds):
            controls.append(("blind", "plain", s, ["--blind", *thesis]))
            controls.append(("openloop", "open_loop", s, ["--open-loop", *thesis]))
            if "vision" in g.controllers:
                controls.append(("vision_blind", "plain", s, ["--preset", "vision", "--blind"]))
    # The controls come right after the first evolution: the headline comparison (GRN vs
    # blind GRN vs open loop) is complete early in a long, resumed-many-times run.
    return runs[:1] + controls + runs[1:]


def _biarm_tasks(b: Any) -> list[str]:
    """``biarm compare`` options for the budget's tasks: ``--tasks`` and ``--episodes-scale``,
    or, with ``task_episodes``, the whole task list with each task's episodes."""
    if not b.task_episodes:
        return ["--episodes-scale", repr(b.episodes_scale), "--tasks", ",".join(b.tasks)]

    thesis = {e: (n, m) for e, n, m in THESIS_TASKS}
    default = BiarmConfig().default_episodes
    tasks = []
    for env in b.tasks:
        n, m = thesis.get(env, (default, None))
        episodes = b.task_episodes.get(env, max(1, int(round(n * b.episodes_scale))))
        tasks.append({"env_id": env, "episodes": int(episodes), "max_steps": m})
    return ["--set", "tasks=" + json.dumps(tasks)]


def plan(cfg: ReproduceConfig, out: Path) -> list[Step]:
    """Every step of the budget, in order: the BIARM grids, then the GRN's trivial policies,
    evolutions and tests, the Kuka baselines, and last the GRN's ablations and plots."""
    steps = _biarm_steps(cfg, out) if cfg.biarm.enabled else []
    if cfg.grn.enabled:
        first, late = _grn_steps(cfg, out)
        steps += first + _kuka_steps(cfg, out) + late
    return steps


def _biarm_steps(cfg: ReproduceConfig, out: Path) -> list[Step]:
    """One ``biarm compare`` grid per protocol."""
    w = str(cfg.workers)
    steps: list[Step] = []
    b = cfg.biarm
    grids = [("biarm", b.protocol), *b.other_protocols.items()]
    for folder, protocol in grids:
        bdir = out / folder
        steps.append(
            Step(
                "biarm-compare" if folder == "biarm" else f"biarm-compare-{protocol}",
                [
                    "biarm",
                    "compare",
                    "--variants",
                    ",".join(b.variants),
                    "--seeds",
                    b.seeds,
                    "--protocol",
                    protocol,
                    *_biarm_tasks(b),
                    "--set",
                    f"eval.episodes={b.eval_episodes}",
                    "--workers",
                    w,
                    "--out",
                    str(bdir),
                ],
                [bdir / "table_3_2.md"],
            )
        )
    return steps


def _grn_steps(cfg: ReproduceConfig, out: Path) -> tuple[list[Step], list[Step]]:
    """The GRN's trivial policies and every evolution with its tests, and (second list) the
    ablations and plots, which run after all evolutions and tests."""
    g = cfg.grn
    w = str(cfg.workers)
    steps: list[Step] = []
    # The trivial policies run once per object split; every evaluation reuses them
    # (same test seeds, so the same episodes).
    for objects, n in (("test", g.test_episodes), ("train", g.train_episodes)):
        path = out / "grn" / f"baselines_{objects}.json"
        steps.append(
            Step(
                f"grn-baselines-{objects}",
                [
                    "grn",
                    "baselines",
                    "--test-episodes",
                    str(n),
                    "--objects",
                    objects,
                    "--workers",
                    w,
                    "--out",
                    str(path),
                ],
                [path],
            )
        )
    # Ablations and plots of every evolution run after all evolutions and tests.
    late: list[Step] = []
    for label, _controller, seed, flags in _grn_runs(cfg, out):
        run_steps, run_late = _grn_run_steps(cfg, out, label, seed, flags)
        steps += run_steps
        late += run_late
    return steps, late


def _grn_run_steps(
    cfg: ReproduceConfig, out: Path, label: str, seed: int, flags: list[str]
) -> tuple[list[Step], list[Step]]:
    """One evolution: evolve, test (and, for a studied controller, ablate and plot)."""
    g = cfg.grn
    w = str(cfg.workers)
    steps: list[Step] = []
    late: list[Step] = []
    rdir = out / "grn" / f"{label}_s{seed}"
    own = g.vision_budget == "preset" and label.startswith("vision")
    budget = [] if own else [
        "--population",
        str(g.population),
        "--generations",
        str(g.generations),
        "--episodes",
        str(g.episodes),
    ]  # fmt: skip
    steps.append(
        Step(
            f"grn-evolve-{label}-s{seed}",
            [
                "grn",
                "evolve",
                *budget,
                "--seed",
                str(seed),
                "--workers",
                w,
                *flags,
                "--out",
                str(rdir),
            ],
            [rdir / "summary.json"],
            resume_if=rdir / "config.json",
        )
    )
    steps += _grn_test_steps(cfg, out, label, seed, rdir)
    if label in g.controllers:
        late += _grn_study_steps(cfg, label, seed, rdir)
    return steps, late


def _grn_test_steps(
    cfg: ReproduceConfig, out: Path, label: str, seed: int, rdir: Path
) -> list[Step]:
    """The test calls of one evolution, each capturing its JSON result."""
    g = cfg.grn
    w = str(cfg.workers)
    steps: list[Step] = []
    # A noisy evaluation also runs the clean test and the trivial policies on the same
    # seeds (evodevo.grn.evaluation), so a controller needs one test call, not two.
    if label in g.controllers:
        evals = [
            ("test_noisy", "test", 0.03, g.test_episodes),
            ("train_clean", "train", 0.0, g.train_episodes),
        ]
    else:
        evals = [("test_clean", "test", 0.0, g.test_episodes)]
    for tag, objects, noise, n in evals:
        steps.append(
            Step(
                f"grn-evaluate-{label}-s{seed}-{tag}",
                [
                    "grn",
                    "evaluate",
                    str(rdir),
                    "--test-episodes",
                    str(n),
                    "--objects",
                    objects,
                    "--noise",
                    repr(noise),
                    "--workers",
                    w,
                    "--baselines-from",
                    str(out / "grn" / f"baselines_{objects}.json"),
                    "--json",
                ],
                [rdir / f"repro_{tag}.json"],
                capture_json=rdir / f"repro_{tag}.json",
            )
        )
    return steps


def _grn_study_steps(cfg: ReproduceConfig, label: str, seed: int, rdir: Path) -> list[Step]:
    """A studied controller's ablations and plots (they run after every evolution and test)."""
    g = cfg.grn
    w = str(cfg.workers)
    late: list[Step] = []
    # the neuromodulated GRN: one ablation per modulator (SPEC §5); else the nine
    # ablations of SPEC §2.5, which apply to plain GRN genomes only
    modulated = label == "neuromodulated"
    late.append(
        Step(
            f"grn-ablate-{label}-s{seed}",
            [
                "grn",
                "ablate",
                str(rdir),
                "--test-episodes",
                str(g.ablation_episodes),
                "--workers",
                w,
                *(["--modulators"] if modulated else []),
            ],
            [rdir / ("modulator_ablations.csv" if modulated else "ablations.csv")],
        )
    )
    late.append(
        Step(
            f"grn-plot-{label}-s{seed}",
            ["grn", "plot", str(rdir)],
            [rdir / "figures" / "expression_trace.png"],
        )
    )
    return late


def _kuka_steps(cfg: ReproduceConfig, out: Path) -> list[Step]:
    """Train and test every Kuka baseline at the GRN's env-step budget times each scale."""
    k, g = cfg.kuka, cfg.grn
    if not k.enabled:
        return []
    w = str(cfg.workers)
    grn_seeds = parse_seeds(g.seeds)
    steps: list[Step] = []
    for scale in k.budget_scales:
        for method in k.methods:
            for seed in parse_seeds(k.seeds):
                # the budget of the plain GRN run with the same seed (else the first seed's)
                ref = (
                    out
                    / "grn"
                    / f"{g.controllers[0]}_s{seed if seed in grn_seeds else grn_seeds[0]}"
                )
                rdir = kuka_run_dir(out, method, scale, seed)
                tag = f"{method}-x{scale:g}-s{seed}"
                steps.append(
                    Step(
                        f"kuka-train-{tag}",
                        [
                            "baselines",
                            "kuka",
                            "--method",
                            method,
                            "--budget-from",
                            str(ref),
                            "--budget-scale",
                            repr(float(scale)),
                            "--seed",
                            str(seed),
                            "--workers",
                            w,
                            "--out",
                            str(rdir),
                        ],
                        [rdir / "summary.json"],
                        resume_if=rdir / "checkpoints",
                    )
                )
                steps.append(
                    Step(
                        f"kuka-evaluate-{tag}",
                        [
                            "baselines",
                            "evaluate",
                            str(rdir),
                            "--test-episodes",
                            str(g.test_episodes),
                            "--objects",
                            "test",
                            "--workers",
                            w,
                            "--baselines-from",
                            str(out / "grn" / "baselines_test.json"),
                            "--json",
                        ],
                        [rdir / "repro_test_clean.json"],
                        capture_json=rdir / "repro_test_clean.json",
                    )
                )
    return steps


def _started(marker: Path) -> bool:
    """A file that exists, or a folder that holds something (e.g. a checkpoint)."""
    if marker.is_dir():
        return any(marker.iterdir())
    return marker.exists()


def status(step: Step) -> str:
    """``done``, ``in progress`` (started: it resumes) or ``to do``."""
    if step.done():
        return "done"
    started = step.resume_if is not None and _started(step.resume_if)
    return "in progress" if started or any(p.exists() for p in step.outputs) else "to do"


def run_step(step: Step, log_dir: Path, echo: bool = True) -> None:
    """Run one step as ``python -m evodevo ...``; raise EvodevoError if it fails."""
    argv = list(step.argv)
    if step.resume_if is not None and _started(step.resume_if):
        argv.append("--resume")
    cmd = [sys.executable, "-m", "evodevo", *argv]
    log_dir.mkdir(parents=True, exist_ok=True)
    log_path = log_dir / f"{step.name}.log"
    last = ""
    with log_path.open("w") as log:
        log.write("$ evodevo " + " ".join(argv) + "\n")
        log.flush()  # the log is read while the step runs (tail -f)
        proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1
        )
        assert proc.stdout is not None
        for line in proc.stdout:
            log.write(line)
            log.flush()
            if echo:
                sys.stdout.write("  " + line)
                sys.stdout.flush()
            if line.strip():
                last = line.strip()
        rc = proc.wait()
    if rc != 0:
        raise EvodevoError(f"step {step.name} failed (exit {rc}); see {log_path}")
    if step.capture_json is not None:
        try:
            json.loads(last)
        except json.JSONDecodeError:
            raise EvodevoError(f"step {step.name} printed no JSON result; see {log_path}") from None
        atomic_write_text(step.capture_json, last + "\n")


def select(steps: list[Step], only: list[str] | None) -> list[Step]:
    """The steps whose name matches one of the ``only`` patterns (all steps if none given)."""
    if not only:
        return steps
    patterns = [p.strip() for item in only for p in item.split(",") if p.strip()]
    chosen = [s for s in steps if any(fnmatch.fnmatchcase(s.name, p) for p in patterns)]
    if not chosen:
        names = ", ".join(s.name for s in steps)
        raise EvodevoError(
            f"--only {','.join(patterns)!r} matches no step of this budget; its steps are: {names}"
        )
    return chosen


def run_reproduce(
    budget: str = "quick",
    out: Path = Path("runs/quick"),
    seed: int = 0,
    workers: int | None = None,
    config: Path | None = None,
    report_only: bool = False,
    only: list[str] | None = None,
    show_plan: bool = False,
    quiet: bool = False,
    sets: list[str] | None = None,
) -> Path:
    """Run (or resume) every step of ``budget`` into ``out`` and write the report; return its path.

    The budget is resolved in the one order of :func:`evodevo.config.resolve`: the
    :class:`ReproduceConfig` defaults, then the preset ``budget`` (or, instead of it, the
    ``config`` file), then ``sets`` (``--set key=value`` on budget keys, e.g.
    ``grn.population=8`` or ``biarm.seeds=0-1``), then ``workers``.

    ``only``: shell-style patterns of step names (e.g. ``kuka-*-td3-x5-s0``); the other steps
    are left as they are, and the report still covers the whole budget (its unfinished parts
    listed), so several selections can run side by side into one folder. ``show_plan``: print
    each (selected) step with its status and return without running anything. Unless ``quiet``,
    a bar on stderr counts the steps (elapsed time, ETA) and names the running one.
    """

    if budget not in PRESETS:
        raise EvodevoError(
            f"--budget {budget!r} is not a budget; choose one of {', '.join(PRESETS)}"
        )
    if workers is not None and workers < 1:
        raise EvodevoError(f"--workers {workers} must be >= 1")
    # --config FILE replaces the preset; --set and --workers override both.
    preset = None if config else PRESETS[budget]
    cfg = resolve(ReproduceConfig, preset, config, sets, {"workers": workers})
    if seed:
        cfg.grn.seeds = ",".join(str(s + seed) for s in parse_seeds(cfg.grn.seeds))
        cfg.grn.control_seeds = ",".join(str(s + seed) for s in parse_seeds(cfg.grn.control_seeds))
        cfg.biarm.seeds = ",".join(str(s + seed) for s in parse_seeds(cfg.biarm.seeds))
    if show_plan:
        chosen = select(plan(cfg, out), only)
        for i, step in enumerate(chosen, 1):
            print(f"[{i}/{len(chosen)}] {step.name}: {status(step)}", flush=True)
        return out / "report.md"
    run = RunDir(out)
    run.write_config(to_dict(cfg), kind="reproduce")
    steps = [] if report_only else select(plan(cfg, out), only)
    t0 = time.perf_counter()
    ran = 0
    with StepBar("reproduce", len(steps), quiet=quiet or not steps) as bar:
        for i, step in enumerate(steps, 1):
            bar.step(i - 1, step.name)
            if step.done():
                print(f"[{i}/{len(steps)}] {step.name}: done already, skipped", flush=True)
                continue
            print(
                f"[{i}/{len(steps)}] {step.name} (elapsed {time.perf_counter() - t0:.0f} s)",
                flush=True,
            )
            run_step(step, out / "logs")
            ran += 1
        bar.update(len(steps), "reproduce: report")
    path = write_report(out, cfg, wall_s=time.perf_counter() - t0, steps_run=ran)
    print(
        f"report: {path} (and {path.with_suffix('.html')}) after {time.perf_counter() - t0:.0f} s",
        flush=True,
    )
    return path
