"""One contiguous buffer for the trainable parameters of a task (SPEC §1.6 hot path).

:func:`flatten` copies the parameters into one flat tensor and rebinds each parameter's data
to its slice of it (the ``nn.Parameter`` objects stay the same, so modules, the EWC penalty
and ``state_dict`` are unchanged), and gives every parameter a ``.grad`` that is a view of one
flat gradient buffer. Backward then accumulates into that buffer in place, so zeroing the
gradients, the norm clip and the Adam step are one operation each on one tensor instead of one
per parameter tensor (8 for a PNN column, 11 for a BIARM column). Same arithmetic, fewer
dispatches, for every variant alike.

>>> import torch
>>> a, b = torch.nn.Parameter(torch.ones(2, 2)), torch.nn.Parameter(torch.zeros(3))
>>> flat = flatten([a, b])
>>> flat.param.shape, a.data_ptr() == flat.param.data_ptr()
(torch.Size([7]), True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import torch

__all__ = ["FlatParams", "adam_step", "flatten", "flatten_adam_state"]


@dataclass
class FlatParams:
    """The flat parameter (give it to the optimiser) and its gradient buffer."""

    param: torch.nn.Parameter
    grad: torch.Tensor
    sizes: tuple[int, ...]

    def zero_grad(self) -> None:
        """Zero every parameter's gradient (one fill of the flat buffer)."""
        self.grad.zero_()


def flatten(params: Sequence[torch.nn.Parameter]) -> FlatParams:
    """Move ``params`` into one flat buffer (in place; values unchanged) and return it."""
    with torch.no_grad():
        flat = torch.cat([p.detach().reshape(-1) for p in params])
    grad = torch.zeros_like(flat)
    offset = 0
    for p in params:
        n = p.numel()
        p.data = flat[offset : offset + n].view_as(p)
        p.grad = grad[offset : offset + n].view_as(p)
        offset += n
    param = torch.nn.Parameter(flat)
    param.grad = grad
    return FlatParams(param, grad, tuple(p.numel() for p in params))


def adam_step(optimizer: torch.optim.Optimizer, lr: float) -> None:
    """``optimizer.step()`` at learning rate ``lr`` for a fused ``torch.optim.Adam`` over one
    flat parameter, as one direct call of the fused kernel that ``step()`` ends in.

    Same kernel, same state tensors (``optimizer.state_dict()`` and checkpoints unchanged), same
    numbers bit for bit (``tests/test_biarm_fastpaths.py``); it skips ``step()``'s Python
    dispatch (hooks, grouping by device, profiler records), which cost more than the kernel
    itself on a 20k-parameter column (``benchmarks/biarm_adam.py``)."""
    group = optimizer.param_groups[0]
    (p,) = group["params"]
    state = optimizer.state[p]
    if not state:  # what Adam's lazy initialisation does for fused=True
        state["step"] = torch.zeros((), dtype=torch.float32, device=p.device)
        state["exp_avg"] = torch.zeros_like(p, memory_format=torch.preserve_format)
        state["exp_avg_sq"] = torch.zeros_like(p, memory_format=torch.preserve_format)
    step = state["step"]
    step.add_(1)
    beta1, beta2 = group["betas"]
    torch._fused_adam_(
        [p], [p.grad], [state["exp_avg"]], [state["exp_avg_sq"]], [], [step],
        amsgrad=False, lr=float(lr), beta1=float(beta1), beta2=float(beta2),
        weight_decay=float(group["weight_decay"]), eps=float(group["eps"]),
        maximize=False, grad_scale=None, found_inf=None,
    )  # fmt: skip


def flatten_adam_state(state: dict[str, Any], sizes: Sequence[int]) -> dict[str, Any]:
    """An Adam ``state_dict`` saved with one entry per parameter (checkpoints written before
    :func:`flatten`) as the state of the single flat parameter; others are returned as is."""
    groups = state.get("param_groups", [])
    per = state.get("state", {})
    if len(groups) != 1 or len(groups[0]["params"]) != len(sizes) or len(sizes) == 1:
        return state
    ids = groups[0]["params"]
    if not all(i in per for i in ids):
        return state
    first = per[ids[0]]
    step = first["step"]
    merged: dict[str, Any] = {"step": step.clone() if isinstance(step, torch.Tensor) else step}
    for key in ("exp_avg", "exp_avg_sq", "max_exp_avg_sq"):
        if key in first:
            merged[key] = torch.cat([per[i][key].reshape(-1) for i in ids])
    group = {**groups[0], "params": [0]}
    return {"state": {0: merged}, "param_groups": [group]}
