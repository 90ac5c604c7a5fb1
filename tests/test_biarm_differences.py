"""The report's computed BIARM "where we differ" lines, from fixture summaries (values checked)."""

from __future__ import annotations

from typing import Any

from evodevo.reproduce.biarm_differences import biarm_differences


def _task(env: str, initial: float, final: float, evals: list[float], limit: int, us: float):
    return {
        "env_id": env,
        "episodes": 10,
        "max_steps": limit,
        "initial_return": initial,
        "final_return": final,
        "retention": 1.0 if initial == final else final / initial,
        "eval_returns_final": evals,
        "us_per_step": us,
    }


def _summary(variant: str, seed: int, cart: float, car_evals: list[float], us: float = 100.0):
    car = sum(car_evals) / len(car_evals)
    return {
        "variant": variant,
        "seed": seed,
        "tasks": [
            _task("CartPole-v1", cart, cart, [cart], 500, us),
            _task("MountainCar-v0", car, car, car_evals, 200, us),
        ],
    }


def _runs() -> dict[str, dict[int, Any]]:
    timeout = [-200.0, -200.0]
    return {
        # BIARM 300, 320, 340 -> mean 320, below the thesis' 500 and outside its interval
        "biarm": {s: _summary("biarm", s, 300.0 + 20 * s, timeout, us=120.0) for s in range(3)},
        # PNN 100, 110, 120: BIARM - PNN = +200, +210, +220 (mean +210) -> exact p = 2/8
        "pnn": {s: _summary("pnn", s, 100.0 + 10 * s, timeout, us=100.0) for s in range(3)},
        # one ablation, above BIARM on CartPole on every seed (+10)
        "no-da": {s: _summary("no-da", s, 310.0 + 20 * s, timeout) for s in range(3)},
        "sb3-dqn": {s: _summary("sb3-dqn", s, 50.0, timeout) for s in range(3)},
    }


def test_lines_hold_the_measured_comparisons():
    text = "\n".join(biarm_differences(_runs(), 1.0))
    assert "cannot go below p = 0.25" in text
    assert "BIARM 320.0 [" in text and "is below the thesis' 500.0" in text
    assert "the thesis' mean is outside our 95 % interval" in text
    assert "BIARM − PNN +210.0 per seed (higher on 3 of 3 seeds, sign-flip p = 0.25)" in text
    # measured while training, with the benchmark's figure (docs/results/biarm.md) beside it
    assert (
        "time per training step BIARM / PNN 1.20 while training, several runs sharing the cores "
        "(the benchmark 1.03-1.06; thesis 1.51)" in text
    )
    # every MountainCar evaluation episode timed out, CartPole's did not
    car = next(line for line in text.splitlines() if "**MountainCar-v0**" in line)
    assert "no greedy evaluation episode of any run reached the goal" in car
    cart = next(line for line in text.splitlines() if "**CartPole-v1**" in line)
    assert "reached the goal" not in cart
    assert "Stable-Baselines3's DQN alone on this task, same network and settings: 50.0" in cart
    # ablation above the full BIARM: 0 of 2 pairs below in ours; the thesis has both below
    assert "all 2 (task, ablation) pairs): 0 of 2 compared pairs are below the full BIARM" in text
    assert "in the thesis' Table 3.4 2 of 2 are" in text
    assert (
        "CartPole-v1: no-da +10.0 (p = 0.25, n=3); MountainCar-v0: no-da +0.0 (p = 1, n=3)." in text
    )
    assert "PNN retention** is exactly 100 % on all 6 (task, seed) pairs" in text
    assert "BIARM retention" not in text
    assert "quick" not in text and "× the thesis' episodes" not in text


def test_reduced_budget_and_forgetting_lines():
    runs = _runs()
    ft = {}
    for s in range(2):
        summ = _summary("finetune", s, 200.0, [-150.0, -200.0])
        summ["tasks"][0]["initial_return"] = 400.0  # 400 -> 200: 50 % kept
        ft[s] = summ
    runs["finetune"] = ft
    runs["pnn"][1]["tasks"][0]["retention"] = 0.9
    runs["biarm"][2]["tasks"][0]["retention"] = 0.947
    text = "\n".join(biarm_differences(runs, 0.1))
    assert "0.1 × the thesis' episodes" in text
    assert "CartPole-v1 400.0 → 200.0 (50 %)" in text
    # a fine-tuning evaluation episode reached MountainCar's goal, so the task is not "unsolved"
    assert "reached the goal" not in text
    assert "PNN retention** is below 100 % on 1 of 6" in text
    assert "BIARM retention** differs from 100 % where" in text
    assert "frozen: CartPole-v1 seed 2 94.7 %." in text


def test_ablation_bullet_names_every_pair_even_one_without_a_shared_seed():
    """4 tasks x 4 ablations = 16 pairs; one ablation has no seed shared with the full BIARM on
    one task, and the bullet still names it (it once dropped LunarLander no-ach) and ends in '.'."""
    envs = ["CartPole-v1", "Acrobot-v1", "MountainCar-v0", "LunarLander-v3"]

    def summary(variant: str, seed: int, value: float, skip: str | None = None) -> dict:
        tasks = [_task(e, value, value, [value], 500, 100.0) for e in envs if e != skip]
        return {"variant": variant, "seed": seed, "tasks": tasks}

    runs: dict[str, dict[int, Any]] = {"biarm": {s: summary("biarm", s, 100.0) for s in (0, 1)}}
    for k, a in enumerate(("no-da", "no-5ht", "no-ne", "no-ach")):
        skip = "LunarLander-v3" if a == "no-ach" else None
        runs[a] = {s: summary(a, s, 100.0 - k - s, skip) for s in (0, 1)}
    bullet = next(line for line in biarm_differences(runs, 1.0) if "**Ablations**" in line)
    for env in envs:
        for a in ("no-da", "no-5ht", "no-ne", "no-ach"):
            assert f" {a} " in " " + bullet.split(f"{env}: ")[1].split(";")[0], (env, a)
    assert "all 16 (task, ablation) pairs): 15 of 15 compared pairs are below" in bullet
    assert "LunarLander-v3: no-da -0.5 (p = 1, n=2)" in bullet  # per seed 0 and -1
    assert "no-ach — (no seed shared with BIARM)." in bullet
    assert not bullet.rstrip(".").endswith(("; ", ";", ", "))
