"""Elastic Weight Consolidation for the shared DQN body (thesis Eq. 2.4; Kirkpatrick et al. 2017).

When task B follows tasks A_1..A_{i-1}, the loss of the ``ewc`` variant is

    L(theta) = L_TD,B(theta) + sum_k sum_j (lambda / 2) F_{k,j} (theta_j - theta*_{k,j})^2

(Eq. 2.4, one penalty per earlier task k, as in Kirkpatrick et al.'s multi-task form), over the
parameters of the shared body only: the per-task heads are never trained after their task, so
they need no protection. ``lambda`` is ``ewc.lam``.

**Fisher.** At the end of each task the diagonal Fisher information is estimated on states
from that task's replay buffer (the ``ewc.fisher_samples`` newest ones). In EWC the Fisher is
that of the model's own predictive distribution (Kirkpatrick et al. 2017 derive the penalty
from a Laplace approximation of the posterior, whose precision is that Fisher); a DQN has no
output distribution, so we take the Boltzmann policy ``pi(a|s) = softmax_a Q(s, a)`` of the
task's head and compute the *true* (not the empirical) Fisher, with the expectation over
actions done exactly rather than by sampling (there are only a handful of actions):

    F_j = mean_s sum_a pi(a|s) (d log pi(a|s) / d theta_j)^2

Per-state gradients come from ``torch.func`` (``vmap`` of ``jacrev``), so the squares are of
per-sample gradients, not of a batch gradient. We chose the log-softmax of Q over the squared
gradient of the TD loss because it needs no target and no rewards, does not vanish where the TD
error is small (a converged task is exactly where protection matters), and is the Fisher of a
probability model as EWC's derivation (a Laplace approximation of the posterior) requires.

**Cost.** The penalty is evaluated in closed form: ``sum_k F_k (theta - theta*_k)^2 =
F (theta - m)^2 + c`` with ``F = sum_k F_k``, ``m = sum_k F_k theta*_k / F`` and a constant
``c``, so every gradient step costs a few element-wise operations however many tasks are
behind (:func:`ewc_penalty` is the literal sum, used by the tests).

>>> import torch
>>> theta = [torch.tensor([1.0, 2.0])]
>>> float(ewc_penalty(theta, [([torch.tensor([0.5, 2.0])], [torch.zeros(2)])], lam=2.0))
8.5
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from torch import nn
from torch.func import functional_call, jacrev, vmap

__all__ = ["ewc_penalty", "diagonal_fisher", "EWC"]

Anchor = tuple[list[torch.Tensor], list[torch.Tensor]]


def ewc_penalty(
    params: Sequence[torch.Tensor], anchors: Sequence[Anchor], lam: float
) -> torch.Tensor:
    """Eq. 2.4's penalty ``sum_k sum_j (lam/2) F_kj (theta_j - theta*_kj)^2``, literally.

    Args:
        params: current parameters theta (list of tensors).
        anchors: per earlier task k, ``(F_k, theta*_k)`` as lists shaped like ``params``.
        lam: lambda.
    """
    total = torch.zeros(())
    for fisher, star in anchors:
        for p, f, s in zip(params, fisher, star, strict=True):
            total = total + (f * (p - s) ** 2).sum()
    return 0.5 * lam * total


def diagonal_fisher(
    model: nn.Module, names: Sequence[str], states: torch.Tensor, chunk: int = 500
) -> list[torch.Tensor]:
    """Diagonal Fisher of ``pi = softmax(model(s))`` w.r.t. the parameters ``names``.

    ``F_j = mean_s sum_a pi(a|s) (d log pi(a|s) / d theta_j)^2`` over the rows of ``states``
    (exact expectation over actions, per-sample gradients).
    """
    params = {n: p.detach() for n, p in model.named_parameters()}
    wanted = {n: params[n] for n in names}
    rest = {n: p for n, p in params.items() if n not in wanted}

    def log_pi(theta: dict[str, torch.Tensor], x: torch.Tensor) -> torch.Tensor:
        q = functional_call(model, {**rest, **theta}, (x.unsqueeze(0),))
        return torch.log_softmax(q, dim=-1).squeeze(0)

    per_sample = vmap(jacrev(log_pi), in_dims=(None, 0))
    fisher = [torch.zeros_like(wanted[n]) for n in names]
    n_states = states.shape[0]
    with torch.no_grad():
        for start in range(0, n_states, chunk):
            x = states[start : start + chunk]
            pi = torch.softmax(functional_call(model, params, (x,)), dim=-1)  # (B, A)
            jac = per_sample(wanted, x)  # name -> (B, A, *shape)
            for f, n in zip(fisher, names, strict=True):
                g2 = jac[n] ** 2
                f += torch.einsum("ba,ba...->...", pi, g2)
    return [f / n_states for f in fisher]


class EWC:
    """The penalty of Eq. 2.4 over a fixed list of (shared) parameters.

    Args:
        params: ``(name, parameter)`` pairs to protect (the shared body).
        lam: lambda.
    """

    def __init__(self, params: Sequence[tuple[str, nn.Parameter]], lam: float) -> None:
        self.names = [n for n, _ in params]
        self.params = [p for _, p in params]
        self.lam = float(lam)
        self.anchors: list[Anchor] = []
        self._f: list[torch.Tensor] = []
        self._m: list[torch.Tensor] = []
        self._c = torch.zeros(())

    def consolidate(self, model: nn.Module, states: torch.Tensor, chunk: int = 500) -> None:
        """End of a task: store its Fisher (from ``states``) and the current parameters."""
        fisher = diagonal_fisher(model, self.names, states, chunk)
        star = [p.detach().clone() for p in self.params]
        self.anchors.append((fisher, star))
        self._combine()

    def _combine(self) -> None:
        """Closed form ``F (theta - m)^2 + c`` of the sum over tasks (see module docstring)."""
        self._f, self._m, c = [], [], torch.zeros((), dtype=torch.float64)
        for j in range(len(self.params)):
            fs = [a[0][j].double() for a in self.anchors]
            ss = [a[1][j].double() for a in self.anchors]
            f = torch.stack(fs).sum(0)
            fm = torch.stack([fk * sk for fk, sk in zip(fs, ss, strict=True)]).sum(0)
            m = torch.where(f > 0, fm / torch.where(f > 0, f, 1.0), ss[-1])
            fss = torch.stack([fk * sk**2 for fk, sk in zip(fs, ss, strict=True)]).sum(0)
            c = c + (fss - f * m**2).sum()
            self._f.append(f.float())
            self._m.append(m.float())
        self._c = c.float()

    def penalty(self) -> torch.Tensor:
        """``(lam/2) sum_k sum_j F_kj (theta_j - theta*_kj)^2`` with gradient to the params."""
        if not self.anchors or self.lam == 0:
            return torch.zeros(())
        total = self._c
        for p, f, m in zip(self.params, self._f, self._m, strict=True):
            total = total + (f * (p - m) ** 2).sum()
        return 0.5 * self.lam * total

    def state_dict(self) -> dict[str, Any]:
        """Fisher and anchor of every consolidated task (checkpoints)."""
        return {"names": list(self.names), "anchors": self.anchors}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        """Restore :meth:`state_dict` output."""
        if list(data["names"]) != self.names:
            raise ValueError(f"EWC state for {data['names']} given to parameters {self.names}")
        self.anchors = [(list(f), list(s)) for f, s in data["anchors"]]
        if self.anchors:
            self._combine()
