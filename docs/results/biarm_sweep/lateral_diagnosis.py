"""Why MountainCar is solved alone but not third in the sequence (issue 21; SPEC §1.2, §1.6).

For a finished (or past-task-1) PNN run, on 500 random MountainCar states padded to d_max:
the frozen columns' activations (size per sample, against the raw input's), and the initial
Q-values of a new MountainCar column built on the run's frozen columns vs. of the same column
alone (no laterals). Usage:

    python docs/results/biarm_sweep/lateral_diagnosis.py docs/results/thesis/biarm_default/runs/pnn__s0
"""

from __future__ import annotations

import sys

import numpy as np
import torch

from evodevo.config import from_dict
from evodevo.neuromod.agent import BiarmAgent
from evodevo.neuromod.checkpoint import load_checkpoint
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.variants import get_variant
from evodevo.runs import read_json


def main(run: str, variant: str = "pnn") -> None:
    torch.set_num_threads(1)
    saved = dict(read_json(f"{run}/config.json")["config"])
    for key in ("seed", "variant"):
        saved.pop(key, None)
    cfg = from_dict(BiarmConfig, saved)
    state = load_checkpoint(f"{run}/checkpoints/task1.pt")["agent"]
    rng = np.random.default_rng(0)
    x = torch.zeros(500, 8)
    x[:, 0] = torch.as_tensor(rng.uniform(-1.2, 0.6, 500), dtype=torch.float32)
    x[:, 1] = torch.as_tensor(rng.uniform(-0.07, 0.07, 500), dtype=torch.float32)
    print(f"raw input: sum |x| per sample {x.abs().sum(1).mean():.2f}")
    net = state["net"]
    h1_prev = None
    for c in (0, 1):
        w1, b1, w2, b2 = (net[f"columns.{c}.{n}"] for n in ("w1", "b1", "w2", "b2"))
        h1 = torch.relu(x @ w1 + b1)
        pre2 = h1 @ w2 + b2
        if c == 1 and h1_prev is not None:
            pre2 = pre2 + h1_prev @ net["columns.1.u2"]
        h2 = torch.relu(pre2)
        h1_prev = h1
        print(
            f"frozen column {c}: sum h1 per sample {h1.sum(1).mean():.1f}, "
            f"sum h2 per sample {h2.sum(1).mean():.1f}"
        )
    for label, frozen in (("third in the sequence", True), ("alone", False)):
        agent = BiarmAgent(cfg, get_variant(variant), 8, 0)
        if frozen:
            agent.load_state(state)
        agent.begin_task(3)
        q = agent.greedy_q(x, agent.col)
        counts = np.bincount(q.argmax(1).numpy(), minlength=3)
        print(
            f"new MountainCar column, {label}: initial Q mean {q.mean():.3f}, std "
            f"{q.std():.3f}, range [{q.min():.2f}, {q.max():.2f}], greedy action counts "
            f"{counts.tolist()}"
        )


if __name__ == "__main__":
    main(*sys.argv[1:])
