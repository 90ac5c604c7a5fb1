"""The BIARM part of the report's "where we differ and why", computed from the saved runs.

Each line is a measured comparison (SPEC §6: every claim with its seeds and interval), not
prose written in advance: our BIARM and PNN against the thesis' Table 3.2 numbers (is the
thesis' mean inside our 95 % bootstrap interval over seeds?), BIARM against PNN and against
each module ablation paired by seed (exact sign-flip test, seeds are the unit), tasks that no
greedy evaluation episode of any run solved, the single-task Stable-Baselines3 DQN as the
"what a standard library gets" reference, and how much of each earlier task the continual
baselines (fine-tuning, EWC) keep (SPEC §1.7 retention).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from evodevo.neuromod.evaluation import retention
from evodevo.neuromod.tables import ABLATIONS, BENCHMARK_OVERHEAD, paired_difference
from evodevo.neuromod.thesis_numbers import TABLE_3_2, TABLE_3_3_MS, TABLE_3_4
from evodevo.stats import MeanSummary, summarise

__all__ = ["biarm_differences"]

Runs = Mapping[str, Mapping[int, Mapping[str, Any]]]
FORGETTING = ("finetune", "ewc")


def _task(summary: Mapping[str, Any], env: str) -> Mapping[str, Any] | None:
    return next((t for t in summary["tasks"] if t["env_id"] == env), None)


def _finals(runs: Runs, variant: str, env: str) -> dict[int, float]:
    """Seed -> final greedy return of ``variant`` on ``env``."""
    out = {}
    for seed, s in runs.get(variant, {}).items():
        t = _task(s, env)
        if t is not None:
            out[int(seed)] = float(t["final_return"])
    return out


def _fmt(s: MeanSummary) -> str:
    return f"{s.mean:.1f} [{s.ci_low:.1f}, {s.ci_high:.1f}] (n={s.n})"


def _vs_thesis(label: str, finals: dict[int, float], thesis: float) -> str:
    s = summarise(list(finals.values()))
    side = "at or above" if s.mean >= thesis else "below"
    inside = s.ci_low <= thesis <= s.ci_high
    where = "inside" if inside else "outside"
    return (
        f"{label} {_fmt(s)} is {side} the thesis' {thesis:.1f}; the thesis' mean is {where} "
        "our 95 % interval"
    )


def _paired(a: dict[int, float], b: dict[int, float]) -> tuple[float, float, int, int] | None:
    """(mean difference a - b, exact sign-flip p, seeds where a > b, shared seeds)."""
    return paired_difference(a, b)


def _per_step_ratio(runs: Runs, env: str) -> float | None:
    """Mean BIARM µs per training step over its seeds divided by PNN's."""
    means = []
    for v in ("biarm", "pnn"):
        vals = [float(t["us_per_step"]) for s in runs.get(v, {}).values() if (t := _task(s, env))]
        if not vals:
            return None
        means.append(float(np.mean(vals)))
    return means[0] / means[1]


def _unsolved(runs: Runs, env: str) -> bool:
    """True when every greedy evaluation episode of every run on ``env`` hit the time limit
    with the per-step reward of -1 (MountainCar, Acrobot: return = -max_steps)."""
    seen = False
    for per_seed in runs.values():
        for s in per_seed.values():
            t = _task(s, env)
            if t is None:
                continue
            limit = t.get("max_steps")
            returns = t.get("eval_returns_final") or []
            if limit is None or not returns:
                return False
            seen = True
            if any(r != -float(limit) for r in returns):
                return False
    return seen


def biarm_differences(runs: Runs, scale: float) -> list[str]:
    """Markdown bullet lines comparing the saved BIARM runs with the thesis and each other."""
    if not runs:
        return []
    first = next(iter(next(iter(runs.values())).values()))
    envs = [t["env_id"] for t in first["tasks"]]
    n_seeds = max(len(r) for r in runs.values())
    lines = []
    if scale < 1:
        lines.append(
            f"- This budget trains {scale:g} × the thesis' episodes, so returns are expected to "
            "lie below the thesis' on the harder tasks; only the full budget is comparable."
        )
    lines.append(
        f"- Seeds are the unit of every test below (up to {n_seeds} per variant): the exact "
        f"two-sided sign-flip test over {n_seeds} paired seeds cannot go below "
        f"p = {2 / 2**n_seeds:.3g}, so with few seeds a difference is a direction, not a "
        "significant result; the intervals are 95 % bootstrap intervals of the mean over seeds."
    )
    for env in envs:
        parts = []
        th = TABLE_3_2.get(env, {})
        for v, label in (("biarm", "BIARM"), ("pnn", "PNN")):
            finals = _finals(runs, v, env)
            if finals and v in th:
                parts.append(_vs_thesis(label, finals, th[v][0]))
        pair = _paired(_finals(runs, "biarm", env), _finals(runs, "pnn", env))
        if pair:
            d, p, k, n = pair
            parts.append(
                f"BIARM − PNN {d:+.1f} per seed (higher on {k} of {n} seeds, sign-flip p = {p:.2g})"
            )
        speed = _per_step_ratio(runs, env)
        if speed is not None and env in TABLE_3_3_MS:
            t_pnn, t_biarm = TABLE_3_3_MS[env]
            bench = BENCHMARK_OVERHEAD.get(env)
            cited = f"the benchmark {bench[0]:.2f}-{bench[1]:.2f}; " if bench else ""
            parts.append(
                f"time per training step BIARM / PNN {speed:.2f} while training, several runs "
                f"sharing the cores ({cited}thesis {t_biarm / t_pnn:.2f})"
            )
        if _unsolved(runs, env):
            parts.append(
                "no greedy evaluation episode of any run reached the goal (every one timed out, "
                "return = −time limit), so this task separates no variants"
            )
        sb3 = _finals(runs, "sb3-dqn", env)
        if sb3:
            parts.append(
                f"Stable-Baselines3's DQN alone on this task, same network and settings: "
                f"{_fmt(summarise(list(sb3.values())))}"
            )
        if parts:
            lines.append(f"- **{env}**: " + "; ".join(parts) + ".")
    lines += _ablation_lines(runs, envs)
    lines += _forgetting_lines(runs, envs)
    return lines + [""]


