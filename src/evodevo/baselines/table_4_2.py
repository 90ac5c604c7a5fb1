"""Thesis Table 4.2 from run directories: GRN and baselines side by side (SPEC §4, §6).

Each run directory (``grn evolve`` or ``baselines kuka``) must have been tested
(``grn evaluate`` / ``baselines evaluate``: ``eval_<objects>_0.json``). Per method (runs of
several seeds pooled):

* success on the test episodes: successes / episodes over all its runs, Wilson 95 % interval;
* training time: mean wall-clock minutes of training per run (``summary.json`` ``wall_s``);
* efficiency: success points per training minute (100 x success / mean minutes; none for
  untrained policies);
* time to target: mean minutes until the training-time success estimate first reached the
  target (GRN/NEAT: the best genome's success in its generation; PPO/TD3: the EvalCallback's),
  over the runs that reached it, with how many did;
* env steps of training (mean per run) and test episodes (total);
* the return rule of each method's runs, read from their ``config.json`` (``evolution.keep``,
  ``keep.rule``; :mod:`evodevo.grn.return_rule`), and the validation episodes it ran (mean per run;
  not training budget), with one sentence above the table saying whether every learner
  returns its model by the same rule (SPEC §6);
* the thesis' numbers (Table 4.2) in their own columns.

All runs must have been tested on the same object split and test seed, or the table refuses;
the caption names the seed range of that test seed (:func:`evodevo.seed_split.range_label`).
:func:`build_table` returns the rows; :func:`write_table` writes ``table_4_2.md``,
``table_4_2.csv`` and ``table_4_2_runs.csv``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError
from evodevo.grn.return_rule import describe_rule, rules_sentence
from evodevo.runs import RunDir, atomic_write_text, read_json
from evodevo.seed_split import range_label
from evodevo.stats import rate

__all__ = ["THESIS", "RunRow", "MethodRow", "read_run", "build_table", "write_table", "markdown"]

THESIS: dict[str, dict[str, float]] = {
    "grn": {"success": 57.5, "minutes": 6.5, "efficiency": 8.85, "episodes": 40},
    "ppo": {"success": 50.0, "minutes": 89.0, "efficiency": 0.56, "episodes": 10},
    "neat": {"success": 33.3, "minutes": 47.4, "efficiency": 0.70, "episodes": 30},
    "td3": {"success": 10.0, "minutes": 70.0, "efficiency": 0.14, "episodes": 40},
}
"""Thesis Table 4.2 (success %, training minutes, efficiency, test episodes)."""

_ORDER = ["grn", "grn_blind", "open_loop", "neuromodulated", "ppo", "td3", "neat", "random", "zero"]


@dataclass
class RunRow:
    """One tested run."""

    method: str
    seed: int
    run: str
    successes: int
    episodes: int
    success_rate: float
    ci_low: float
    ci_high: float
    train_min: float
    env_steps: int
    time_to_target_min: float | None
    objects: str
    test_seed: int
    return_rule: str = ""
    """The rule the run returned its model by (:func:`evodevo.grn.return_rule.describe_rule`)."""
    validation_episodes: int = 0
    """Validation episodes of that rule (not training budget)."""
    saved: dict[str, Any] | None = None
    """The run's ``config.json`` (for the caption; not written to the CSV)."""


@dataclass
class MethodRow:
    """One line of the table: a method's runs pooled."""

    method: str
    runs: int
    seeds: str
    successes: int
    episodes: int
    success_rate: float
    ci_low: float
    ci_high: float
    train_min: float
    efficiency: float | None
    env_steps: float
    time_to_target_min: float | None
    reached_target: int
    thesis_success: float | None
    thesis_minutes: float | None
    thesis_efficiency: float | None
    thesis_episodes: float | None
    return_rule: str = ""
    """The rule of the method's runs (several joined with " / " when they differ)."""
    validation_episodes: float = 0.0
    """Mean validation episodes per run."""


def _first_reach(rows: list[dict[str, str]], t_key: str, s_key: str, target: float) -> float | None:
    for r in rows:
        if float(r[s_key]) >= target:
            return float(r[t_key])
    return None


