"""The ablation tables of several seeds' best genomes as one table (SPEC §2.5, §6).

Each seed's ``ablations.json`` (:func:`evodevo.grn.ablations.run_ablations`) tests its own best
genome and its nine ablations on the same fixed test episodes. Pooled over seeds:

* per seed, the change in points and its exact McNemar p (paired on that seed's episodes);
* the pooled success of the intact genomes and of the ablated ones, and the change with a
  Newcombe 95 % interval over all episodes (this interval treats the two samples as
  independent, so it is conservative for paired episodes);
* an exact McNemar p on the discordant episodes summed over the seeds (the pairs stay pairs)
  when every seed's table records them, else the unpaired Fisher p on the pooled counts, with
  the test named;
* how many seeds' ablated genome succeeded less often than the intact one.

>>> rows = pool_ablations({0: [{"ablation": "intact", "successes": 5, "episodes": 10},
...     {"ablation": "no_noise", "successes": 3, "episodes": 10, "mcnemar_p": 0.5,
...      "only_ablated": 0, "only_intact": 2}]})
>>> rows[1]["successes"], rows[1]["intact_successes"], rows[1]["test"], rows[1]["seeds_lower"]
(3, 5, 'McNemar', 1)
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from evodevo.errors import EvodevoError
from evodevo.grn.ablations import difference_interval
from evodevo.stats import fisher_exact, mcnemar_exact_counts, rate

__all__ = ["pool_ablations", "pooled_ablations_markdown", "read_ablation_tables"]


def read_ablation_tables(
    run_dirs: dict[int, Path], name: str = "ablations.json"
) -> dict[int, list[dict[str, Any]]]:
    """``{seed: rows}`` of every run directory that holds the table ``name``
    (``ablations.json``, or ``modulator_ablations.json`` of a neuromodulated GRN)."""
    tables: dict[int, list[dict[str, Any]]] = {}
    for seed, rdir in run_dirs.items():
        path = Path(rdir) / name
        if path.is_file():
            try:
                tables[seed] = list(json.loads(path.read_text())["rows"])
            except (ValueError, KeyError, TypeError) as exc:
                raise EvodevoError(
                    f"{path} is not an ablation table ({exc}); rerun `evodevo grn ablate`"
                ) from exc
    return tables


def pool_ablations(tables: dict[int, list[dict[str, Any]]]) -> list[dict[str, Any]]:
    """One pooled row per ablation (``intact`` first) from ``{seed: rows}``."""
    if not tables:
        return []
    intact: dict[int, dict[str, Any]] = {}
    for seed, rows in tables.items():
        found = [r for r in rows if r["ablation"] == "intact"]
        if not found:
            raise EvodevoError(f"the ablation table of seed {seed} has no 'intact' row")
        intact[seed] = found[0]
    names: list[str] = []
    for rows in tables.values():
        names += [r["ablation"] for r in rows if r["ablation"] not in names]
    pooled: list[dict[str, Any]] = []
    for name in names:
        per_seed: dict[int, dict[str, Any]] = {}
        for seed, rows in tables.items():
            match = [r for r in rows if r["ablation"] == name]
            if match:
                per_seed[seed] = match[0]
        k = sum(int(r["successes"]) for r in per_seed.values())
        n = sum(int(r["episodes"]) for r in per_seed.values())
        ki = sum(int(intact[s]["successes"]) for s in per_seed)
        ni = sum(int(intact[s]["episodes"]) for s in per_seed)
        lo, hi = difference_interval(k, n, ki, ni)
        paired = all("only_ablated" in r and "only_intact" in r for r in per_seed.values())
        if name == "intact":
            p, test = 1.0, "—"
        elif paired:
            p = mcnemar_exact_counts(
                sum(int(r["only_ablated"]) for r in per_seed.values()),
                sum(int(r["only_intact"]) for r in per_seed.values()),
            )
            test = "McNemar"
        else:
            p, test = fisher_exact(k, n, ki, ni), "Fisher"
        r = rate(k, n)
        pooled.append(
            {
                "ablation": name,
                "seeds": sorted(per_seed),
                "successes": k,
                "episodes": n,
                "success_rate": r.rate,
                "ci_low": r.ci_low,
                "ci_high": r.ci_high,
                "intact_successes": ki,
                "intact_episodes": ni,
                "change": k / n - ki / ni,
                "change_ci_low": lo,
                "change_ci_high": hi,
                "p": p,
                "test": test,
                "per_seed": {
                    s: (
                        int(row["successes"]) / int(row["episodes"])
                        - int(intact[s]["successes"]) / int(intact[s]["episodes"]),
                        row.get("mcnemar_p"),
                    )
                    for s, row in per_seed.items()
                },
                "seeds_lower": sum(
                    int(row["successes"]) * int(intact[s]["episodes"])
                    < int(intact[s]["successes"]) * int(row["episodes"])
                    for s, row in per_seed.items()
                ),
            }
        )
    return pooled


def pooled_ablations_markdown(rows: list[dict[str, Any]]) -> str:
    """The pooled table in Markdown (see the module docstring for what each column is)."""
    if not rows:
        return "(no ablation tables)\n"
    seeds = rows[0]["seeds"]
    lines = [
        f"Ablations of the best genome of each of seeds {', '.join(map(str, seeds))} (each on "
        f"its own {rows[0]['episodes'] // max(len(seeds), 1)} test episodes), pooled. Per seed: "
        "change in points (exact McNemar p on that seed's episodes). Pooled: success over all "
        "episodes, change against the intact genomes with a Newcombe 95 % interval (unpaired, "
        "so conservative), and the test named in its column: exact McNemar on the discordant "
        "episodes summed over seeds, or Fisher on the pooled counts where a table lacks them.",
        "",
        "| ablation | per seed, points (McNemar p) | pooled success [95 % CI] | pooled change [95 % CI] | p (test) | seeds lower |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        per = "; ".join(
            f"s{s}: {100 * d:+.1f}"
            + (f" ({p:.2g})" if p is not None and r["ablation"] != "intact" else "")
            for s, (d, p) in r["per_seed"].items()
        )
        p_txt = "—" if r["test"] == "—" else f"{r['p']:.3g} ({r['test']})"
        lines.append(
            f"| {r['ablation']} | {per} | {100 * r['success_rate']:.1f} % "
            f"[{100 * r['ci_low']:.1f}, {100 * r['ci_high']:.1f}] | "
            f"{100 * r['change']:+.1f} [{100 * r['change_ci_low']:+.1f}, "
            f"{100 * r['change_ci_high']:+.1f}] | {p_txt} | "
            + (f"{r['seeds_lower']} of {len(r['seeds'])} |" if r["ablation"] != "intact" else "— |")
        )
    return "\n".join(lines) + "\n"
