"""``evodevo grn``: evolve, evaluate, ablate, plot and film the GRN controller (SPEC §2).

Every command limits torch/BLAS to one thread first (``set_single_thread``); user errors raise
:class:`~evodevo.errors.EvodevoError`, which the top-level CLI prints as one line.
"""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import typer

import evodevo
from evodevo.callbacks import Callback
from evodevo.cli.common import (
    ADDRESS_HELP,
    BACKEND_HELP,
    OLD_EPISODES_HELP,
    OLD_SEED_HELP,
    SET_HELP,
    TEST_EPISODES_HELP,
    TEST_SEED_HELP,
    TEST_SET_HELP,
    add_evaluate_command,
    check_backend,
    check_seed,
    format_rate,
    parse_list,
    renamed,
)
from evodevo.config import from_dict, load_config, merge, parse_sets, to_dict
from evodevo.errors import EvodevoError
from evodevo.grn.ablations import ablations_stem, run_ablations
from evodevo.grn.config import GrnConfig
from evodevo.grn.evaluation import evaluate_baselines
from evodevo.grn.evaluation import test_episodes as fixed_test_episodes
from evodevo.grn.evaluator import action_dims, is_vector_observation, make_env
from evodevo.grn.evolution import evolve_run
from evodevo.grn.figures import plot_ablations, plot_run
from evodevo.grn.frontends import frontend_dim
from evodevo.grn.neuromodulated import (
    MODULATOR_TRACE_FILE,
    record_modulator_trace,
    run_modulator_ablations,
)
from evodevo.grn.recording import TRACE_FILE, record_trace
from evodevo.grn.vision_preset import vision_preset
from evodevo.parallel import set_single_thread
from evodevo.progress import CommandProgress, GenerationBar
from evodevo.runs import RunDir, read_json, run_kind
from evodevo.tensorboard import GenerationScalars
from evodevo.video import film_episode, save_frames

__all__ = ["app"]

app = typer.Typer(
    help="GRN controller (thesis Chapter 4): evolve, evaluate, ablate, plot, video.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _overrides(
    population: int | None,
    generations: int | None,
    episodes: int | None,
    seed: int | None,
    controller: str | None,
    blind: bool,
    open_loop: bool,
    final_pick: int | None = None,
    keep: str | None = None,
    optimizer: str | None = None,
) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if optimizer is not None:
        out.setdefault("evolution", {})["optimizer"] = optimizer
    if keep is not None:
        out.setdefault("evolution", {})["keep"] = keep
    if final_pick is not None:
        out.setdefault("evolution", {})["final_pick_episodes"] = final_pick
    if population is not None:
        out.setdefault("evolution", {})["population"] = population
    if generations is not None:
        out.setdefault("evolution", {})["generations"] = generations
    if episodes is not None:
        out.setdefault("evaluation", {})["episodes"] = episodes
    if seed is not None:
        out["seed"] = seed
    if open_loop:
        if controller not in (None, "open_loop"):
            raise EvodevoError(f"--open-loop and --controller {controller} contradict each other")
        controller = "open_loop"
    if controller is not None:
        out["controller"] = controller
    if blind:
        out.setdefault("sensors", {})["blind"] = True
    return out


@contextlib.contextmanager
def _remove_if_failed(out: Path, fresh: bool) -> Iterator[None]:
    """Remove ``out`` again if this command created it and a user error (e.g. an environment
    that cannot be made) stops the run before its first checkpoint: no half-written run."""
    try:
        yield
    except EvodevoError:
        if fresh and out.is_dir() and not (out / "checkpoints" / "checkpoint.npz").exists():
            shutil.rmtree(out, ignore_errors=True)
        raise


