"""Tables of docs/results/history.md, "The GRN that sees" (issue 22), from the saved per-episode files.

Usage: python docs/results/grn_vision/analyse.py  (reads docs/results/grn_vision/*, thesis/grn/*)
Every policy row is on the same 200 held-out-object test episodes (test seed 10000); pairs are
compared with the exact McNemar test (evodevo.stats.mcnemar_exact).
"""

from __future__ import annotations

import json
from pathlib import Path

from evodevo.reproduce.run_files import paired, successes
from evodevo.stats import rate

HERE = Path(__file__).resolve().parent
THESIS = HERE.parent / "thesis" / "grn"
BASE = HERE / "baselines_test_episodes.csv"


def fmt(k: int, n: int) -> str:
    r = rate(k, n)
    return f"{100 * r.rate:.1f} % [{100 * r.ci_low:.1f}, {100 * r.ci_high:.1f}] ({k}/{n})"


def pfmt(pair: tuple[float, float] | None) -> str:
    return "—" if pair is None else f"{100 * pair[0]:+.1f} (p = {pair[1]:.2g})"


def main() -> None:
    refs = {
        "constant turn": successes(BASE, "turn"),
        "scripted image-only pipeline": successes(BASE, "scripted"),
        "all-zero": successes(BASE, "zero"),
        "uniform random": successes(BASE, "random"),
        "open-loop sequence (thesis preset, seed 0)": successes(
            THESIS / "openloop_s0" / "eval_test_0_episodes.csv", "genome"
        ),
        "thesis GRN, seed 0": successes(
            THESIS / "plain_s0" / "eval_test_0.03_episodes.csv", "genome"
        ),
    }
    seeds = sorted(HERE.glob("vision_s*"))
    blind = {}
    for b in sorted(HERE.glob("vision_blind_s*")):
        blind[b.name.rsplit("_s", 1)[1]] = successes(b / "eval_test_0_episodes.csv", "genome")
    print("| policy | test success, clean [Wilson 95 %] | noise 0.03 | training episodes | wall |")
    print("|---|---|---|---|---|")
    pooled_k = pooled_n = 0
    grn: dict[str, list[int]] = {}
    for d in seeds:
        s = d.name.rsplit("_s", 1)[1]
        ev = d / "eval_test_0.03_episodes.csv"
        clean, noisy = successes(ev, "genome"), successes(ev, "genome_noisy")
        if clean is None:
            continue
        grn[s] = clean
        summ = json.loads((d / "summary.json").read_text())
        pooled_k, pooled_n = pooled_k + sum(clean), pooled_n + len(clean)
        nz = fmt(sum(noisy), len(noisy)) if noisy else "—"
        print(
            f"| **GRN, vision preset, seed {s}** | **{fmt(sum(clean), len(clean))}** | {nz} | "
            f"{summ['episodes_run']} | {summ['wall_s'] / 60:.1f} min |"
        )
    if pooled_n:
        print(f"| GRN, vision preset, pooled | {fmt(pooled_k, pooled_n)} | | | |")
    for s, b in blind.items():
        if b:
            summ = json.loads((HERE / f"vision_blind_s{s}" / "summary.json").read_text())
            print(
                f"| blind GRN, vision preset, seed {s} | {fmt(sum(b), len(b))} | — | "
                f"{summ['episodes_run']} | {summ['wall_s'] / 60:.1f} min |"
            )
    for name, e in refs.items():
        if e:
            print(f"| {name} | {fmt(sum(e), len(e))} | | | |")
    print()
    cols = list(grn)
    print(
        "| GRN seed − policy, points (exact McNemar p) | "
        + " | ".join(f"seed {s}" for s in cols)
        + " |"
    )
    print("|---|" + "---|" * len(cols))
    for name, e in {**{f"blind GRN seed {s}": b for s, b in blind.items()}, **refs}.items():
        print(f"| {name} | " + " | ".join(pfmt(paired(grn[s], e)) for s in cols) + " |")


