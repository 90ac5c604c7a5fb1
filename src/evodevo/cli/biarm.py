"""``evodevo biarm``: train one run, compare variants over seeds, re-draw a report (SPEC §1).

Examples::

    evodevo biarm train --variant biarm --seed 0 --out runs/biarm_s0
    evodevo biarm train --resume --out runs/biarm_s0      # after a kill or Ctrl-C
    evodevo biarm train --variant pnn --tasks CartPole-v1,Acrobot-v1 --episodes-scale 0.1 --out runs/x
    evodevo biarm compare --variants biarm,pnn --seeds 0-4 --workers 2 --out runs/cmp
    evodevo biarm train --variant ewc --seed 0 --out runs/ewc_s0   # or finetune, sb3-dqn
    evodevo biarm report runs/cmp
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import typer

import evodevo
from evodevo.callbacks import CallbackList
from evodevo.cli.common import ADDRESS_HELP, check_backend, check_seed, parse_list, parse_seeds
from evodevo.config import describe, from_dict, merge, parse_sets, resolve
from evodevo.errors import ConfigError, EvodevoError
from evodevo.neuromod.compare import contrast_table, grid_progress, run_grid, write_report
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.protocol_sweep import SweepSpec, protocol_config, run_sweep, sweep_table
from evodevo.neuromod.resolve import resolve_biarm
from evodevo.neuromod.resume import saved_config
from evodevo.neuromod.tasks import resolve_tasks
from evodevo.neuromod.trainer import train as run_train
from evodevo.neuromod.variants import VARIANTS, Variant, get_variant
from evodevo.parallel import set_single_thread
from evodevo.progress import CommandProgress, TaskBars
from evodevo.runs import read_json, run_kind
from evodevo.signals import GracefulStop
from evodevo.tensorboard import EpisodeScalars, RunsExporter
from evodevo.video import film_episode, save_frames

#: Every variant name, for the help texts.
VARIANT_NAMES = ", ".join(VARIANTS)

__all__ = ["app"]

_TASKS_HELP = (
    "Comma-separated Gymnasium ids, each optionally with the environment's own parameters, "
    "ID[key=value,...], e.g. 'CartPole-v1,LunarLander-v3[gravity=-5]' (default: thesis)."
)
_SEQUENCE_HELP = (
    "A named sequence of related tasks instead of --tasks: cartpole-dynamics, "
    "cartpole-dynamics-reversed, lunarlander-gravity (evodevo/presets/biarm_sequences/)."
)

app = typer.Typer(
    help="BIARM: neuromodulated progressive networks (SPEC §1).",
    no_args_is_help=True,
    rich_markup_mode=None,
    add_completion=False,
)


def _load(
    config: Path | None,
    tasks: str | None,
    episodes_scale: float | None,
    overrides: list[str] | None = None,
    protocol: str | None = None,
    sequence: str | None = None,
) -> BiarmConfig:
    """:func:`evodevo.neuromod.resolve.resolve_biarm` of the command's options."""
    return resolve_biarm(protocol, config, overrides, episodes_scale, tasks, sequence)


_PROTOCOL_HELP = (
    "DQN protocol preset (SPEC 1.6): default (the measured choice), v3 (the default without "
    "CartPole's gradient clip of 1), scaled (v3 with 10 validation episodes, as its first full "
    "runs), v2 (unscaled Xavier laterals, Eq. 3.7 as written, 10 validation episodes) or v1 "
    "(the first results' protocol)."
)
_SET_HELP = "Override a config key, e.g. --set eval.episodes=5 (repeatable)."


def _resume_settings(
    out: Path, variant: str | None, seed: int | None, own_config: bool
) -> tuple[str | None, int | None, Any]:
    """Variant, seed and config saved in OUT/config.json (for ``train --resume``)."""
    saved = read_json(out / "config.json")
    if saved.get("kind") != "biarm":
        raise EvodevoError(
            f"--resume: {str(out)!r} holds a {saved.get('kind')!r} run, not a BIARM run"
        )
    data = saved_config(saved.get("config", {}))
    saved_variant, saved_seed = data.pop("variant", None), data.pop("seed", None)
    cfg = None if own_config else from_dict(BiarmConfig, data)
    return (
        variant if variant is not None else saved_variant,
        seed if seed is not None else saved_seed,
        cfg,
    )


