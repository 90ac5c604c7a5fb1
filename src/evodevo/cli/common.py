"""Helpers shared by the CLI sub-commands: seed ranges, list options, backends, ``evaluate``."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import typer

from evodevo.config import parse_sets
from evodevo.errors import EvodevoError
from evodevo.grn.evaluation import evaluate_run
from evodevo.parallel import set_single_thread
from evodevo.progress import CommandProgress
from evodevo.seeding import parse_seeds

__all__ = ["parse_seeds", "parse_list", "check_seed", "renamed"]


def check_seed(option: str, seed: int | None) -> None:
    """Reject a negative seed (NumPy seeds are non-negative) before any work starts."""
    if seed is not None and seed < 0:
        raise EvodevoError(f"{option} {seed} must be >= 0 (seeds are non-negative integers)")


def renamed(old: str, new: str, old_value: Any, new_value: Any) -> Any:
    """The value of option ``new``, also accepted under its deprecated name ``old``.

    The old name prints a one-line notice on stderr; giving both is an error.
    """
    if old_value is None:
        return new_value
    if new_value is not None:
        raise EvodevoError(f"{old} is the old name of {new}; give {new} only")
    typer.echo(f"warning: {old} is deprecated here; use {new} (same meaning)", err=True)
    return old_value


#: Help of the test options shared by ``evaluate``, ``baselines`` and ``ablate``.
TEST_EPISODES_HELP = "Test episodes [40 = evaluation.test_episodes of the config]."
TEST_SEED_HELP = (
    "Seed of the fixed test episodes [the run's evaluation.test_seed: 1000000, the locked test "
    "range, for runs configured since the seed split; 10000, a validation seed, for older runs; "
    "the output names the range, SPEC §6]."
)
OLD_EPISODES_HELP = "Deprecated name of --test-episodes."
OLD_SEED_HELP = "Deprecated name of --test-seed."


def parse_list(text: str | None, option: str | None = None) -> list[str] | None:
    """Comma-separated list, or None when not given.

    With ``option`` (e.g. ``"--tasks"``), a given text that names nothing (``''``, ``','``)
    is an error instead of meaning "the default".
    """
    if text is None:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items and option is not None:
        raise EvodevoError(
            f"{option} {text!r} names nothing; give a comma-separated list or leave {option} out"
        )
    return items or None


# ---------------------------------------------------------------------------- backends
#: Help of ``--backend`` and ``--address`` (every command that spreads work over workers).
BACKEND_HELP = "local (in-process / process pool) or ray (Ray actors)."
ADDRESS_HELP = "Ray cluster: auto or HOST:PORT (with --backend ray; default: a private local Ray)."


TEST_SET_HELP = (
    "Change what the run is tested on, e.g. --set env.kwargs.dark_after=1 (repeatable; "
    "evaluation.* and env.* only; the result files get a suffix naming the change)."
)

SET_HELP = (
    "Override a config key, e.g. --set evolution.optimizer=cmaes or --set "
    "genome.regulation=false (repeatable; applied last; unknown keys are an error)."
)


def check_backend(backend: str, address: str | None, workers: int) -> None:
    """Reject a bad ``--backend``/``--address``/``--workers`` before any work starts."""
    if workers < 1:
        raise EvodevoError(f"--workers {workers} must be at least 1")
    if backend not in ("local", "ray"):
        raise EvodevoError(f"--backend {backend!r} is not known; choose local or ray")
    if address is not None and backend != "ray":
        raise EvodevoError("--address only goes with --backend ray")


# ---------------------------------------------------------------------------- evaluate
def format_rate(name: str, r: Mapping[str, Any]) -> str:
    """``  name  55.0 % [40.0, 69.2] (22 successes)`` of a success-rate dict."""
    return (
        f"  {name:<16} {100 * r['success_rate']:5.1f} % "
        f"[{100 * r['ci_low']:.1f}, {100 * r['ci_high']:.1f}] ({r['successes']} successes)"
    )


_BASELINES_HELP = "Also run the trivial policies (all-zero, random, constant turn)."
_BASELINES_FROM_HELP = "JSON of `grn baselines` for the same episodes (reused)."


def add_evaluate_command(
    app: typer.Typer,
    *,
    help: str,
    run_help: str,
    noise_help: str,
    label: str | None = None,
    check_run: Callable[[Path], None] | None = None,
) -> None:
    """Register the ``evaluate`` command shared by ``evodevo grn`` and ``evodevo baselines``.

    Both test a run directory with :func:`evodevo.grn.evaluation.evaluate_run` (the same fixed
    test seeds, the trivial policies beside it; SPEC §2.5) and print the same lines.

    Args:
        app: the sub-command group.
        help: the command's help text.
        run_help: help of the RUN_DIR argument.
        noise_help: help of ``--noise``.
        label: name printed for the tested controller (None: the run's controller kind).
        check_run: called with RUN_DIR first (a clear error for another kind of run).
    """

    def evaluate(
        run_dir: Path = typer.Argument(..., help=run_help),
        test_episodes: int | None = typer.Option(None, help=TEST_EPISODES_HELP),
        objects: str = typer.Option("test", help="test (held-out objects) or train."),
        noise: float = typer.Option(0.0, help=noise_help),
        test_seed: int | None = typer.Option(None, help=TEST_SEED_HELP),
        workers: int = typer.Option(1, help="Worker processes or Ray actors."),
        backend: str = typer.Option("local", help=BACKEND_HELP),
        address: str | None = typer.Option(None, help=ADDRESS_HELP),
        baselines: bool = typer.Option(True, "--baselines/--no-baselines", help=_BASELINES_HELP),
        baselines_from: Path | None = typer.Option(
            None, "--baselines-from", help=_BASELINES_FROM_HELP
        ),
        as_json: bool = typer.Option(False, "--json", help="Print the result as JSON (last line)."),
        old_episodes: int | None = typer.Option(
            None, "--episodes", hidden=True, help=OLD_EPISODES_HELP
        ),
        old_seed: int | None = typer.Option(None, "--seed", hidden=True, help=OLD_SEED_HELP),
        quiet: bool = typer.Option(False, "--quiet", help="No progress bar (stderr)."),
        set_: list[str] | None = typer.Option(None, "--set", help=TEST_SET_HELP),
    ) -> None:
        episodes = renamed("--episodes", "--test-episodes", old_episodes, test_episodes)
        seed = renamed("--seed", "--test-seed", old_seed, test_seed)
        set_single_thread()
        check_backend(backend, address, workers)
        check_seed("--test-seed", seed)
        if check_run is not None:
            check_run(run_dir)
        with CommandProgress("evaluate", quiet):
            res = evaluate_run(
                run_dir,
                episodes,
                objects,
                noise,
                seed,
                workers,
                baselines,
                baselines_from,
                backend=backend,
                address=address,
                overrides=parse_sets(set_),
            )
        if as_json:
            typer.echo(json.dumps({k: v for k, v in res.items() if k != "machine"}))
            return
        _echo_evaluation(
            res, label if label is not None else str(res["controller"]), objects, noise
        )

    app.command("evaluate", help=help)(evaluate)


def _echo_evaluation(res: Mapping[str, Any], name: str, objects: str, noise: float) -> None:
    """The lines ``evaluate`` prints: the test, the run's rate (clean and noisy), the baselines."""
    typer.echo(
        f"{res['episodes']} episodes on {objects} objects, test seed {res['test_seed']} "
        f"({res.get('seed_range', 'test')} range, SPEC §6), noise {noise:g}"
    )
    typer.echo(format_rate(name, res))
    if "clean" in res:
        typer.echo(format_rate(f"{name} (clean)", res["clean"]))
        if res.get("retention") is not None:
            typer.echo(f"  retention noisy/clean: {res['retention']:.2f}")
    for base, r in res["baselines"].items():
        typer.echo(format_rate(base, r))


__all__ += [
    "BACKEND_HELP",
    "ADDRESS_HELP",
    "SET_HELP",
    "check_backend",
    "format_rate",
    "add_evaluate_command",
]