def _env_overrides(env_id: str, cfg: GrnConfig) -> dict[str, Any]:
    """Config changes that drive ``env_id``, its sizes read from its spaces (``--env``).

    A flat Box observation is the sensor vector (``n_visual`` 0, ``n_proprio`` its size, its
    Box bounds mapped onto ``sensors.vector_range``; no camera, so no visual noise, no
    front-end calibration and no simulator shaping); an RGB image goes through the config's
    front-end as for the Kuka env. The actions' size and bounds are read by the evaluator.
    """
    same = env_id == cfg.env.id
    kwargs = dict(cfg.env.kwargs) if same else {}
    env = make_env(env_id, kwargs)
    try:
        action_dims(env.action_space)  # a one-line error for anything but flat Box actions
        space = env.observation_space
    finally:
        env.close()
    out: dict[str, Any] = {"env": {"id": env_id, "kwargs": kwargs}}
    if is_vector_observation(space):
        out["sensors"] = {
            "n_visual": 0,
            "n_proprio": int(space.shape[0]),  # type: ignore[index]
            "proprio": True,  # the observation is the sensor vector (the vision preset hides it)
            "encoder": "cnn",
            "feature_dim": frontend_dim("cnn"),
        }
        out["genome"] = {"p_init": "normal"}
        out["evaluation"] = {"noisy_fraction": 0.0, "distance_weight": 0.0}
    elif not (isinstance(space, gym.spaces.Box) and len(space.shape) == 3 and space.shape[-1] == 3):
        raise EvodevoError(
            f"--env {env_id}: its observation space {space} is neither a flat Box vector nor "
            "an RGB image (H, W, 3); the GRN reads one of those"
        )
    return out


_FINAL_PICK_HELP = (
    "Re-select the final genome among the last elites on this many fresh episodes "
    "each (evolution.final_pick_episodes; 0 = off) [the config's]."
)
_KEEP_HELP = (
    "Which genome the run returns: last (the last generation's best), record (the "
    "champion by lifetime success record) or validated (each generation's best scored on "
    "evaluation.validation_episodes validation episodes, the most successes kept); "
    "evolution.keep [the config's: record in the vision preset, last in the thesis preset]."
)
_OPTIMIZER_HELP = (
    "ga (Algorithm 3, the thesis) or cmaes (CMA-ES on the genome as a vector; section "
    "cmaes); evolution.optimizer [the config's: ga]."
)
_CONFIG_HELP = (
    "YAML config; keys it leaves out take the thesis defaults (configs/grn.yaml). "
    "Without it, --preset."
)
_PRESET_HELP = (
    "Without --config: vision (configs/grn_vision.yaml: blob front-end, substeps, shaped "
    "training fitness) or thesis (configs/grn.yaml, the thesis protocol)."
)
_ENV_HELP = (
    "Any Gymnasium env with a Box observation (a vector or an RGB image) and Box "
    "actions; sensor and action sizes come from its spaces [the config's env.id]."
)
_CONTROLLER_HELP = "Controller kind: plain, neuromodulated, open_loop, linear, mlp [plain]."
_RESUME_HELP = (
    "Continue an interrupted run in --out; with a larger --generations, extend a "
    "finished one (what a larger budget buys)."
)
_EVOLVE_TENSORBOARD_HELP = (
    "Also write history.csv's numbers as TensorBoard scalars into this folder."
)


#: What ``grn evolve`` runs without options (the vision preset): its help states these values,
#: read from the config, not written again here.
_DEFAULT = from_dict(GrnConfig, vision_preset())