@app.command()
def train(
    variant: str | None = typer.Option(None, help=f"One of {VARIANT_NAMES} [biarm]."),
    tasks: str | None = typer.Option(None, help=_TASKS_HELP),
    sequence: str | None = typer.Option(None, help=_SEQUENCE_HELP),
    episodes_scale: float | None = typer.Option(None, help="Multiply every task's episodes."),
    seed: int | None = typer.Option(
        None, help="Run seed (every random stream derives from it) [0]."
    ),
    config: Path | None = typer.Option(None, help="YAML config (configs/biarm.yaml keys)."),
    set_: list[str] | None = typer.Option(None, "--set", help=_SET_HELP),
    protocol: str | None = typer.Option(
        None,
        help=_PROTOCOL_HELP,
    ),
    resume: bool = typer.Option(
        False,
        help="Continue from the newest checkpoint in --out (after a task, or every "
        "checkpoint_every episodes); variant, seed and config default to the saved ones.",
    ),
    quiet: bool = typer.Option(False, help="No progress bar."),
    tensorboard: Path | None = typer.Option(
        None, help="Also write the per-episode metrics as TensorBoard scalars into this folder."
    ),
    out: Path = typer.Option(..., help="Run directory."),
) -> None:
    """Train one variant through the task sequence into OUT.

    SIGINT/SIGTERM finish the current episode, write a checkpoint and stop; --resume
    continues with the numbers an uninterrupted run would give.
    """
    check_seed("--seed", seed)
    cfg = None
    if resume and not (out / "config.json").is_file():
        where = "does not exist" if not out.exists() else "holds no run (no config.json)"
        raise EvodevoError(
            f"--resume: {str(out)!r} {where}; check --out, or start a new run without --resume"
        )
    if resume:
        own = (
            config is not None
            or tasks is not None
            or sequence is not None
            or episodes_scale is not None
            or bool(set_)
            or protocol is not None
        )
        variant, seed, cfg = _resume_settings(out, variant, seed, own)
    var = get_variant(variant if variant is not None else "biarm")
    seed = 0 if seed is None else seed
    if cfg is None:
        cfg = _load(config, tasks, episodes_scale, set_, protocol, sequence)
    resolve_tasks(cfg)
    set_single_thread()
    with GracefulStop() as stop:
        summary = _train_with_progress(cfg, var, seed, out, resume, quiet, stop, tensorboard)
    for t in summary["tasks"]:
        typer.echo(
            f"{t['env_id']:16s} initial {t['initial_return']:9.2f}  final {t['final_return']:9.2f}"
            f"  retention {t['retention']:.3f}  {t['us_per_step']:.0f} µs/step"
        )
    typer.echo(f"wrote {out}/summary.json")


def _train_with_progress(
    cfg: BiarmConfig,
    var: Variant,
    seed: int,
    out: Path,
    resume: bool,
    quiet: bool,
    stop: Any,
    tensorboard: Path | None = None,
) -> dict[str, Any]:
    """``trainer.train`` with one progress bar per task unless ``quiet`` (and TensorBoard
    scalars into ``tensorboard`` if given)."""
    if tensorboard is None:
        return _train_with_bars(cfg, var, seed, out, resume, quiet, stop, None)

    tb = EpisodeScalars(tensorboard)
    try:
        return _train_with_bars(cfg, var, seed, out, resume, quiet, stop, tb)
    finally:
        tb.close()


def _train_with_bars(
    cfg: BiarmConfig,
    var: Variant,
    seed: int,
    out: Path,
    resume: bool,
    quiet: bool,
    stop: GracefulStop,
    tb: Any,
) -> dict[str, Any]:
    with TaskBars(quiet) as bars:
        callback = CallbackList([bars, tb])
        return run_train(cfg, var, seed, out, resume=resume, callback=callback, stop=stop)