def second_preset() -> None:
    """The second vision preset (restart, proprioception off; ``vision2_s*``), 2026-12-04."""
    base = {
        "constant turn": successes(BASE, "turn"),
        "scripted image-only pipeline": successes(BASE, "scripted"),
        "all-zero": successes(BASE, "zero"),
        "uniform random": successes(BASE, "random"),
        "first vision preset, seed 0": successes(
            HERE / "vision_s0" / "eval_test_0.03_episodes.csv", "genome"
        ),
    }
    runs = sorted(HERE.glob("vision2_s*"))
    if not runs:
        return
    print()
    print("| second vision preset | clean [Wilson 95 %] | noise 0.03 | training episodes | wall |")
    print("|---|---|---|---|---|")
    got: dict[str, list[int]] = {}
    for d in runs:
        s = d.name.rsplit("_s", 1)[1]
        ev = d / "eval_test_0.03_episodes.csv"
        clean, noisy = successes(ev, "genome"), successes(ev, "genome_noisy")
        if clean is None:
            continue
        got[s] = clean
        summ = json.loads((d / "summary.json").read_text())
        nz = fmt(sum(noisy), len(noisy)) if noisy else "—"
        print(
            f"| seed {s} | {fmt(sum(clean), len(clean))} | {nz} | {summ['episodes_run']} | "
            f"{summ['wall_s'] / 60:.1f} min |"
        )
    k, n = sum(sum(v) for v in got.values()), sum(len(v) for v in got.values())
    print(f"| pooled, {len(got)} seeds | {fmt(k, n)} | | | |")
    print()
    print("| second preset − policy, points (exact McNemar p) | " + " | ".join(got) + " |")
    print("|---|" + "---|" * len(got))
    for name, e in base.items():
        print(f"| {name} | " + " | ".join(pfmt(paired(got[s], e)) for s in got) + " |")
    noes: dict[str, list[int]] = {}
    variants = (
        ("vision2_noes_s*", "no early stop"),  # the same preset, evolution.early_stop false
        ("vision3_grasp_s*", "reach at the grasp"),  # + evaluation.distance_at grasp, weight 2
        ("vision2_blind_s*", "blind GRN (no-early-stop preset)"),  # visual features zeroed
        ("vision2_g30_s*", "preset extended to 30 generations (3,600 episodes)"),
        ("vision4_pop24_s*", "24 genomes x 4 episodes x 18 generations (1,728 episodes)"),
        ("vision5_pick_s*", "24 x 4 x 17 + final pick 6 elites x 28 episodes (1,800 episodes)"),
        ("vision5_pick_blind_s*", "blind GRN of 24 x 4 x 17 + final pick"),
        ("vision6_target_s*", "reach to the seen target at the grasp, weight 3"),
        ("vision6_blind_s*", "blind GRN of the reach-to-target config"),
        ("vision7_record_s*", "the preset, keeping the champion by record (evolution.keep)"),
        ("vision7_blind_s*", "blind GRN of the preset, keeping the champion by record"),
        ("vision8_t5_s*", "the preset (keep record) with tournament 5"),
    )
    blind_ep = HERE / "vision2_blind_s0" / "eval_test_0_episodes.csv"
    blind0 = successes(blind_ep, "genome") if blind_ep.is_file() else None
    for pattern, label in variants:
        mine: dict[str, list[int]] = {}
        for d in sorted(HERE.glob(pattern)):
            s = d.name.rsplit("_s", 1)[1]
            ev = next(d.glob("eval_test_*_episodes.csv"), None)
            clean = None if ev is None else successes(ev, "genome")
            if clean is None:
                continue
            noisy = successes(ev, "genome_noisy") or []
            summ = json.loads((d / "summary.json").read_text())
            print(f"\n{label}, seed {s}: {fmt(sum(clean), len(clean))}, noisy "
                  f"{fmt(sum(noisy), len(noisy)) if noisy else '—'}, {summ['episodes_run']} "
                  f"episodes, {summ['wall_s'] / 60:.1f} min")  # fmt: skip
            others = {**base, **{f"early-stopped seed {k}": v for k, v in got.items()}}
            others.update({f"no early stop, seed {k}": v for k, v in noes.items()})
            if blind0 is not None and "blind" not in pattern:
                others["blind GRN, seed 0"] = blind0
            if pattern.startswith("vision5_pick_s"):
                for b in sorted(HERE.glob("vision5_pick_blind_s*")):
                    ep = b / "eval_test_0_episodes.csv"
                    if ep.is_file():
                        others[f"blind GRN of this config, {b.name[-2:]}"] = successes(ep, "genome")
                same = HERE / f"vision4_pop24_s{s}" / "eval_test_0_episodes.csv"
                if same.is_file():
                    others["24 x 4 x 18 without the pick, same seed"] = successes(same, "genome")
            if pattern.startswith(("vision6_target_s", "vision7_record_s", "vision8_t5_s")):
                for name, sub in (
                    ("the preset keeping the champion by record, same seed", "vision7_record"),
                    ("the preset (reach to the nearest object), same seed", "vision2_noes"),
                    ("blind GRN of the preset, same seed", "vision2_blind"),
                    ("blind GRN of this config, same seed", "vision6_blind"),
                    ("blind GRN keeping the champion by record, same seed", "vision7_blind"),
                ):
                    ep = next((HERE / f"{sub}_s{s}").glob("eval_test_*_episodes.csv"), None)
                    if ep is not None:
                        others[name] = successes(ep, "genome")
            for name, e in others.items():
                print(f"  − {name}: {pfmt(paired(clean, e))}")
            mine[s] = clean
        k, n = sum(sum(v) for v in mine.values()), sum(len(v) for v in mine.values())
        if n:
            print(f"\n{label}, pooled over {len(mine)} seeds: {fmt(k, n)}")
        if not noes:
            noes = mine


