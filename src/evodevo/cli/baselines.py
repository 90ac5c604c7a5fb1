"""``evodevo baselines``: the Kuka grasping baselines of SPEC §4 (PPO, TD3, NEAT, random, zero).

``evodevo baselines kuka --method M --out DIR`` trains (or, for zero/random, records) one
baseline into a run directory laid out like a GRN run's; ``evodevo baselines evaluate DIR`` tests
it with the GRN's evaluate code (the same fixed test seeds, the trivial policies beside it).
User errors raise :class:`~evodevo.errors.EvodevoError`, printed by the top-level CLI as one line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from evodevo.baselines.kuka_config import METHODS, KukaBaselineConfig
from evodevo.baselines.kuka_runner import read_baseline_config, run_baseline
from evodevo.callbacks import Callback
from evodevo.cli.common import (
    ADDRESS_HELP,
    BACKEND_HELP,
    add_evaluate_command,
    check_backend,
    check_seed,
)
from evodevo.config import load_config, merge, parse_sets
from evodevo.errors import EvodevoError
from evodevo.parallel import set_single_thread
from evodevo.progress import TrainingBar
from evodevo.runs import RunDir, read_json
from evodevo.tensorboard import CurveScalars

__all__ = ["app"]

app = typer.Typer(
    help="Baselines (SPEC §4): PPO, TD3 (Stable-Baselines3), NEAT (neat-python), random, zero.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _budget_from(path: Path, scale: float) -> int:
    """Env steps of a finished run (``summary.json``: ``env_steps``) times ``scale``."""
    summary = read_json(path / "summary.json")
    steps = summary.get("env_steps")
    if not isinstance(steps, int) or steps <= 0:
        raise EvodevoError(f"--budget-from {str(path)!r}: its summary.json records no env_steps")
    return max(1, int(round(steps * scale)))


_METHOD_HELP = "ppo | td3 | neat | random | zero | recurrent_ppo (sb3-contrib)."
_KUKA_SET_HELP = (
    "Override a config key, e.g. --set keep.rule=validated or --set "
    "evaluation.validation_episodes=20 (repeatable; applied last; unknown keys are an error)."
)
_KUKA_TENSORBOARD_HELP = (
    "Also write learning_curve.csv's numbers (and NEAT's history.csv) as TensorBoard "
    "scalars into this folder."
)


#: The defaults the help states, read from the config (written once, in kuka_config).
_DEFAULT = KukaBaselineConfig()


@app.command()
def kuka(
    method: str = typer.Option(..., "--method", help=_METHOD_HELP),
    out: Path = typer.Option(..., "--out", help="Run directory (created)."),
    budget_steps: int | None = typer.Option(
        None,
        "--budget-steps",
        help=f"Training env steps [PPO/TD3 {_DEFAULT.budget.default_env_steps}; NEAT "
        f"{_DEFAULT.neat.generations} generations].",
    ),
    budget_minutes: float | None = typer.Option(
        None, "--budget-minutes", help="Training wall-clock minutes (with or instead of steps)."
    ),
    budget_from: Path | None = typer.Option(
        None, "--budget-from", help="Use the env steps of this run (e.g. a `grn evolve` run)."
    ),
    budget_scale: float = typer.Option(1.0, help="Multiply the --budget-from steps (e.g. 5)."),
    seed: int | None = typer.Option(None, "--seed", help=f"Run seed [{_DEFAULT.seed}]."),
    config: Path | None = typer.Option(
        None, "--config", help="YAML config (configs/baselines_kuka.yaml)."
    ),
    set_: list[str] | None = typer.Option(None, "--set", help=_KUKA_SET_HELP),
    workers: int = typer.Option(1, help="Evaluator worker processes or Ray actors (NEAT)."),
    backend: str = typer.Option("local", help=BACKEND_HELP + " NEAT only."),
    address: str | None = typer.Option(None, help=ADDRESS_HELP),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted run in --out."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar or lines (stderr)."),
    tensorboard: Path | None = typer.Option(None, help=_KUKA_TENSORBOARD_HELP),
) -> None:
    """Train one Kuka baseline into OUT (config.json, summary.json, learning_curve.csv, model).

    NEAT evaluates its genomes through the GRN's evaluator (--workers, --backend ray); PPO and
    TD3 train in this process (Stable-Baselines3), so --backend applies to them only in
    `baselines evaluate`.
    """
    set_single_thread()
    check_seed("--seed", seed)
    if method not in METHODS:
        raise EvodevoError(f"--method {method!r} is not known; choose one of {', '.join(METHODS)}")
    budget_steps = _budget_steps(budget_steps, budget_minutes, budget_from, budget_scale)
    check_backend(backend, address, workers)
    if backend != "local" and method != "neat":
        raise EvodevoError(
            f"--backend {backend} applies to NEAT only: {method} trains in this process; "
            "use --backend ray with `evodevo baselines evaluate` to test it on Ray"
        )
    ov: dict[str, Any] = {"method": method}
    if seed is not None:
        ov["seed"] = seed
    if budget_steps is not None:
        ov.setdefault("budget", {})["env_steps"] = budget_steps
    if budget_minutes is not None:
        ov.setdefault("budget", {})["minutes"] = budget_minutes
    cfg = _kuka_config(out, config, resume, merge(ov, parse_sets(set_)))
    summary = _train(cfg, out, workers, resume, quiet, backend, address, tensorboard)
    reach = summary.get("time_to_target_s")
    typer.echo(
        f"{cfg.method}: {summary['env_steps']} env steps, {summary['wall_s']:.0f} s training"
        f" (stopped by {summary['stopped_by']}); target {cfg.budget.target_success:.2f} "
        + (f"reached after {reach:.0f} s" if reach is not None else "not reached")
        + f"; run in {out}"
    )


def _budget_steps(
    steps: int | None, minutes: float | None, budget_from: Path | None, scale: float
) -> int | None:
    """``--budget-steps``, or the steps of ``--budget-from`` times ``--budget-scale``; every
    budget option checked (SPEC §4: the baselines train for the GRN's env steps)."""
    if steps is not None and steps <= 0:
        raise EvodevoError(f"--budget-steps {steps} must be > 0")
    if minutes is not None and minutes <= 0:
        raise EvodevoError(f"--budget-minutes {minutes} must be > 0")
    if scale <= 0:
        raise EvodevoError(f"--budget-scale {scale} must be > 0")
    if budget_from is None:
        return steps
    if steps is not None:
        raise EvodevoError("--budget-from and --budget-steps contradict each other; give one")
    return _budget_from(budget_from, scale)


def _kuka_config(
    out: Path, config: Path | None, resume: bool, ov: dict[str, Any]
) -> KukaBaselineConfig:
    """The config of ``baselines kuka``: ``--config`` (or, on ``--resume`` without it, the
    run's saved config) with ``ov``, the command's flags and ``--set``, applied last."""
    if resume and config is None and (out / "config.json").is_file():
        saved = read_json(out / "config.json")
        if saved.get("kind") != "baseline":
            raise EvodevoError(
                f"--resume: {str(out)!r} holds a {saved.get('kind')!r} run, not a baseline run"
            )
        return load_config(KukaBaselineConfig, None, merge(saved.get("config", {}), ov))
    return load_config(KukaBaselineConfig, config, ov)


def _train(
    cfg: KukaBaselineConfig,
    out: Path,
    workers: int,
    resume: bool,
    quiet: bool,
    backend: str,
    address: str | None,
    tensorboard: Path | None,
) -> dict[str, Any]:
    """``run_baseline`` with a progress bar over the budget and the TensorBoard sink."""
    b = cfg.budget
    by_generation = cfg.method == "neat" and b.env_steps is None
    if b.env_steps is not None:
        total: int | None = b.env_steps
    elif b.minutes is not None:
        total = None  # a wall-clock budget: the bar counts steps (generations) and time
    else:
        total = cfg.neat.generations if by_generation else b.default_env_steps
    unit = "generations" if by_generation else "env steps"
    trained = cfg.method in ("ppo", "td3", "neat", "recurrent_ppo")
    callbacks: list[Callback] = []
    tb = None
    if tensorboard is not None:
        tb = CurveScalars(tensorboard)
        callbacks.append(tb)
    try:
        with TrainingBar(f"{cfg.method} {unit}", total, quiet or not trained, by_generation) as bar:
            return run_baseline(
                cfg,
                out,
                workers=workers,
                resume=resume,
                quiet=quiet,
                backend=backend,
                address=address,
                callbacks=[bar, *callbacks],
            )
    finally:
        if tb is not None:
            tb.close()


def _check_baseline_run(run_dir: Path) -> None:
    """A clear error when RUN_DIR holds another kind of run."""
    read_baseline_config(RunDir(run_dir, create=False))


add_evaluate_command(
    app,
    help="Test a baseline on the fixed test seeds with the GRN's evaluate code (SPEC §2.5, §4).",
    run_help="Run directory of `evodevo baselines kuka`.",
    noise_help="Visual-feature noise std (NEAT only).",
    check_run=_check_baseline_run,
)
