"""Train a Kuka baseline into a run directory, and load one back for the evaluate code path.

:func:`run_baseline` dispatches on ``config.method``: PPO/TD3 (:mod:`evodevo.baselines.sb3_kuka`),
NEAT (:mod:`evodevo.baselines.neat_kuka`), or the trivial all-zero and uniform-random policies,
which need no training (their run directory only records what to evaluate). Every run directory
holds ``config.json`` (kind ``"baseline"``) and ``summary.json``, like a GRN run's.

:func:`load_run` is what :func:`evodevo.grn.evaluation.load_run` calls for kind ``"baseline"``:
it returns the evaluator config (the run's ``env`` and ``evaluation`` sections, so the same test
seeds as a GRN run), the encoder (NEAT) and the "genome" (an SB3 model or NEAT network reference),
so ``evodevo grn evaluate`` and ``evodevo baselines evaluate`` test a baseline exactly as a GRN.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from evodevo.baselines.kuka_config import KukaBaselineConfig
from evodevo.baselines.policies import NeatNet, Sb3Model, load_sb3
from evodevo.callbacks import Callback, CallbackList
from evodevo.config import from_dict, to_dict
from evodevo.errors import ConfigError, EvodevoError
from evodevo.grn.evaluation import LoadedRun
from evodevo.grn.frontends import load_frontend
from evodevo.runs import RunDir, machine_info

__all__ = ["RUN_KIND", "run_baseline", "load_run", "read_baseline_config"]

RUN_KIND = "baseline"
"""``kind`` in a baseline run's ``config.json``."""


def read_baseline_config(run: RunDir) -> KukaBaselineConfig:
    """The :class:`KukaBaselineConfig` saved in ``run``; a clear error for another kind of run."""
    saved = run.read_config()
    if saved.get("kind") != RUN_KIND:
        raise EvodevoError(
            f"{str(run.path)!r} holds a {saved.get('kind')!r} run, not a Kuka baseline run "
            "(evodevo baselines kuka)"
        )
    try:
        return from_dict(KukaBaselineConfig, saved["config"])
    except ConfigError as exc:
        raise EvodevoError(
            f"{str(run / 'config.json')!r} is not a Kuka baseline config: {exc}"
        ) from None


def _check_budget(cfg: KukaBaselineConfig) -> None:
    b = cfg.budget
    for name, value in (("--budget-steps", b.env_steps), ("--budget-minutes", b.minutes)):
        if value is not None and value <= 0:
            raise EvodevoError(f"{name} {value} must be > 0")


def run_baseline(
    cfg: KukaBaselineConfig,
    out: str | Path,
    workers: int = 1,
    resume: bool = False,
    quiet: bool = False,
    backend: str = "local",
    address: str | None = None,
    callbacks: Sequence[Callback] = (),
) -> dict[str, Any]:
    """Train (or, for zero/random, just record) the baseline ``cfg.method`` into ``out``.

    Args:
        cfg: the resolved config.
        out: run directory (created).
        workers: evaluator worker processes or Ray actors (NEAT; SB3 trains on one env in
            this process).
        resume: continue the run in ``out`` from its last checkpoint (same config).
        quiet: no progress lines.
        backend: "local" or "ray": where NEAT's evaluator runs (the same numbers either way).
        address: Ray cluster ("auto" or HOST:PORT); None starts a private local Ray.
        callbacks: :class:`~evodevo.callbacks.Callback` s (progress, TensorBoard).

    Returns:
        The run's ``summary.json`` content.
    """
    _check_budget(cfg)
    run = RunDir(out)
    cfg_dict = to_dict(cfg)
    if resume:
        if not (run / "config.json").is_file():
            raise EvodevoError(f"--resume: {str(run.path)!r} holds no run; start without --resume")
        saved = to_dict(read_baseline_config(run))
        run.check_same_config(cfg_dict, list(cfg_dict), saved)
    else:
        if (run / "config.json").is_file():
            raise EvodevoError(
                f"{str(run.path)!r} already holds a run; pass --resume to continue it or choose "
                "another --out"
            )
        run.write_config(cfg_dict, kind=RUN_KIND)
    if cfg.method in ("ppo", "td3", "recurrent_ppo"):  # RecurrentPPO: sb3-contrib
        from evodevo.baselines.sb3_kuka import train_sb3  # optional dependency: stable_baselines3

        return train_sb3(cfg, run, resume=resume, quiet=quiet, callback=CallbackList(callbacks))
    if cfg.method == "neat":
        from evodevo.baselines.neat_kuka import train_neat  # optional dependency: neat

        return train_neat(
            cfg,
            run,
            workers=workers,
            resume=resume,
            quiet=quiet,
            backend=backend,
            address=address,
            callback=CallbackList(callbacks),
        )
    summary: dict[str, Any] = {
        "kind": "baseline_kuka",
        "method": cfg.method,
        "seed": cfg.seed,
        "env_steps": 0,
        "wall_s": 0.0,
        "eval_wall_s": 0.0,
        "stopped_by": "untrained",
        "target_success": cfg.budget.target_success,
        "time_to_target_s": None,
        "steps_to_target": None,
        "success_history": [],
        "best_training_success": None,
        "budget": {"env_steps": 0, "minutes": 0.0},
        "machine": machine_info(),
    }
    run.write_summary(summary)
    return summary


def load_run(run: RunDir, saved: dict[str, Any]) -> Any:
    """A baseline run as :class:`evodevo.grn.evaluation.LoadedRun` (policy in place of a genome)."""
    cfg = read_baseline_config(run)
    genome: Any = None
    encoder = None
    if cfg.method in ("ppo", "td3", "recurrent_ppo"):
        from evodevo.baselines.sb3_kuka import MODEL_FILE  # optional dependency: stable_baselines3

        ref = Sb3Model(cfg.method, str((run / MODEL_FILE).resolve()))
        load_sb3(ref.algo, ref.path)  # fail here, with the path, not inside a worker
        genome = ref
    elif cfg.method == "neat":
        from evodevo.baselines.neat_kuka import GENOME_FILE, NEAT_INI  # optional dependency: neat

        genome = NeatNet.load(run / GENOME_FILE, (run / NEAT_INI).resolve())
        encoder = load_frontend(cfg.evaluator_config(), run.path)
    # SB3 and trivial policies use no encoder (LoadedRun's Evaluator accepts None)
    return LoadedRun(run, cfg.evaluator_config(), encoder, genome, cfg.method)  # type: ignore[arg-type]