@app.command()
def evolve(
    out: Path = typer.Option(..., "--out", help="Run directory (created)."),
    population: int | None = typer.Option(
        None, help=f"Genomes per generation [{_DEFAULT.evolution.population}]."
    ),
    generations: int | None = typer.Option(
        None, help=f"Maximum generations [{_DEFAULT.evolution.generations}]."
    ),
    episodes: int | None = typer.Option(
        None, help=f"Episodes per evaluation [{_DEFAULT.evaluation.episodes}]."
    ),
    final_pick: int | None = typer.Option(None, help=_FINAL_PICK_HELP),
    keep: str | None = typer.Option(None, help=_KEEP_HELP),
    optimizer: str | None = typer.Option(None, help=_OPTIMIZER_HELP),
    workers: int = typer.Option(1, help="Worker processes (each owns its environments)."),
    seed: int | None = typer.Option(None, help=f"Run seed [{_DEFAULT.seed}]."),
    config: Path | None = typer.Option(None, "--config", help=_CONFIG_HELP),
    set_: list[str] | None = typer.Option(None, "--set", help=SET_HELP),
    preset: str = typer.Option("vision", help=_PRESET_HELP),
    env_id: str | None = typer.Option(None, "--env", help=_ENV_HELP),
    controller: str | None = typer.Option(None, help=_CONTROLLER_HELP),
    blind: bool = typer.Option(False, "--blind", help="Blind-GRN control: visual features zeroed."),
    open_loop: bool = typer.Option(False, "--open-loop", help="Evolve a fixed action sequence."),
    resume: bool = typer.Option(False, "--resume", help=_RESUME_HELP),
    quiet: bool = typer.Option(False, "--quiet", help="No progress line per generation."),
    backend: str = typer.Option("local", help=BACKEND_HELP),
    address: str | None = typer.Option(None, help=ADDRESS_HELP),
    tensorboard: Path | None = typer.Option(None, help=_EVOLVE_TENSORBOARD_HELP),
) -> None:
    """Evolve a GRN (Algorithm 3) into OUT: best_genome.npz, encoder.pt, history.csv, summary.json."""
    set_single_thread()
    check_seed("--seed", seed)
    check_backend(backend, address, workers)
    flags = _overrides(
        population,
        generations,
        episodes,
        seed,
        controller,
        blind,
        open_loop,
        final_pick,
        keep,
        optimizer,
    )
    ov = merge(flags, parse_sets(set_))
    cfg = _evolve_config(out, config, preset, resume, env_id, ov)
    summary = _run_evolution(cfg, out, workers, resume, quiet, backend, address, tensorboard)
    _echo_evolution(summary, out)


def _evolve_config(
    out: Path,
    config: Path | None,
    preset: str,
    resume: bool,
    env_id: str | None,
    ov: dict[str, Any],
) -> GrnConfig:
    """The config ``grn evolve`` runs with (SPEC §2.4): the saved one on ``--resume`` (unless
    ``--config``), else ``--config`` or the ``--preset``; then ``ov`` (the command's flags and
    ``--set``) and the ``--env`` sizes."""
    if resume and not (out / "config.json").is_file():
        where = "does not exist" if not out.exists() else "holds no run (no config.json)"
        raise EvodevoError(
            f"--resume: {str(out)!r} {where}; check --out, or start a new run without --resume"
        )
    if resume and config is None:
        saved = read_json(out / "config.json").get("config", {})
        cfg = load_config(GrnConfig, None, merge(saved, ov))
    elif config is None:  # the default preset sees; --preset thesis: the thesis
        if preset not in ("vision", "thesis"):
            raise EvodevoError(f"--preset {preset!r} is not a preset; choose vision or thesis")
        base = vision_preset() if preset == "vision" else {}
        cfg = load_config(GrnConfig, None, merge(base, ov))
    else:
        cfg = load_config(GrnConfig, config, ov)
    if env_id is not None:
        env_ov = _env_overrides(env_id, cfg)
        merged = merge(to_dict(cfg), env_ov)
        merged["env"] = env_ov["env"]  # the new env's kwargs replace the old env's
        cfg = load_config(GrnConfig, None, merged)
    if cfg.controller == "open_loop" and cfg.sensors.blind:
        raise EvodevoError(
            "--blind and the open-loop controller contradict each other: an open-loop policy "
            "reads no sensors; drop --blind (or sensors.blind) or choose another controller"
        )
    return cfg


def _run_evolution(
    cfg: GrnConfig,
    out: Path,
    workers: int,
    resume: bool,
    quiet: bool,
    backend: str,
    address: str | None,
    tensorboard: Path | None,
) -> dict[str, Any]:
    """``evolve_run`` with the per-generation bar and the TensorBoard sink; a fresh run that
    fails before its first checkpoint leaves no folder behind."""
    fresh = not out.exists()
    callbacks: list[Callback] = []
    if tensorboard is not None:
        callbacks.append(GenerationScalars(tensorboard))
    with CommandProgress("evaluate population", quiet) as bars, _remove_if_failed(out, fresh):
        callbacks.insert(0, GenerationBar(bars, cfg.evolution.generations))
        return evolve_run(
            cfg,
            out,
            workers=workers,
            resume=resume,
            callbacks=callbacks,
            progress=False,  # the bars print the per-generation line
            backend=backend,
            address=address,
        )