@app.command()
def compare(
    variants: str = typer.Option(
        "biarm,pnn", help=f"Comma-separated variants out of {VARIANT_NAMES}."
    ),
    seeds: str = typer.Option("0-4", help="Seeds, e.g. 0-4 or 0,2,5."),
    episodes_scale: float | None = typer.Option(None, help="Multiply every task's episodes."),
    tasks: str | None = typer.Option(None, help=_TASKS_HELP),
    sequence: str | None = typer.Option(None, help=_SEQUENCE_HELP),
    workers: int = typer.Option(2, help="Parallel runs (worker processes or Ray actors)."),
    config: Path | None = typer.Option(None, help="YAML config."),
    set_: list[str] | None = typer.Option(None, "--set", help=_SET_HELP),
    protocol: str | None = typer.Option(
        None,
        help=_PROTOCOL_HELP,
    ),
    backend: str = typer.Option(
        "local", help="local (process pool) or ray (one Ray task per run)."
    ),
    address: str | None = typer.Option(
        None, help=ADDRESS_HELP + " On a cluster --out must be on storage every node sees."
    ),
    out: Path = typer.Option(..., help="Output folder (runs/, tables, figures)."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar (stderr)."),
    tensorboard: Path | None = typer.Option(
        None,
        help="Also write each finished run's per-episode metrics as TensorBoard scalars into "
        "this folder (one subfolder per run).",
    ),
) -> None:
    """Run the variant x seed grid in parallel (resumable) and write tables and figures.

    Finished runs (summary.json present) are skipped; interrupted ones resume from their newest
    checkpoint.
    """
    names = parse_list(variants) or []
    if not names:
        raise EvodevoError("--variants names no variant; e.g. biarm,pnn")
    for v in names:
        get_variant(v)
    seed_list = parse_seeds(seeds)
    cfg = _load(config, tasks, episodes_scale, set_, protocol, sequence)
    set_single_thread()
    check_backend(backend, address, workers)

    exporter = None
    if tensorboard is not None:
        exporter = RunsExporter(out / "runs", tensorboard)
    on_item = exporter.on_item if exporter is not None else None
    with CommandProgress("training runs", quiet, on_item=on_item):
        done = run_grid(
            cfg, names, seed_list, out, workers=workers, backend=backend, address=address
        )
    if exporter is not None:  # and the runs finished by an earlier invocation
        exporter.export_finished()
    typer.echo(f"trained {len(done)} run(s); writing tables and figures")
    report = write_report(out)
    typer.echo(f"wrote {report}")


_SWEEP_SET_HELP = (
    "Override a config key in the base config of every run of the sweep, e.g. --set "
    "eval.episodes=5 (repeatable; a protocol's own overrides still win; tasks come from "
    "--tasks and the sweep file; episodes_scale replaces the sweep file's; unknown keys are an "
    "error). Finished runs in OUT are kept as they are: give a new OUT for other overrides."
)


@app.command()
def sweep(
    config: Path = typer.Option(
        Path("configs/biarm_sweep.yaml"), help="Sweep YAML: protocols, tasks, variants, seeds."
    ),
    protocols: str | None = typer.Option(None, help="Only these protocols (comma-separated)."),
    tasks: str | None = typer.Option(None, help="Only these tasks (comma-separated ids)."),
    variants: str | None = typer.Option(None, help="Only these variants (comma-separated)."),
    seeds: str | None = typer.Option(None, help="Only these seeds, e.g. 0-4."),
    set_: list[str] | None = typer.Option(None, "--set", help=_SWEEP_SET_HELP),
    workers: int = typer.Option(1, help="Parallel runs (worker processes)."),
    table_only: bool = typer.Option(False, help="Only rewrite the table from finished runs."),
    out: Path = typer.Option(..., help="Sweep folder (OUT/PROTOCOL/TASK/VARIANT__sSEED)."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar (stderr)."),
) -> None:
    """The DQN protocol sweep (SPEC 1.6): each task alone, per protocol.

    Finished runs are skipped, interrupted ones resume; the table (OUT/sweep.md) covers every
    finished run of the selection.
    """
    spec = SweepSpec.load(config).select(
        parse_list(protocols),
        parse_list(tasks),
        parse_list(variants),
        parse_seeds(seeds) if seeds else None,
    )
    spec = sweep_with_sets(spec, set_)
    if not table_only:
        set_single_thread()
        with CommandProgress("training runs", quiet):
            done = run_sweep(spec, out, workers=workers)
        typer.echo(f"trained {len(done)} run(s)")
    typer.echo(sweep_table(spec, out))


def sweep_with_sets(spec: SweepSpec, sets: list[str] | None) -> SweepSpec:
    """``spec`` with ``--set key=value`` in the base config of every protocol (SPEC 1.6).

    Each run's config is then the :class:`~evodevo.neuromod.config.BiarmConfig` defaults, the
    ``--set`` overrides, then its protocol's overrides (so the protocols still differ as the
    sweep file says); ``episodes_scale`` replaces the sweep file's. Unknown keys and bad values
    are one :class:`~evodevo.errors.ConfigError` naming the key, before any run.
    """
    base = parse_sets(sets)
    if not base:
        return spec
    if "tasks" in base:
        raise ConfigError(
            "--set tasks: a sweep trains each task alone; choose them with --tasks or in the "
            "sweep file"
        )
    checked = resolve(BiarmConfig, sets=sets)  # unknown keys and bad values fail here
    scale = checked.episodes_scale if "episodes_scale" in base else spec.episodes_scale
    base.pop("episodes_scale", None)
    merged = {name: merge(base, over) for name, over in spec.protocols.items()}
    for name, over in merged.items():
        try:
            protocol_config(BiarmConfig(), over)
        except ConfigError as exc:
            raise ConfigError(f"--set with protocol {name!r}: {exc}") from None
    return dataclasses.replace(spec, protocols=merged, episodes_scale=scale)


@app.command()
def video(
    run_dir: Path = typer.Argument(..., help="Run directory of `biarm train` (or OUT/runs/...)."),
    task: str = typer.Option(..., help="The column: task index (0, 1, ...) or Gymnasium id."),
    out: Path = typer.Option(..., help="GIF (or MP4, with imageio-ffmpeg) to write."),
    episode_seed: int | None = typer.Option(
        None, help="Reset seed of the filmed episode [eval.seed: the first evaluation episode]."
    ),
    fps: float | None = typer.Option(None, help="Frames per second [the env's render_fps]."),
    max_steps: int | None = typer.Option(None, help="Stop filming after this many steps."),
) -> None:
    """Film one task's column acting greedily in its environment (step, action, reward, return)."""
    check_seed("--episode-seed", episode_seed)
    seed = episode_seed
    if fps is not None and not fps > 0:
        raise EvodevoError(f"--fps {fps} must be > 0")
    if max_steps is not None and max_steps < 1:
        raise EvodevoError(f"--max-steps {max_steps} must be >= 1")
    kind = run_kind(run_dir)
    if kind is not None and kind != "biarm":
        raise EvodevoError(
            f"{str(run_dir)!r} is a {kind!r} run, not a BIARM run; film it with `evodevo grn "
            f"video {run_dir} --out {out}`"
        )
    policy = evodevo.load(run_dir, task=task)
    if seed is None:
        seed = int(read_json(run_dir / "config.json")["config"].get("eval", {}).get("seed", 0))
    env = policy.make_env(render_mode="rgb_array")
    try:
        rate = fps if fps is not None else float(env.metadata.get("render_fps") or 30)
        frames, res = film_episode(policy, env, seed, f"column {task}: {policy.env_id}", max_steps)
    finally:
        env.close()
    save_frames(frames, out, rate)
    typer.echo(f"{out} ({len(frames)} frames at {rate:g} fps; return {res['return']:.2f})")


@app.command()
def report(
    out: Path = typer.Argument(..., help="A folder written by `evodevo biarm compare`."),
    figures: bool = typer.Option(True, help="Also re-draw the figures."),
) -> None:
    """Re-draw tables and figures from the saved runs, without re-running anything."""
    typer.echo(f"wrote {write_report(out, figures=figures)}")
    progress = grid_progress(out)
    if progress and progress[0] < progress[1]:
        typer.echo(
            f"note: {progress[0]} of the grid's {progress[1]} runs have finished; the tables "
            "cover those only (resume the rest with the same `evodevo biarm compare` call)",
            err=True,
        )


@app.command("config")
def show_config() -> None:
    """Print every config key with its default and meaning."""
    for key, default, doc in describe(BiarmConfig):
        typer.echo(f"{key:32s} {default:28s} {doc}")


@app.command()
def contrast(
    runs: str = typer.Option(..., help="label=DIR pairs, e.g. fixed=out/f,learned=out/l."),
    variant: str = typer.Option("biarm", help="Which variant's runs to contrast."),
) -> None:
    """Print a Markdown table contrasting one variant under several settings (saved runs only)."""
    pairs = {}
    for item in parse_list(runs) or []:
        if "=" not in item:
            raise EvodevoError(f"--runs item {item!r} must look like label=DIR")
        label, folder = item.split("=", 1)
        pairs[label] = folder
    if not pairs:
        raise EvodevoError("--runs names no folder; e.g. fixed=out/f,learned=out/l")
    typer.echo(contrast_table(pairs, variant))