def _clean_result(run: RunDir, objects: str, kind: str | None) -> dict[str, Any]:
    """The clean test result: ``eval_<objects>_0.json``, else the clean part of a noisy test.

    A noisy ``grn evaluate`` (``--noise S``) also tests the same episodes without noise and
    stores that result under ``"clean"`` of ``eval_<objects>_<S>.json``; it is the same
    measurement as a separate clean test, so it is used rather than run twice.
    """
    eval_path = run / f"eval_{objects}_0.json"
    if eval_path.is_file():
        return dict(read_json(eval_path))
    for noisy in sorted(run.path.glob(f"eval_{objects}_*.json")):
        ev = read_json(noisy)
        clean = ev.get("clean") if isinstance(ev, dict) else None
        if isinstance(clean, dict):
            return {
                **{k: clean[k] for k in ("successes", "success_rate", "ci_low", "ci_high")},
                "episodes": ev["episodes"],
                "objects": ev["objects"],
                "test_seed": ev["test_seed"],
            }
    cmd = "grn evaluate" if kind == "grn" else "baselines evaluate"
    raise EvodevoError(
        f"{str(run.path)!r} has no test result on {objects} objects ({eval_path.name}); "
        f"run `evodevo {cmd} {run.path} --objects {objects}` first"
    )


def read_run(path: str | Path, objects: str = "test", target: float = 0.5) -> RunRow:
    """Read one tested run directory (GRN or Kuka baseline) into a :class:`RunRow`."""
    run = RunDir(path, create=False)
    saved = run.read_config()
    kind, cfg = saved.get("kind"), saved.get("config", {})
    if kind == "grn":
        controller = str(cfg.get("controller", "plain"))
        method = {"plain": "grn"}.get(controller, controller.replace(":", "."))
        if cfg.get("sensors", {}).get("blind"):
            method += "_blind"
        curve = run.read_csv("history.csv") if (run / "history.csv").is_file() else []
        reach_s = _first_reach(curve, "elapsed_s", "best_success", target)
    elif kind == "baseline":
        method = str(cfg.get("method"))
        curve = run.read_csv("learning_curve.csv") if (run / "learning_curve.csv").is_file() else []
        reach_s = _first_reach(curve, "train_s", "success", target)
    else:
        raise EvodevoError(
            f"{str(run.path)!r} holds a {kind!r} run; Table 4.2 compares Kuka runs of "
            "`grn evolve` and `baselines kuka`"
        )
    summary = run.read_summary()
    ev = _clean_result(run, objects, kind)
    return RunRow(
        method=method,
        seed=int(cfg.get("seed", 0)),
        run=str(run.path),
        successes=int(ev["successes"]),
        episodes=int(ev["episodes"]),
        success_rate=float(ev["success_rate"]),
        ci_low=float(ev["ci_low"]),
        ci_high=float(ev["ci_high"]),
        train_min=float(summary.get("wall_s", 0.0)) / 60.0,
        env_steps=int(summary.get("env_steps", 0)),
        time_to_target_min=None if reach_s is None else reach_s / 60.0,
        objects=str(ev["objects"]),
        test_seed=int(ev["test_seed"]),
        return_rule=describe_rule(saved, summary),
        validation_episodes=int(summary.get("validation_episodes", 0) or 0),
        saved=saved,
    )


def build_table(
    run_dirs: list[str | Path], objects: str = "test", target: float = 0.5
) -> tuple[list[MethodRow], list[RunRow]]:
    """Per-method rows (pooled over seeds) and per-run rows of the given tested runs."""
    if not run_dirs:
        raise EvodevoError("no run directory given; pass the tested runs to compare")
    if not 0.0 <= target <= 1.0:
        raise EvodevoError(f"--target {target} must lie in [0, 1]")
    runs = [read_run(p, objects, target) for p in run_dirs]
    seeds = {r.test_seed for r in runs}
    if len(seeds) > 1:
        raise EvodevoError(
            f"the runs were tested with different test seeds {sorted(seeds)}; evaluate them "
            "on the same episodes (same --seed) to compare"
        )
    by_method: dict[str, list[RunRow]] = {}
    for r in runs:
        by_method.setdefault(r.method, []).append(r)
    order = sorted(by_method, key=lambda m: (_ORDER.index(m) if m in _ORDER else len(_ORDER), m))
    table = []
    for m in order:
        rs = by_method[m]
        k, n = sum(r.successes for r in rs), sum(r.episodes for r in rs)
        pooled = rate(k, n)
        minutes = sum(r.train_min for r in rs) / len(rs)
        reached = [r.time_to_target_min for r in rs if r.time_to_target_min is not None]
        thesis = THESIS.get(m, {})
        table.append(
            MethodRow(
                method=m,
                runs=len(rs),
                seeds=",".join(str(r.seed) for r in sorted(rs, key=lambda r: r.seed)),
                successes=k,
                episodes=n,
                success_rate=pooled.rate,
                ci_low=pooled.ci_low,
                ci_high=pooled.ci_high,
                train_min=minutes,
                efficiency=100.0 * pooled.rate / minutes if minutes > 0 else None,
                env_steps=sum(r.env_steps for r in rs) / len(rs),
                time_to_target_min=sum(reached) / len(reached) if reached else None,
                reached_target=len(reached),
                thesis_success=thesis.get("success"),
                thesis_minutes=thesis.get("minutes"),
                thesis_efficiency=thesis.get("efficiency"),
                thesis_episodes=thesis.get("episodes"),
                return_rule=" / ".join(sorted({r.return_rule for r in rs})),
                validation_episodes=sum(r.validation_episodes for r in rs) / len(rs),
            )
        )
    return table, runs