def _echo_evolution(summary: dict[str, Any], out: Path) -> None:
    """The lines ``grn evolve`` prints at the end: budget spent, final pick, kept champion."""
    typer.echo(
        f"{summary['generations_run']} generations, {summary['episodes_run']} episodes, "
        f"{summary['wall_s']:.0f} s; best training success {summary['best_training_success']:.2f}"
        f"{' (early stop)' if summary['stopped_early'] else ''}; run in {out}"
    )
    pick = summary.get("final_pick")
    if pick is not None:
        typer.echo(
            f"final pick: the {len(pick['successes'])} elites won {pick['successes']} of "
            f"{pick['episodes']} fresh episodes; kept the one ranked {pick['picked_rank']}"
        )
    champ = summary.get("champion")
    if summary.get("kept") == "record" and champ is not None:
        typer.echo(
            f"kept the champion by record: {champ['successes']} of {champ['episodes']} training "
            f"episodes (95 % lower bound {champ['lower_bound']:.2f})"
        )


add_evaluate_command(
    app,
    help="Test the best genome on fixed seeds, beside the trivial policies (SPEC §2.5).",
    run_help="Run directory of `evodevo grn evolve`.",
    noise_help="Visual-feature noise std (0.03 = robustness test).",
    label="genome",
)


@app.command()
def baselines(
    out: Path = typer.Option(..., "--out", help="JSON file to write (+ _episodes.csv beside it)."),
    config: Path | None = typer.Option(None, "--config", help="YAML config (env, test seed)."),
    test_episodes: int | None = typer.Option(None, help=TEST_EPISODES_HELP),
    objects: str = typer.Option("test", help="test or train objects."),
    test_seed: int | None = typer.Option(None, help=TEST_SEED_HELP),
    workers: int = typer.Option(1, help="Worker processes."),
    old_episodes: int | None = typer.Option(
        None, "--episodes", hidden=True, help=OLD_EPISODES_HELP
    ),
    old_seed: int | None = typer.Option(None, "--seed", hidden=True, help=OLD_SEED_HELP),
    policies: str | None = typer.Option(
        None,
        help="Comma-separated reference policies [zero,random,turn,scripted; scripted_memory "
        "when env.kwargs.dark_after is set]; policies already in --out for the same episodes "
        "are kept, missing ones are run.",
    ),
    set_: list[str] | None = typer.Option(None, "--set", help=SET_HELP),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar (stderr)."),
) -> None:
    """Reference policies (all-zero, uniform random, constant turn, scripted image-only pipeline)
    on the fixed test episodes.

    The file is what `grn evaluate --baselines-from` and `evodevo reproduce` reuse (SPEC §2.5).
    """
    episodes = renamed("--episodes", "--test-episodes", old_episodes, test_episodes)
    seed = renamed("--seed", "--test-seed", old_seed, test_seed)
    set_single_thread()
    check_seed("--test-seed", seed)
    names = parse_list(policies, "--policies")
    with CommandProgress("reference policies", quiet):
        res = evaluate_baselines(
            load_config(GrnConfig, config, parse_sets(set_)),
            out,
            episodes,
            objects,
            seed,
            workers,
            policies=names,
        )
    for name, b in res["baselines"].items():
        typer.echo(format_rate(name, b))


@app.command()
def ablate(
    run_dir: Path = typer.Argument(..., help="Run directory of `evodevo grn evolve`."),
    test_episodes: int | None = typer.Option(
        None, help="Test episodes per ablation [evaluation.test_episodes of the run's config]."
    ),
    objects: str = typer.Option("test", help="test or train objects."),
    test_seed: int | None = typer.Option(None, help=TEST_SEED_HELP),
    workers: int = typer.Option(1, help="Worker processes."),
    old_episodes: int | None = typer.Option(
        None, "--episodes", hidden=True, help=OLD_EPISODES_HELP
    ),
    old_seed: int | None = typer.Option(None, "--seed", hidden=True, help=OLD_SEED_HELP),
    modulators: bool = typer.Option(
        False, "--modulators", help="Neuromodulated GRN: set each gamma to 0 instead (SPEC §5)."
    ),
    set_: list[str] | None = typer.Option(None, "--set", help=TEST_SET_HELP),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar (stderr)."),
) -> None:
    """The nine ablations of SPEC §2.5 on the best genome: ablations.md/.csv and a figure."""
    episodes = renamed("--episodes", "--test-episodes", old_episodes, test_episodes)
    seed = renamed("--seed", "--test-seed", old_seed, test_seed)
    set_single_thread()
    check_seed("--test-seed", seed)
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    overrides = parse_sets(set_)
    if modulators:
        with CommandProgress("modulator ablations", quiet):
            run_modulator_ablations(run_dir, episodes, objects, seed, workers, overrides)
        stem = ablations_stem(overrides, "modulator_ablations")
        typer.echo((run_dir / f"{stem}.md").read_text().rstrip())
        return
    with CommandProgress("ablations", quiet):
        run_ablations(run_dir, episodes, objects, seed, workers, overrides)
    run = RunDir(run_dir, create=False)
    (run.path / "figures").mkdir(exist_ok=True)
    stem = ablations_stem(overrides)
    plot_ablations(run, run.path / "figures", stem)
    typer.echo((run.path / f"{stem}.md").read_text().rstrip())