def _ablation_lines(runs: Runs, envs: list[str]) -> list[str]:
    """One bullet holding every (task, ablation) pair of the budget, grouped by task; a pair
    without a seed shared with the full BIARM is named as such, never dropped."""
    present = [a for a in ABLATIONS if a in runs]
    if "biarm" not in runs or not present:
        return []
    below_ours = below_thesis = compared = 0
    per_task = []
    for env in envs:
        full = _finals(runs, "biarm", env)
        cells = []
        for a in present:
            pair = _paired(_finals(runs, a, env), full)
            th = TABLE_3_4.get(env, {})
            if a in th and "biarm" in th:
                below_thesis += th[a][0] < th["biarm"][0]
            if pair is None:
                cells.append(f"{a} — (no seed shared with BIARM)")
                continue
            d, p, _k, n = pair
            compared += 1
            below_ours += d < 0
            cells.append(f"{a} {d:+.1f} (p = {p:.2g}, n={n})")
        per_task.append(f"{env}: " + ", ".join(cells))
    total = len(envs) * len(present)
    return [
        f"- **Ablations** (ablation − full BIARM, final return paired by seed, all {total} "
        f"(task, ablation) pairs): {below_ours} of {compared} compared pairs are below the full "
        f"BIARM in our runs; in the thesis' Table 3.4 {below_thesis} of {total} are. "
        + "; ".join(per_task)
        + "."
    ]


def _forgetting_lines(runs: Runs, envs: list[str]) -> list[str]:
    out = []
    if "pnn" in runs:
        kept = [
            float(t["retention"])
            for s in runs["pnn"].values()
            for t in s["tasks"]
            if t.get("retention") is not None
        ]
        if kept and all(r == 1.0 for r in kept):
            out.append(
                f"- **PNN retention** is exactly 100 % on all {len(kept)} (task, seed) pairs: frozen "
                "columns evaluated on fixed seeds (SPEC §1.7). The thesis' 91-99 % PNN retention "
                "(Table 3.5) is evaluation noise, not forgetting."
            )
        elif kept:
            out.append(
                f"- **PNN retention** is below 100 % on {sum(r != 1.0 for r in kept)} of "
                f"{len(kept)} (task, seed) pairs, which frozen columns should not allow "
                "(SPEC §1.7): a non-deterministic task or a defect; check the runs."
            )
    moved = [
        f"{t['env_id']} seed {seed} {100 * float(t['retention']):.1f} %"
        for seed, s in sorted(runs.get("biarm", {}).items())
        for t in s["tasks"]
        if t.get("retention") is not None and float(t["retention"]) != 1.0
    ]
    if moved:
        out.append(
            "- **BIARM retention** differs from 100 % where a frozen column's return moved after "
            "it was frozen: " + "; ".join(moved) + ". Its laterals are gated by the *current* "
            "module states (Eq. 3.8), so a frozen BIARM column is not a fixed function; its "
            "weights do not change."
        )
    for v in FORGETTING:
        if v not in runs:
            continue
        cells = []
        for env in envs[:-1]:
            ini = [float(t["initial_return"]) for s in runs[v].values() if (t := _task(s, env))]
            fin = [float(t["final_return"]) for s in runs[v].values() if (t := _task(s, env))]
            if ini:
                r = retention(float(np.mean(ini)), float(np.mean(fin)))
                cells.append(
                    f"{env} {np.mean(ini):.1f} → {np.mean(fin):.1f} "
                    f"({'undefined' if np.isnan(r) else f'{100 * r:.0f} %'})"
                )
        if cells:
            out.append(
                f"- **{v}** (one network through the sequence) keeps of each earlier task, "
                "initial → final return (retention of the seed means; PNN: 100 % by "
                "construction): " + "; ".join(cells) + "."
            )
    return out
