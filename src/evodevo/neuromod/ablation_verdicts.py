"""Is every module necessary? BIARM against each module ablation, with verdicts (SPEC §1.5, §6).

Table 3.4's claim (every ablation lower on every task), decided as E5 of the claims page
registers it: per (task, module) cell, the full BIARM's final greedy return minus the
ablation's, paired by training seed (the seeds both finished), an exact sign-flip test, the 95 %
bootstrap interval of the mean difference and δ = 10 % of the task's random-to-solved span
(:func:`evodevo.evidence.normalise.return_margin`); **Holm over all cells together** (16 with
four tasks and four modules), not per module.

Per module the reading is:

* **supported** (the module is necessary) — at least one of its cells is "different" with
  BIARM higher, and none is "different" with the ablation higher;
* **refuted** — every one of its cells is "equivalent within δ";
* **inconclusive** — otherwise.

>>> runs = {v: {s: {"tasks": [{"env_id": "CartPole-v1", "final_return": r + s}]}
...             for s in range(3)} for v, r in (("biarm", 450.0), ("no-da", 400.0))}
>>> [(c.a, c.b, round(c.mean_diff, 1)) for c in ablation_comparisons(runs, reps=200)]
[('biarm', 'no-da', 50.0)]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from evodevo.evidence.aggregate import DEFAULT_REPS
from evodevo.evidence.verdict import (
    DIFFERENT,
    EQUIVALENT,
    Comparison,
    holm_table,
    to_markdown,
)
from evodevo.neuromod.final_verdicts import task_comparisons
from evodevo.neuromod.tables import ABLATIONS

__all__ = [
    "ABLATION_TITLE",
    "ABLATION_FILE",
    "ablation_comparisons",
    "module_readings",
    "ablation_verdict_markdown",
]

ABLATION_TITLE = "Is every module necessary? BIARM against each ablation, with verdicts (SPEC §6)"
ABLATION_FILE = "table_ablation_verdicts"
"""``table_ablation_verdicts.md`` and ``.csv`` in a ``biarm compare`` folder."""

Runs = Mapping[str, Mapping[int, Mapping[str, Any]]]


def ablation_comparisons(
    runs: Runs, full: str = "biarm", reps: int = DEFAULT_REPS
) -> list[Comparison]:
    """``full`` − each ablation of :data:`~evodevo.neuromod.tables.ABLATIONS` in ``runs``, one
    comparison per task with a δ, Holm-corrected over every cell together; modules in
    :data:`ABLATIONS` order, tasks in sequence order."""
    if full not in runs:
        return []
    cells = [c for m in ABLATIONS if m in runs for c in task_comparisons(runs, full, m, reps)]
    return holm_table(cells) if cells else []


def module_readings(cells: Sequence[Comparison]) -> dict[str, str]:
    """Per ablated module, the reading of its cells (module docstring)."""
    out: dict[str, str] = {}
    for module in dict.fromkeys(c.b for c in cells):
        mine = [c for c in cells if c.b == module]
        higher = any(c.verdict == DIFFERENT and c.mean_diff > 0 for c in mine)
        lower = any(c.verdict == DIFFERENT and c.mean_diff < 0 for c in mine)
        if higher and not lower:
            out[module] = "supported (necessary)"
        elif all(c.verdict == EQUIVALENT for c in mine):
            out[module] = "refuted (equivalent within δ on every task)"
        else:
            out[module] = "inconclusive"
    return out


def ablation_verdict_markdown(cells: Sequence[Comparison]) -> str:
    """The cells with their caption, and one reading per module (no ablation: one line)."""
    if not cells:
        return "(no ablation shares finished seeds and tasks with `biarm`)\n"
    caption = (
        "Final greedy return per task, biarm − ablation paired by seed (the seeds both "
        "finished): mean difference with its 95 % bootstrap interval, exact sign-flip p, Holm "
        f"over all {len(cells)} cells together, δ = 10 % of the task's random-to-solved span, "
        "MDE at α = 0.05 and power 0.8. A module is necessary (supported) when one of its cells "
        "is different with biarm higher and none with the ablation higher; refuted when every "
        "cell is equivalent within δ; otherwise inconclusive."
    )
    readings = "\n".join(f"- `{m}`: {r}" for m, r in module_readings(cells).items())
    return f"{caption}\n\n{to_markdown(cells)}\n\nPer module:\n\n{readings}\n"