def _f(v: float | None, fmt: str, none: str = "—") -> str:
    return none if v is None else format(v, fmt)


def markdown(table: list[MethodRow], runs: list[RunRow], target: float, title: str = "") -> str:
    """Table 4.2 as Markdown, with its object split, test seed and target named."""
    objects, test_seed = runs[0].objects, runs[0].test_seed
    rules = rules_sentence([r.saved for r in runs if r.saved is not None])
    lines = [
        title or f"Table 4.2 (reproduced): Kuka grasping, {objects} objects",
        "",
        f"Test: {objects} objects, test seed {test_seed} ({range_label(test_seed)} range); "
        f"success with Wilson 95 % interval, "
        f"runs pooled. Training time: mean per run. Efficiency: success points per training "
        f"minute. Time to target: mean minutes until the training-time success first reached "
        f"{target:.2f} (runs that reached it / runs). Validation episodes: mean per run, run by "
        f"the return rule, not part of the training budget. Thesis columns: thesis Table 4.2.",
        "",
        rules,
        "",
        "| Method | Runs (seeds) | Return rule | Success [95 % CI] | Training time | Env steps "
        "| Validation episodes | Efficiency | Time to target | Test episodes | Thesis success "
        "| Thesis time | Thesis efficiency | Thesis test episodes |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table:
        ttt = _f(r.time_to_target_min, ".1f")
        lines.append(
            f"| {r.method} | {r.runs} ({r.seeds}) | {r.return_rule} | {100 * r.success_rate:.1f} % "
            f"[{100 * r.ci_low:.1f}, {100 * r.ci_high:.1f}] ({r.successes}/{r.episodes}) "
            f"| {r.train_min:.1f} min | {r.env_steps:.0f} | {r.validation_episodes:.0f} "
            f"| {_f(r.efficiency, '.2f')} "
            f"| {ttt}{' min' if r.time_to_target_min is not None else ''} "
            f"({r.reached_target}/{r.runs}) | {r.episodes} "
            f"| {_f(r.thesis_success, '.1f')}{' %' if r.thesis_success is not None else ''} "
            f"| {_f(r.thesis_minutes, '.1f')}{' min' if r.thesis_minutes is not None else ''} "
            f"| {_f(r.thesis_efficiency, '.2f')} | {_f(r.thesis_episodes, '.0f')} |"
        )
    return "\n".join(lines) + "\n"


def write_table(
    run_dirs: list[str | Path],
    out: str | Path,
    objects: str = "test",
    target: float = 0.5,
) -> tuple[list[MethodRow], list[RunRow]]:
    """Write ``table_4_2.md``, ``table_4_2.csv`` (per method) and ``table_4_2_runs.csv``."""
    table, runs = build_table(run_dirs, objects, target)
    out_dir = RunDir(out)
    out_dir.write_csv(
        "table_4_2.csv", [asdict(r) for r in table], list(MethodRow.__dataclass_fields__)
    )
    fields = [f for f in RunRow.__dataclass_fields__ if f != "saved"]
    rows = [{k: v for k, v in asdict(r).items() if k != "saved"} for r in runs]
    out_dir.write_csv("table_4_2_runs.csv", rows, fields)
    atomic_write_text(out_dir / "table_4_2.md", markdown(table, runs, target))
    return table, runs