def preset_vs_own_blind(seeing: str = "vision2_noes", blind_of: str = "vision2_blind") -> None:
    """A preset's runs (``seeing``_s*) against the blind GRN of the same preset and seed."""
    rows = []
    for d in sorted(HERE.glob(f"{seeing}_s*")):
        s = d.name.rsplit("_s", 1)[1]
        b = HERE / f"{blind_of}_s{s}" / "eval_test_0_episodes.csv"
        mine = successes(next(d.glob("eval_test_*_episodes.csv")), "genome")
        if not b.is_file() or mine is None:
            continue
        blind = successes(b, "genome")
        rows.append((s, mine, blind))
    if not rows:
        return
    print(f"\n| seed | {seeing} | {blind_of}, same seed | seeing − blind (exact McNemar p) |")
    print("|---|---|---|---|")
    for s, mine, blind in rows:
        print(
            f"| {s} | {fmt(sum(mine), len(mine))} | {fmt(sum(blind), len(blind))} | "
            f"{pfmt(paired(mine, blind))} |"
        )
    k = sum(sum(m) for _, m, _ in rows)
    n = sum(len(m) for _, m, _ in rows)
    kb = sum(sum(b) for _, _, b in rows)
    print(f"| pooled | {fmt(k, n)} | {fmt(kb, n)} | |")


def baselines_on_features() -> None:
    """PPO and NEAT on the blob features at the preset's budget (``ppo_blob_s*``,
    ``neat_blob_s*``; ``evodevo baselines kuka --config configs/baselines_kuka_vision.yaml``)
    against the preset's seeds and the controls, on the same 200 test episodes."""
    refs = {
        "constant turn": successes(BASE, "turn"),
        "scripted image-only pipeline": successes(BASE, "scripted"),
    }
    for s in "012":
        for sub, name in (
            ("vision7_record", "GRN, keep record"),
            ("vision2_noes", "GRN, keep last"),
        ):
            ep = next((HERE / f"{sub}_s{s}").glob("eval_test_*_episodes.csv"), None)
            if ep is not None:
                refs[f"{name}, seed {s}"] = successes(ep, "genome")
    for d in sorted([*HERE.glob("ppo_blob_s*"), *HERE.glob("neat_blob_s*")]):
        ev = d / "eval_test_0_episodes.csv"
        mine = successes(ev, "genome") if ev.is_file() else None
        if mine is None:
            continue
        summ = json.loads((d / "summary.json").read_text())
        steps = summ.get("env_steps", summ.get("total_timesteps", "?"))
        print(f"\n{d.name}: {fmt(sum(mine), len(mine))}, training env steps {steps}")
        for name, e in refs.items():
            print(f"  − {name}: {pfmt(paired(mine, e))}")
    pooled_pairs(
        ("GRN (keep record)", "vision7_record_s{}"),
        ("PPO", "ppo_blob_s{}"),
        ("NEAT", "neat_blob_s{}"),
    )