@app.command()
def plot(
    run_dir: Path = typer.Argument(..., help="Run directory of `evodevo grn evolve`."),
    objects: str = typer.Option("test", help="Objects of the traced episode: test or train."),
) -> None:
    """Draw all figures of the run into RUN_DIR/figures (records trace.npz first if missing;
    for a neuromodulated run also modulator_trace.npz)."""
    set_single_thread()
    if not run_dir.is_dir():
        raise EvodevoError(f"run directory {str(run_dir)!r} does not exist")
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    if not (run_dir / TRACE_FILE).is_file() and (run_dir / "best_genome.npz").is_file():
        record_trace(run_dir, objects=objects)
    saved = read_json(run_dir / "config.json") if (run_dir / "config.json").is_file() else {}
    neuromodulated = saved.get("config", {}).get("controller") == "neuromodulated"
    if neuromodulated and not (run_dir / MODULATOR_TRACE_FILE).is_file():
        record_modulator_trace(run_dir, objects=objects)
    for p in plot_run(run_dir):
        typer.echo(str(p))


@app.command()
def video(
    run_dir: Path = typer.Argument(..., help="Run directory of `grn evolve` or `baselines kuka`."),
    out: Path = typer.Option(..., "--out", help="GIF (or MP4, with imageio-ffmpeg) to write."),
    episode: int = typer.Option(0, help="Index of the test episode (its fixed test seed)."),
    objects: str = typer.Option("test", help="test or train objects."),
    fps: float = typer.Option(2.0, help="Frames (environment steps) per second."),
    max_steps: int | None = typer.Option(None, help="Stop filming after this many steps."),
    set_: list[str] | None = typer.Option(None, "--set", help=TEST_SET_HELP),
) -> None:
    """Film the best genome on one test episode: step, action, reward and success on each frame.

    The episode is the one `grn evaluate` runs with the same index and objects.
    """
    set_single_thread()
    if episode < 0:
        raise EvodevoError(f"--episode {episode} must be >= 0")
    if objects not in ("test", "train"):
        raise EvodevoError(f"--objects {objects!r} is not accepted; choose test or train")
    if not fps > 0:
        raise EvodevoError(f"--fps {fps} must be > 0")
    if max_steps is not None and max_steps < 1:
        raise EvodevoError(f"--max-steps {max_steps} must be >= 1")
    if run_kind(run_dir) == "biarm":
        raise EvodevoError(
            f"{str(run_dir)!r} is a BIARM run; film one of its columns with `evodevo biarm "
            f"video {run_dir} --task N --out {out}`"
        )
    policy = evodevo.load(run_dir, overrides=parse_sets(set_))
    cfg = policy.config  # type: ignore[attr-defined]
    ep = fixed_test_episodes(cfg.evaluation.test_seed, episode + 1, objects == "test")[episode]
    env = policy.make_env(test_objects=ep.test_objects, render_mode="rgb_array")  # type: ignore[call-arg]
    try:
        title = f"{policy.kind} test episode {episode} ({objects} objects)"  # type: ignore[attr-defined]
        frames, res = film_episode(policy, env, ep.seed, title, max_steps)
    finally:
        env.close()
    save_frames(frames, out, fps)
    outcome = {True: "success", False: "failure", None: f"return {res['return']:.2f}"}[
        res["success"]
    ]
    typer.echo(f"{out} ({len(frames)} frames at {fps:g} fps; {outcome})")
