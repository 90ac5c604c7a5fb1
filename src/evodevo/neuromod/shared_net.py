"""One shared network with a Q-head per task: the fine-tuning and EWC baselines.

The body is the first column of SPEC §1.2 -- two hidden layers of ``hidden`` ReLU units on the
padded input ``phi(x)`` of Eq. 3.10, Xavier-uniform weights, zero biases -- but it is shared by
every task and keeps learning through the whole sequence. Task i gets its own linear Q-head
(action counts differ between tasks); when task i starts, the heads of tasks < i are frozen
(they receive no gradient from task i anyway), the body is not. So the body drifts towards the
newest task and the earlier heads read features they were not trained on: catastrophic
forgetting, which the retention table then shows (thesis §1.4.4).

:class:`SharedNet` offers the interface of :class:`~evodevo.neuromod.columns.ProgressiveNet`
that :class:`~evodevo.neuromod.agent.BiarmAgent` uses (``add_column``, ``current``, ``q``,
``make_target``, ...), so every variant shares one agent and one training loop. The body is
initialised from ``torch_gen(seed, 3, 0)`` like column 0 of the progressive net, head i
from ``torch_gen(seed, 3, i)`` after it.

>>> import torch
>>> net = SharedNet(obs_dim=4, hidden=8, seed=0)
>>> _ = net.add_column(2); _ = net.add_column(3)
>>> net.q(torch.zeros(5, 4), 1, None).shape
torch.Size([5, 3])
>>> [n for n, _ in net.shared_parameters()]
['body.w1', 'body.b1', 'body.w2', 'body.b2']
"""

from __future__ import annotations

import copy
from collections.abc import Iterator

import torch
from torch import nn

from evodevo.neuromod.columns import xavier
from evodevo.seeding import torch_gen

__all__ = ["SharedBody", "TaskHead", "HeadView", "SharedNet"]


class SharedBody(nn.Module):
    """``h2 = relu(W2 relu(W1 phi(x) + b1) + b2)``, the two hidden layers of SPEC §1.2."""

    def __init__(self, obs_dim: int, hidden: int, gen: torch.Generator) -> None:
        super().__init__()
        self.w1 = xavier((obs_dim, hidden), (obs_dim, hidden), gen)
        self.b1 = nn.Parameter(torch.zeros(hidden))
        self.w2 = xavier((hidden, hidden), (hidden, hidden), gen)
        self.b2 = nn.Parameter(torch.zeros(hidden))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h1 = torch.relu(torch.addmm(self.b1, x, self.w1))
        return torch.relu(torch.addmm(self.b2, h1, self.w2))


class TaskHead(nn.Module):
    """A task's linear Q-head (one output per action)."""

    def __init__(self, hidden: int, n_actions: int, gen: torch.Generator) -> None:
        super().__init__()
        self.n_actions = n_actions
        self.wq = xavier((hidden, n_actions), (hidden, n_actions), gen)
        self.bq = nn.Parameter(torch.zeros(n_actions))

    def forward(self, h: torch.Tensor) -> torch.Tensor:
        return torch.addmm(self.bq, h, self.wq)


class HeadView(nn.Module):
    """Body + one head as a module ``x -> Q`` (what the agent trains and copies as target)."""

    def __init__(self, body: SharedBody, head: TaskHead) -> None:
        super().__init__()
        self.body = body
        self.head = head
        self.n_actions = head.n_actions

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.body(x))


class SharedNet(nn.Module):
    """The shared body and the per-task heads.

    Args:
        obs_dim: ``d_max``.
        hidden: body width (SPEC §1.2: 128).
        seed: run seed.
    """

    gated = False
    progressive = False

    def __init__(self, obs_dim: int, hidden: int, seed: int) -> None:
        super().__init__()
        self.obs_dim = obs_dim
        self.hidden = hidden
        self.seed = seed
        self.body = SharedBody(obs_dim, hidden, torch_gen(seed, 3, 0))
        self.heads = nn.ModuleList()
        # views share the body's and heads' parameters; kept out of the module tree so the
        # state dict holds every tensor once
        self._views: list[HeadView] = []

    @property
    def n_columns(self) -> int:
        """Number of tasks (heads) so far."""
        return len(self.heads)

    @property
    def current(self) -> HeadView:
        """Body + the newest head."""
        return self._views[-1]

    def add_column(self, n_actions: int) -> HeadView:
        """Freeze the earlier heads and add a trainable head for a new task (body stays live)."""
        for head in self.heads:
            for p in head.parameters():
                p.requires_grad_(False)
        gen = torch_gen(self.seed, 3, self.n_columns + 1)
        head = TaskHead(self.hidden, n_actions, gen)
        self.heads.append(head)
        view = HeadView(self.body, head)
        object.__setattr__(self, "_views", [*self._views, view])
        return view

    def shared_parameters(self) -> Iterator[tuple[str, nn.Parameter]]:
        """``(name, parameter)`` of the body: what EWC protects (Eq. 2.4)."""
        for name, p in self.body.named_parameters():
            yield f"body.{name}", p

    def q(
        self,
        x: torch.Tensor,
        col: int,
        states: torch.Tensor | None,
        ctx: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Q-values (B, n_actions) of task ``col``'s head (``states``/``ctx`` unused)."""
        return self._views[col](x)

    def make_target(self) -> HeadView:
        """A frozen copy of body + current head (the DQN target network)."""
        target = copy.deepcopy(self.current)
        for p in target.parameters():
            p.requires_grad_(False)
        return target

    def refresh_frozen(self) -> None:
        """Nothing is cached (interface of :class:`ProgressiveNet`)."""

    def freeze_all(self) -> None:
        """Freeze body and heads after the last task."""
        for p in self.parameters():
            p.requires_grad_(False)

    def config_dict(self) -> dict[str, object]:
        """Constructor arguments plus each head's action count."""
        return {
            "obs_dim": self.obs_dim,
            "hidden": self.hidden,
            "seed": self.seed,
            "actions": [h.n_actions for h in self.heads],  # type: ignore[union-attr]
        }
