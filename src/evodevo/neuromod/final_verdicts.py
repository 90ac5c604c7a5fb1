"""Verdicts on the final return (SPEC §6): each variant against the reference ``pnn``, per task.

Table 3.2's question, answered as the claims page decides it: per task, the final greedy return
of variant A minus that of ``pnn``, paired by training seed (the seeds both have finished), an
exact sign-flip test with Holm's correction over the tasks of the pair, the 95 % bootstrap
interval of the mean difference, and a margin δ fixed before any run — 10 % of the span from a
uniform-random policy's mean return to the task's solved threshold, in return units
(:func:`evodevo.evidence.normalise.return_margin`). The verdict is "different", "equivalent
within δ" or "inconclusive" with the runs a decision would need
(:mod:`evodevo.evidence.verdict`); the minimum detectable difference of these runs stands
beside it. A task without a solved threshold (or trained with another step limit) has no δ
and is left out, and says so.

>>> runs = {v: {s: {"tasks": [{"env_id": "CartPole-v1", "final_return": r + s}]}
...             for s in range(3)} for v, r in (("pnn", 400.0), ("biarm", 450.0))}
>>> [(c.task, c.a, round(c.mean_diff, 1)) for c in final_return_comparisons(runs, reps=200)]
[('CartPole-v1', 'biarm', 50.0)]
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from evodevo.evidence.aggregate import DEFAULT_REPS
from evodevo.evidence.normalise import return_margin
from evodevo.evidence.verdict import Comparison, compare, holm_table, to_markdown
from evodevo.neuromod.continual_metrics import scale_of

__all__ = [
    "FINAL_TITLE",
    "FINAL_FILE",
    "task_comparisons",
    "final_return_comparisons",
    "final_verdict_markdown",
    "final_verdict_csv",
]

FINAL_TITLE = "Final return: each variant against pnn, with its verdict (SPEC §6)"
FINAL_FILE = "table_final_verdicts"
"""``table_final_verdicts.md`` and ``.csv`` in a ``biarm compare`` folder."""

Runs = Mapping[str, Mapping[int, Mapping[str, Any]]]


def task_comparisons(runs: Runs, a: str, b: str, reps: int = DEFAULT_REPS) -> list[Comparison]:
    """``a`` − ``b`` on the final return, one uncorrected comparison per task that has a δ,
    paired on the seeds both finished; empty when they share no seed or task sequence."""
    seeds = sorted(set(runs[a]) & set(runs[b]))
    if not seeds:
        return []
    tasks = runs[b][seeds[0]]["tasks"]
    if [t["env_id"] for t in runs[a][seeds[0]]["tasks"]] != [t["env_id"] for t in tasks]:
        return []  # another task sequence: nothing to pair
    out = []
    for i, task in enumerate(tasks):
        scale = scale_of(str(task["env_id"]), task.get("max_steps"))
        if scale is None:
            continue
        xa = [float(runs[a][s]["tasks"][i]["final_return"]) for s in seeds]
        xb = [float(runs[b][s]["tasks"][i]["final_return"]) for s in seeds]
        out.append(compare(a, xa, b, xb, return_margin(scale), reps=reps, task=task["env_id"]))
    return out


def final_return_comparisons(
    runs: Runs, reference: str = "pnn", reps: int = DEFAULT_REPS
) -> list[Comparison]:
    """Every variant of ``runs`` (``{variant: {seed: summary}}``) against ``reference``, one
    :class:`~evodevo.evidence.verdict.Comparison` per task with a δ, Holm-corrected over the
    tasks of each pair; variants sorted by name, tasks in sequence order."""
    if reference not in runs:
        return []
    out: list[Comparison] = []
    for variant in sorted(v for v in runs if v != reference):
        family = task_comparisons(runs, variant, reference, reps)
        if family:
            out += holm_table(family)
    return out


def final_verdict_markdown(comparisons: list[Comparison]) -> str:
    """The table with its caption (empty comparisons: one line saying why)."""
    if not comparisons:
        return "(no variant shares finished seeds and tasks with `pnn`)\n"
    caption = (
        "Final greedy return per task, variant − pnn paired by seed (the seeds both finished): "
        "mean difference in return with its 95 % bootstrap interval, exact sign-flip p and its "
        "Holm correction over the tasks of each pair, δ = 10 % of the span from a uniform-random "
        "policy's mean return to the solved threshold (`evodevo.evidence.normalise`), and the "
        "minimum detectable difference (MDE) of these runs at α = 0.05 and power 0.8. Verdict: "
        "different (Holm p < 0.05 and the interval excludes 0), equivalent within δ (the "
        "interval inside ±δ), or inconclusive with the runs a decision would need."
    )
    return f"{caption}\n\n{to_markdown(comparisons)}\n"


def final_verdict_csv(comparisons: list[Comparison]) -> str:
    """The comparisons as CSV (one row each, the numbers unrounded)."""
    cols = ["task", "a", "b", "n", "mean_diff", "low", "high", "std_diff", "p", "p_adj"]
    cols += ["delta", "mde", "verdict", "runs_needed", "test"]
    lines = [",".join(cols)]
    for c in comparisons:
        values = [getattr(c, k) for k in cols]
        lines.append(",".join("" if v is None else str(v) for v in values))
    return "\n".join(lines) + "\n"
