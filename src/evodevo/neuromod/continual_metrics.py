"""Continual-learning metrics of one BIARM run, from its saved files only (SPEC §6).

Everything is read from a finished run folder: ``metrics.csv`` (one row per training episode:
task index and return) and ``summary.json`` (per task the greedy return on the evaluation seeds
right after the task, ``initial_return`` = ``R_{i,i}``, and after the whole sequence,
``final_return`` = ``R_{T,i}``). Per task ``i`` of a sequence of ``T``:

* **AUC_i** — area under the training curve, taken as the *mean training-episode return* over
  task i's episodes (the curve's area divided by its length, so tasks of different lengths
  compare); **normalised AUC_i** is the mean of the per-episode returns normalised to [0, 1],
  ``clip((R - R_random) / (R_solved - R_random), 0, 1)`` with the anchors of
  :mod:`evodevo.evidence.normalise` (random policy 0, solved threshold 1). The anchors hold
  for the environment's own step limit: a task trained with another ``max_steps`` (or an
  environment without a solved threshold) has no normalised metrics (``None``).
* **Forward transfer** (Continual World, Wołczyk et al. 2021):
  ``FT_i = (AUC_i - AUC_i^ref) / (1 - AUC_i^ref)`` on normalised AUCs, where ``AUC_i^ref`` is
  that of the single-task reference (variant ``single``: the same code with every lateral input
  scaled by 0) trained with the same seed. Without a reference run of that seed, the mean over
  the reference's seeds is used, and :attr:`TaskMetrics.reference` says so. 0 means no
  transfer, 1 means the task was solved from its first episode, negative values are
  interference. Undefined (``None``) when the reference's AUC is 1.
* **Forgetting_i** = ``R_{i,i} - R_{T,i}`` in return units on the evaluation seeds (0: kept,
  positive: worse at the end); ``None`` for the last task, which nothing follows. (Eq. 1.4 of
  :mod:`evodevo.neuromod.forgetting` takes the max over the intermediate returns instead.)
* **Backward transfer** (GEM, Lopez-Paz & Ranzato 2017), one number per run:
  ``BWT = mean_{i<T} (R_{T,i} - R_{i,i})`` on normalised returns, so that every task weighs
  the same; negative is forgetting. The clipping at 1 hides a drop that stays above the
  solved threshold (forgetting in return units shows it).
* **Episodes to threshold**: the number of training episodes of task i after which the rolling
  mean of the training return over the last :data:`WINDOW` (20) episodes first reaches the
  task's threshold (by default its solved threshold,
  :func:`evodevo.evidence.normalise.solved_return`), counted from the task's start; only full
  windows count, so the earliest possible value is 20; ``None`` if never reached.

>>> episodes_to_threshold([0, 0, 5, 9, 9, 9], threshold=8.0, window=2)
5
>>> forward_transfer(0.625, 0.25)
0.5
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from evodevo.envs.env_ids import parse_env_id
from evodevo.errors import EvodevoError
from evodevo.evidence.normalise import TaskScale, solved_return, task_scale
from evodevo.runs import RunDir

__all__ = [
    "REFERENCE_VARIANT",
    "WINDOW",
    "TaskMetrics",
    "RunMetrics",
    "training_returns",
    "unit_returns",
    "area_under_curve",
    "forward_transfer",
    "episodes_to_threshold",
    "backward_transfer",
    "scale_of",
    "run_metrics",
    "grid_metrics",
]

#: The variant whose runs are the single-task reference of forward transfer (SPEC §6).
REFERENCE_VARIANT = "single"
#: Episodes in the rolling mean of the training return that must reach a task's threshold.
WINDOW = 20


@dataclass(frozen=True)
class TaskMetrics:
    """One task's continual-learning metrics in one run (definitions in the module doc).

    Attributes:
        index: Position of the task in the sequence (0-based).
        env_id: Gymnasium id.
        episodes: Training episodes of the task.
        auc: Mean training-episode return (return units).
        auc_normalised: Mean of the per-episode returns normalised to [0, 1]; ``None`` for a
            task without normalisation anchors.
        initial_return: ``R_{i,i}``, mean greedy return right after the task.
        final_return: ``R_{T,i}``, mean greedy return after the whole sequence.
        forgetting: ``R_{i,i} - R_{T,i}``; ``None`` for the last task.
        threshold: Return the rolling training mean must reach (``None``: no threshold).
        episodes_to_threshold: Episodes until it did; ``None`` if it never did.
        forward_transfer: ``FT_i`` against the single-task reference; ``None`` without one,
            without normalisation anchors, or when the reference's AUC is 1.
        reference: Which reference runs ``FT_i`` used, e.g. ``"single seed 3"`` or
            ``"mean of single seeds 0-4 (seed 7 missing)"``; ``None`` without one.
    """

    index: int
    env_id: str
    episodes: int
    auc: float
    auc_normalised: float | None
    initial_return: float
    final_return: float
    forgetting: float | None
    threshold: float | None
    episodes_to_threshold: int | None
    forward_transfer: float | None = None
    reference: str | None = None


@dataclass(frozen=True)
class RunMetrics:
    """The continual-learning metrics of one run.

    Attributes:
        variant: Variant name of the run.
        seed: Run seed.
        run_dir: The run folder the numbers were read from.
        eval_seeds: Evaluation seeds of ``R_{i,i}`` and ``R_{T,i}``.
        tasks: One :class:`TaskMetrics` per task, in sequence order.
        backward_transfer: GEM's BWT on normalised returns; ``None`` with one task or when a
            task before the last has no normalisation anchors.
    """

    variant: str
    seed: int
    run_dir: str
    eval_seeds: tuple[int, ...]
    tasks: tuple[TaskMetrics, ...] = field(default_factory=tuple)
    backward_transfer: float | None = None

    @property
    def mean_forward_transfer(self) -> float | None:
        """Mean of ``FT_i`` over the tasks (Continual World's FT), ``None`` if one is missing."""
        fts = [t.forward_transfer for t in self.tasks]
        if not fts or any(f is None for f in fts):
            return None
        return float(np.mean([f for f in fts if f is not None]))


# ---------------------------------------------------------------------------- equations
def unit_returns(returns: Sequence[float] | np.ndarray, scale: TaskScale) -> np.ndarray:
    """Returns normalised by ``scale`` (:mod:`evodevo.evidence.normalise`), clipped to [0, 1].

    >>> unit_returns([0.0, 5.0, 20.0], TaskScale("t", 0.0, 10.0)).tolist()
    [0.0, 0.5, 1.0]
    """
    return np.clip(scale.normalise(returns), 0.0, 1.0)


def area_under_curve(returns: Sequence[float] | np.ndarray) -> float:
    """Area under a training curve per episode: the mean of its episode returns.

    >>> area_under_curve([1.0, 2.0, 6.0])
    3.0
    """
    r = np.asarray(returns, dtype=float)
    if r.size == 0:
        raise EvodevoError("a training curve without episodes has no area; the task logged none")
    return float(r.mean())


def forward_transfer(auc: float, auc_reference: float) -> float | None:
    """Continual World's ``(AUC - AUC^ref) / (1 - AUC^ref)`` on normalised AUCs.

    ``None`` when ``AUC^ref`` is 1 (the reference solved every episode: nothing to transfer).

    >>> forward_transfer(0.25, 0.25)
    0.0
    >>> forward_transfer(0.25, 0.5)
    -0.5
    """
    if auc_reference >= 1.0:
        return None
    return float((auc - auc_reference) / (1.0 - auc_reference))


def episodes_to_threshold(
    returns: Sequence[float] | np.ndarray, threshold: float, window: int = WINDOW
) -> int | None:
    """Episodes (from the task's start) until the mean of the last ``window`` returns first
    reaches ``threshold``; only full windows count; ``None`` if it never does.

    >>> episodes_to_threshold([1.0, 3.0, 3.0], threshold=3.0, window=2)
    3
    >>> episodes_to_threshold([1.0, 3.0], threshold=5.0, window=2) is None
    True
    """
    if window < 1:
        raise EvodevoError(f"window={window} must be at least 1 episode")
    r = np.asarray(returns, dtype=float)
    if r.size < window:
        return None
    rolling = np.convolve(r, np.ones(window) / window, mode="valid")
    hits = np.flatnonzero(rolling >= threshold)
    return int(hits[0]) + window if hits.size else None


def backward_transfer(
    initial: Sequence[float] | np.ndarray, final: Sequence[float] | np.ndarray
) -> float | None:
    """GEM's ``mean_{i<T} (R_{T,i} - R_{i,i})`` from per-task returns after each task
    (``initial``) and after the sequence (``final``); ``None`` with a single task.

    >>> backward_transfer([1.0, 0.5, 0.9], [0.5, 0.5, 0.9])
    -0.25
    """
    a = np.asarray(initial, dtype=float)
    b = np.asarray(final, dtype=float)
    if a.shape != b.shape:
        raise EvodevoError(f"{a.size} initial returns but {b.size} final ones; give one per task")
    if a.size < 2:
        return None
    return float(np.mean(b[:-1] - a[:-1]))


# ---------------------------------------------------------------------------- run files
def training_returns(run_dir: str | Path) -> dict[int, np.ndarray]:
    """Task index -> training-episode returns in episode order, from ``metrics.csv``."""
    rows = RunDir(run_dir, create=False).read_csv("metrics.csv")
    if rows and not {"task", "return"} <= set(rows[0]):
        raise EvodevoError(
            f"{str(Path(run_dir) / 'metrics.csv')!r} has columns {sorted(rows[0])}, not the "
            "task and return of a BIARM run; pass `evodevo biarm train` run folders"
        )
    out: dict[int, list[float]] = {}
    for row in rows:
        out.setdefault(int(row["task"]), []).append(float(row["return"]))
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def scale_of(env_id: str, max_steps: int | None = None) -> TaskScale | None:
    """The normalisation anchors of ``env_id`` (:func:`evodevo.evidence.normalise.task_scale`).

    ``None`` for an environment without a solved threshold in its Gymnasium spec, and for a
    task trained with a step limit ``max_steps`` other than the environment's own: the random
    return and the solved threshold hold for that limit only.
    """
    try:
        solved = solved_return(env_id)
    except EvodevoError:
        return None
    own = gym.spec(parse_env_id(env_id)[0]).max_episode_steps
    if max_steps is not None and own is not None and int(max_steps) != int(own):
        return None
    return task_scale(env_id, solved=solved)


def _scale_key(task: Mapping[str, Any]) -> tuple[str, int | None]:
    steps = task.get("max_steps")
    return str(task["env_id"]), None if steps is None else int(steps)


def _threshold(
    env_id: str, thresholds: Mapping[str, float | None] | None, scale: TaskScale | None
) -> float | None:
    if thresholds is not None and env_id in thresholds:
        value = thresholds[env_id]
        return None if value is None else float(value)
    return None if scale is None else scale.solved_return


def run_metrics(
    run_dir: str | Path,
    reference_aucs: Mapping[int, float | None] | None = None,
    reference: Mapping[int, str] | None = None,
    thresholds: Mapping[str, float | None] | None = None,
    window: int = WINDOW,
    scales: Mapping[tuple[str, int | None], TaskScale | None] | None = None,
) -> RunMetrics:
    """The metrics of one finished run folder.

    Args:
        run_dir: A finished ``biarm train`` run (``summary.json`` and ``metrics.csv``).
        reference_aucs: Per task index the reference's normalised AUC; without it (or for a
            task it lacks) ``forward_transfer`` is ``None``.
        reference: Per task index the description of that reference (``TaskMetrics.reference``).
        thresholds: Return thresholds per environment id overriding the solved thresholds
            (``None`` for an id: no threshold).
        window: Episodes of the rolling mean behind ``episodes_to_threshold``.
        scales: Normalisation anchors per (environment id, step limit); missing ones are
            looked up with :func:`scale_of`.
    """
    folder = Path(run_dir)
    summary = RunDir(folder, create=False).read_summary()
    curves = training_returns(folder)
    tasks = summary["tasks"]
    last = len(tasks) - 1
    out: list[TaskMetrics] = []
    unit_initial: list[float] = []
    unit_final: list[float] = []
    for i, t in enumerate(tasks):
        env = str(t["env_id"])
        curve = curves.get(i)
        if curve is None or curve.size == 0:
            raise EvodevoError(
                f"{str(folder / 'metrics.csv')!r} holds no training episode of task {i} ({env}); "
                "the run did not finish it — resume it with the same command"
            )
        key = _scale_key(t)
        scale = scales[key] if scales is not None and key in scales else scale_of(*key)
        auc_n = None if scale is None else float(unit_returns(curve, scale).mean())
        thr = _threshold(env, thresholds, scale)
        ini, fin = float(t["initial_return"]), float(t["final_return"])
        if scale is not None:
            unit_initial.append(float(unit_returns([ini], scale)[0]))
            unit_final.append(float(unit_returns([fin], scale)[0]))
        ref_auc = None if reference_aucs is None else reference_aucs.get(i)
        ft = None if ref_auc is None or auc_n is None else forward_transfer(auc_n, ref_auc)
        label = None if ref_auc is None or reference is None else reference.get(i)
        out.append(
            TaskMetrics(
                index=i,
                env_id=env,
                episodes=int(curve.size),
                auc=area_under_curve(curve),
                auc_normalised=auc_n,
                initial_return=ini,
                final_return=fin,
                forgetting=None if i == last else ini - fin,
                threshold=thr,
                episodes_to_threshold=None
                if thr is None
                else episodes_to_threshold(curve, thr, window),
                forward_transfer=ft,
                reference=label,
            )
        )
    complete = len(unit_initial) == len(tasks)
    return RunMetrics(
        variant=str(summary["variant"]),
        seed=int(summary["seed"]),
        run_dir=str(folder),
        eval_seeds=tuple(int(s) for s in summary.get("eval_seeds", [])),
        tasks=tuple(out),
        backward_transfer=backward_transfer(unit_initial, unit_final) if complete else None,
    )


def _seeds_text(seeds: Sequence[int]) -> str:
    ordered = sorted(seeds)
    if len(ordered) > 1 and ordered == list(range(ordered[0], ordered[-1] + 1)):
        return f"{ordered[0]}-{ordered[-1]}"
    return ", ".join(map(str, ordered))


def grid_metrics(
    grid: Mapping[str, Mapping[int, str | Path]],
    reference_variant: str = REFERENCE_VARIANT,
    thresholds: Mapping[str, float | None] | None = None,
    window: int = WINDOW,
) -> dict[str, dict[int, RunMetrics]]:
    """:func:`run_metrics` of every run of a grid ``{variant: {seed: run_dir}}``.

    Forward transfer pairs each run with the ``reference_variant`` run of its seed; a seed the
    reference lacks gets the mean of the reference's normalised AUCs over its seeds (stated in
    ``TaskMetrics.reference``). Without any reference run every ``forward_transfer`` is None.

    Raises:
        EvodevoError: a reference run's tasks (ids or episodes) differ from the run's.
    """
    scales: dict[tuple[str, int | None], TaskScale | None] = {}
    for runs in grid.values():
        for d in runs.values():
            for t in RunDir(d, create=False).read_summary()["tasks"]:
                key = _scale_key(t)
                if key not in scales:
                    scales[key] = scale_of(*key)
    refs = {
        s: run_metrics(d, thresholds=thresholds, window=window, scales=scales)
        for s, d in sorted(grid.get(reference_variant, {}).items())
    }
    ref_seeds = sorted(refs)
    out: dict[str, dict[int, RunMetrics]] = {}
    for variant, runs in grid.items():
        for seed, d in sorted(runs.items()):
            aucs: dict[int, float | None] = {}
            labels: dict[int, str] = {}
            if refs:
                tasks = RunDir(d, create=False).read_summary()["tasks"]
                for i, t in enumerate(tasks):
                    _check_reference(d, t, i, refs)
                    if seed in refs:
                        aucs[i] = refs[seed].tasks[i].auc_normalised
                        labels[i] = f"{reference_variant} seed {seed}"
                    else:
                        vals = [r.tasks[i].auc_normalised for r in refs.values()]
                        aucs[i] = None if any(v is None for v in vals) else _mean(vals)
                        labels[i] = (
                            f"mean of {reference_variant} seeds {_seeds_text(ref_seeds)} "
                            f"(seed {seed} missing)"
                        )
            out.setdefault(variant, {})[int(seed)] = run_metrics(
                d, aucs, labels, thresholds=thresholds, window=window, scales=scales
            )
    return out


def _mean(values: Sequence[float | None]) -> float:
    return float(np.mean([v for v in values if v is not None]))


def _check_reference(
    run_dir: str | Path, task: Mapping[str, Any], i: int, refs: Mapping[int, RunMetrics]
) -> None:
    for r in refs.values():
        if i >= len(r.tasks):
            raise EvodevoError(
                f"{str(run_dir)!r} has task {i} ({task['env_id']}) but the reference run "
                f"{r.run_dir!r} has only {len(r.tasks)} tasks; train the reference on the same "
                "task sequence"
            )
        ref = r.tasks[i]
        if ref.env_id != task["env_id"] or ref.episodes != int(task["episodes"]):
            raise EvodevoError(
                f"task {i} of {str(run_dir)!r} is {task['env_id']} with {task['episodes']} "
                f"episodes, but in the reference run {r.run_dir!r} it is {ref.env_id} with "
                f"{ref.episodes}; train the reference with the same tasks and episodes"
            )