def pooled_pairs(*runs_of: tuple[str, str]) -> None:
    """Seeds 0-2 pooled per policy (name, run-folder pattern), and every pair of them on the
    same episodes matched by seed (exact McNemar); a policy with a seed missing is left out."""
    pooled: dict[str, list[int]] = {}
    for name, pattern in runs_of:
        runs = [HERE / pattern.format(s) / "eval_test_0_episodes.csv" for s in "012"]
        if all(r.is_file() for r in runs):
            pooled[name] = [x for r in runs for x in successes(r, "genome") or []]
    print("\nseeds 0-2 pooled; pairs matched by seed and episode (exact McNemar):")
    names = list(pooled)
    for i, a in enumerate(names):
        print(f"  {a}: {fmt(sum(pooled[a]), len(pooled[a]))}")
        for b in names[i + 1 :]:
            print(f"    − {b}: {pfmt(paired(pooled[a], pooled[b]))}")


def neuromodulated() -> None:
    """The neuromodulated GRN (SPEC §5) on the vision preset (``vision9_nm_s*``) against the
    plain GRN and the blind GRN of the same seed (``keep: record``) and the constant turn."""
    for d in sorted(HERE.glob("vision9_nm_s*")):
        ev = d / "eval_test_0_episodes.csv"
        if not ev.is_file():
            continue
        s = d.name.rsplit("_s", 1)[1]
        mine = successes(ev, "genome")
        assert mine is not None
        print(f"\nneuromodulated GRN, seed {s}: {fmt(sum(mine), len(mine))}")
        for name, other in (
            ("plain GRN", successes(HERE / f"vision7_record_s{s}" / ev.name, "genome")),
            ("blind GRN", successes(HERE / f"vision7_blind_s{s}" / ev.name, "genome")),
            ("constant turn", successes(BASE, "turn")),
        ):
            print(f"  − {name}: {pfmt(paired(mine, other))}")
    pooled_pairs(
        ("neuromodulated GRN", "vision9_nm_s{}"),
        ("plain GRN (keep record)", "vision7_record_s{}"),
        ("blind GRN", "vision7_blind_s{}"),
    )


def noisy_features() -> None:
    """The preset's kept genomes (``vision7_record_s*``) with N(0, 0.03²) noise on the visual
    features (``evodevo grn evaluate DIR --test-episodes 200 --noise 0.03``) against the same
    genome clean, the constant turn and the blind GRN (no visual input, so no noise to add)."""
    pooled: dict[str, list[int]] = {"noisy": [], "clean": [], "blind": [], "turn": []}
    for s in "012":
        d = HERE / f"vision7_record_s{s}"
        runs = {
            "noisy": successes(d / "eval_test_0.03_episodes.csv", "genome_noisy"),
            "clean": successes(d / "eval_test_0_episodes.csv", "genome"),
            "blind": successes(HERE / f"vision7_blind_s{s}" / "eval_test_0_episodes.csv", "genome"),
            "turn": successes(BASE, "turn"),
        }
        if any(v is None for v in runs.values()):
            continue
        noisy = runs["noisy"] or []
        print(f"\nGRN with feature noise 0.03, seed {s}: {fmt(sum(noisy), len(noisy))}")
        for name in ("clean", "blind", "turn"):
            print(f"  − {name}: {pfmt(paired(noisy, runs[name]))}")
            pooled[name] += runs[name] or []
        pooled["noisy"] += noisy
    if pooled["noisy"]:
        noisy = pooled["noisy"]
        print(f"\npooled with feature noise: {fmt(sum(noisy), len(noisy))}")
        for name in ("clean", "blind", "turn"):
            print(f"  − {name}: {pfmt(paired(noisy, pooled[name]))}")


if __name__ == "__main__":
    main()
    second_preset()
    preset_vs_own_blind()
    preset_vs_own_blind("vision7_record", "vision7_blind")
    baselines_on_features()
    neuromodulated()
    noisy_features()
