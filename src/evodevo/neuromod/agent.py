"""The learner: column stack, neuromodulators, optimiser and the DQN update (SPEC §1.2-1.6).

:class:`BiarmAgent` is the same class for every variant; the :class:`Variant` decides whether
laterals are gated, whether the modules run (Eq. 3.1-3.6), drive the learning rate (Eq. 3.7)
and the context gate (Eq. 3.8), and which modules are ablated. The ``finetune`` and ``ewc``
baselines swap the column stack for one shared body with per-task heads
(:class:`~evodevo.neuromod.shared_net.SharedNet`); ``ewc`` adds the Eq. 2.4 penalty to every
gradient step and consolidates the Fisher at the end of each task (:meth:`end_task`).

Hot path (per environment step): :meth:`act` (greedy forward in NumPy on a preallocated
row, :meth:`~evodevo.neuromod.columns.ProgressiveNet.q_np`), :meth:`observe` (module update),
:meth:`update` (one DQN gradient step). Frozen columns are computed once per update for the
mini-batch states and next states together, without autograd. With the C++ kernels
(:mod:`evodevo.neuromod.kernels`) the loss and its gradients of a progressive column are one
call (``csrc/td_update.h``) for PNN and BIARM alike; ``learned`` modules and the shared-body
baselines use autograd (:meth:`_loss_autograd`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from evodevo.neuromod.columns import Column, ProgressiveNet, huber
from evodevo.neuromod.config import BiarmConfig
from evodevo.neuromod.ewc import EWC
from evodevo.neuromod.flat_params import FlatParams, adam_step, flatten, flatten_adam_state
from evodevo.neuromod.kernels import NO_TENSOR
from evodevo.neuromod.kernels import load as load_kernel
from evodevo.neuromod.lr_modulation import effective_lr
from evodevo.neuromod.modules import Neuromodulators
from evodevo.neuromod.replay import Batch, ReplayBuffer
from evodevo.neuromod.shared_net import HeadView, SharedNet
from evodevo.neuromod.variants import Variant

__all__ = ["BiarmAgent"]


class BiarmAgent:
    """Columns + modules + DQN update for one run.

    Args:
        cfg: the run config.
        variant: which of the six variants.
        obs_dim: ``d_max``.
        seed: run seed (columns from ``derive(seed, 3, i)``, modules from ``derive(seed, 4)``).
    """

    def __init__(self, cfg: BiarmConfig, variant: Variant, obs_dim: int, seed: int) -> None:
        self.cfg = cfg
        self.variant = variant
        self.obs_dim = obs_dim
        self.seed = seed
        self.modules: Neuromodulators | None = None
        ctx_w: list[float] = list(cfg.modules.context_weights)
        lr_w: list[float] = list(cfg.modules.lr_weights)
        # the states the gates read (live, or at rest for lr-only) and those Eq. 3.7 reads
        # (None: the live ones; the resting list for gates-only)
        self._gate_np: np.ndarray | None = None
        self._lr_rest: list[float] | None = None
        if variant.modulated:
            self.modules = Neuromodulators(cfg.modules, obs_dim, seed, variant.ablated)
            ctx_w = self.modules.to_internal(ctx_w).tolist()
            lr_w = self.modules.to_internal(lr_w).tolist()
            self.states_t: torch.Tensor | None = self.modules.state_t
            self._gate_np = self.modules.state_array
            at_rest = np.full_like(self.modules.state_array, cfg.modules.ablated_value)
            if not variant.gates_modulated:
                self._gate_np = at_rest
                self.states_t = torch.from_numpy(at_rest)
            if not variant.lr_modulated:
                self._lr_rest = at_rest.tolist()
        else:
            self.states_t = None
        if cfg.modules.lr_relative:  # eta_base at the resting state (modules.lr_relative)
            rest = cfg.modules.initial_state * sum(cfg.modules.lr_weights)
            lr_w = [w / rest for w in lr_w]
        self._lr_w = lr_w  # Eq. 3.7 weights, internal layout (Python floats: a 4-term sum)
        self.learned = (
            variant.modulated
            and variant.gated
            and variant.gates_modulated
            and cfg.modules.learning == "learned"
        )
        self.net: ProgressiveNet | SharedNet
        if variant.architecture == "shared":
            self.net = SharedNet(obs_dim, cfg.network.hidden, seed)
        elif variant.architecture == "progressive":
            self.net = ProgressiveNet(
                obs_dim=obs_dim,
                hidden=cfg.network.hidden,
                gated=variant.gated,
                adapter_dim=cfg.network.adapter_dim,
                seed=seed,
                context_weights=ctx_w,
                learn_context=cfg.modules.learn_context_weights,
                lateral_kernel=cfg.network.lateral_kernel,
                lateral_init=cfg.network.lateral_init,
                # the single-task reference reads nothing from earlier columns (SPEC §6)
                lateral_scale=cfg.network.lateral_scale if variant.lateral else 0.0,
            )
        else:
            raise ValueError(
                f"variant {variant.name!r} ({variant.architecture}) is not trained by BiarmAgent"
            )
        self.progressive = isinstance(self.net, ProgressiveNet)
        if self.modules is not None and getattr(self.net, "kernel", "torch") == "cpp":
            self.modules.use_kernel(load_kernel())  # the module update in C++ too (kernels)
        self.ewc: EWC | None = None
        if variant.consolidation == "ewc":
            assert isinstance(self.net, SharedNet)
            self.ewc = EWC(list(self.net.shared_parameters()), cfg.ewc.lam)
        self.obs_t = torch.zeros(1, obs_dim)
        self.obs_np = self.obs_t.numpy()[0]
        self._module_step: Callable[[np.ndarray, float], None] | None = None
        if self.modules is not None:  # the per-step update as a closure on the obs row
            self._module_step = self.modules.step_function(self.obs_np, self.obs_t[0])
        self.col = -1
        self.target: Column | HeadView | None = None
        self.optimizer: torch.optim.Optimizer | None = None
        self.params: list[torch.nn.Parameter] = []
        self.flat: FlatParams | None = None
        # (online parameters, target parameters, gradient views) for the C++ TD update
        self._td_cpp: tuple[list[torch.Tensor], list[torch.Tensor], list[torch.Tensor]] | None
        self._td_cpp = None
        self.grad_steps = 0
        # the DQN settings of the task in training (dqn.per_task applied; set by the trainer)
        self.dqn = cfg.dqn

    # ------------------------------------------------------------------ tasks
    def begin_task(self, n_actions: int, lateral_scale: float | None = None) -> None:
        """Freeze earlier columns, add column i, reset novelty, fresh target and Adam.

        ``lateral_scale`` overrides ``network.lateral_scale`` for this column (restoring a
        checkpoint whose columns were built with other scales)."""
        if isinstance(self.net, ProgressiveNet):
            self.net.add_column(n_actions, lateral_scale)
        else:
            self.net.add_column(n_actions)
        self.col = self.net.n_columns - 1
        self.target = self.net.make_target()
        self.params = [p for p in self.net.current.parameters() if p.requires_grad]
        if self.learned and self.col > 0 and self.modules is not None:
            self.params += [p for p in self.modules.parameters() if p.requires_grad]
        # one flat buffer: zeroing, clipping and Adam are one operation each (flat_params)
        self.flat = flatten(self.params)
        # the soft target update's tensor lists, taken after flatten() moved the trainable
        # parameters into the flat buffer (same order: the target is a deep copy)
        self._online_params = [p.detach() for p in self.net.current.parameters()]
        self._target_params = [p.detach() for p in self.target.parameters()]
        self.optimizer = torch.optim.Adam([self.flat.param], lr=self.dqn.lr, fused=True)
        self._group = self.optimizer.param_groups[0]
        self._td_cpp = None
        net = self.net
        cpp = isinstance(net, ProgressiveNet) and net.kernel == "cpp"
        if cpp and not self.learned and self.ewc is None:  # C++ loss + gradients (td_update.h)
            column = net.current
            self._td_cpp = (
                list(column.parameters()),
                list(self.target.parameters()),
                # the views of the flat gradient buffer, in parameter order
                [
                    p.grad if p.requires_grad and p.grad is not None else NO_TENSOR
                    for p in column.parameters()
                ],
            )
        self.grad_steps = 0
        if self.modules is not None:
            self.modules.start_task()

    def end_task(self, buffer: ReplayBuffer) -> None:
        """End of the current task: EWC consolidates its Fisher from ``buffer`` (else no-op).

        The Fisher is averaged over the ``ewc.fisher_samples`` newest states of the task's
        replay buffer (:mod:`evodevo.neuromod.ewc`).
        """
        if self.ewc is None or buffer.size == 0:
            return
        n = min(buffer.size, self.cfg.ewc.fisher_samples)
        idx = (buffer.pos - 1 - np.arange(n)) % buffer.capacity
        states = torch.from_numpy(buffer.data[idx, : buffer.obs_dim].copy())
        self.ewc.consolidate(self.net.current, states, self.cfg.ewc.fisher_chunk)

    def end_training(self) -> None:
        """Freeze everything after the last task."""
        self.net.freeze_all()

    # ------------------------------------------------------------------ per step
    def lr(self) -> float:
        """Eq. 3.7 (modulated variants; divided by its resting value with
        ``modules.lr_relative``) or ``eta_base`` (PNN)."""
        base = self.dqn.lr
        if self.modules is None:
            return base
        states = self._lr_rest if self._lr_rest is not None else self.modules.state_array.tolist()
        return effective_lr(base, states, self._lr_w)

    def gate(self) -> float:
        """Context gate ``sigmoid(sum w_m s_m)`` of the current column (nan without laterals)."""
        net = self.net
        if self.states_t is None or not isinstance(net, ProgressiveNet) or not net.gated:
            return float("nan")
        if self.col < 1:
            return float("nan")
        with torch.no_grad():
            return float(net.current.context(self.states_t))

    def act(self, eps: float, rng: np.random.Generator) -> int:
        """Epsilon-greedy action for the observation already written into ``obs_np``."""
        if rng.random() < eps:
            return int(rng.integers(self.net.current.n_actions))
        net = self.net
        if isinstance(net, ProgressiveNet):  # NumPy forward: batch 1 is per-op overhead
            return int(net.q_np(self.obs_np, self.col, self._gate_np).argmax())
        with torch.no_grad():
            return int(net.q(self.obs_t, self.col, self.states_t).argmax())

    def observe(self, obs: np.ndarray, reward: float) -> None:
        """Module update for one environment step (Eq. 3.1-3.6); no-op for PNN."""
        if self._module_step is not None:
            self._module_step(obs, reward)

    @property
    def fused_update(self) -> bool:
        """True when the TD loss and its gradients come from the C++ kernel (one call)."""
        return self._td_cpp is not None

    def td_loss(self, batch: Batch) -> torch.Tensor:
        """The TD loss of the current column on ``batch`` (SPEC §1.6): from the C++ kernel,
        which also writes every gradient into the flat buffer, when :attr:`fused_update`; else
        from PyTorch, with its autograd graph (call ``backward``)."""
        return self._loss_cpp(batch) if self._td_cpp is not None else self._loss_autograd(batch)

    def update(self, batch: Batch) -> torch.Tensor:
        """One DQN gradient step (SPEC §1.6) at the Eq. 3.7 learning rate; returns the loss."""
        dqn = self.dqn
        column = self.net.current
        target = self.target
        opt = self.optimizer
        flat = self.flat
        assert target is not None and opt is not None and flat is not None
        if self._td_cpp is not None:
            loss = self._loss_cpp(batch)  # writes every gradient into flat.grad
        else:
            loss = self._loss_autograd(batch)
            flat.zero_grad()
            loss.backward()  # accumulates into flat.grad (every .grad is a view of it)
        # gradient-norm clip (what clip_grad_norm_ does), on the one flat gradient
        total = torch.linalg.vector_norm(flat.grad)
        flat.grad.mul_(torch.clamp(dqn.grad_clip / (total + 1e-6), max=1.0))
        lr = self.lr()  # Eq. 3.7 (eta_base for PNN)
        self._group["lr"] = lr  # the one param group of the flat buffer (state_dict shows it)
        adam_step(opt, lr)  # = opt.step(), bit for bit, without its Python dispatch
        if self.learned and self.modules is not None and self.col > 0:
            self.modules.refresh()  # the per-step update's matrices copy the trained weights
        self.grad_steps += 1
        if dqn.target_mode == "soft":  # Polyak: target <- target + tau (online - target)
            torch._foreach_lerp_(self._target_params, self._online_params, dqn.tau)
        elif self.grad_steps % dqn.target_update == 0:
            target.load_state_dict(column.state_dict())
        return loss

    def _loss_cpp(self, batch: Batch) -> torch.Tensor:
        """TD loss of a progressive column with its gradients, in one C++ call."""
        obs, nobs, act, rew, term, _ = batch
        net = self.net
        assert isinstance(net, ProgressiveNet) and self._td_cpp is not None
        online, target, grads = self._td_cpp
        col = self.col
        st = self.states_t
        prev = net.lateral_inputs(torch.cat((obs, nobs)), col, st) if col > 0 else ()
        dqn = self.dqn
        return load_kernel().td_update(  # type: ignore[union-attr]
            obs, nobs, act, rew, term, list(prev), NO_TENSOR if st is None else st,
            online, target, grads, net.gated, dqn.gamma, dqn.huber_delta, dqn.double_q,
        )  # fmt: skip

    def _loss_autograd(self, batch: Batch) -> torch.Tensor:
        """TD loss (Huber on the taken actions, SPEC §1.6) with its autograd graph."""
        obs, nobs, act, rew, term, n_task = batch
        dqn = self.dqn
        col = self.col
        column = self.net.current
        target = self.target
        assert target is not None
        st = self.states_t
        bsz = obs.shape[0]
        if col > 0 and isinstance(self.net, ProgressiveNet):
            assert isinstance(column, Column) and isinstance(target, Column)
            prev = self.net.lateral_inputs(torch.cat((obs, nobs)), col, st)
            st_on = st
            if self.learned:  # per-sample gate from the module networks' batch outputs
                assert self.modules is not None
                st_on = self.modules.batch_targets(obs, rew, n_task)
            q_all = column(obs, column.rows(prev, 0, bsz), st_on)
            with torch.no_grad():
                nprev = column.rows(prev, bsz, 2 * bsz)
                q_tgt = target(nobs, nprev, st)
                q_sel = column(nobs, nprev, st) if dqn.double_q else q_tgt
        else:
            q_all = column(obs)
            with torch.no_grad():
                q_tgt = target(nobs)
                q_sel = column(nobs) if dqn.double_q else q_tgt
        with torch.no_grad():  # double Q: the online column picks, the target evaluates
            if dqn.double_q:
                q_next = q_tgt.gather(1, q_sel.argmax(1, keepdim=True)).squeeze(1)
            else:
                q_next = q_tgt.max(1).values
        q = q_all.gather(1, act.unsqueeze(1)).squeeze(1)
        with torch.no_grad():
            y = rew + dqn.gamma * (1.0 - term) * q_next
        loss = huber(q, y, dqn.huber_delta)
        if self.ewc is not None:
            loss = loss + self.ewc.penalty()
        return loss

    # ------------------------------------------------------------------ evaluation
    def greedy_q(self, x: torch.Tensor, col: int) -> torch.Tensor:
        """Q-values of column ``col`` with the current scalar states (no autograd)."""
        with torch.no_grad():
            return self.net.q(x, col, self.states_t)

    # ------------------------------------------------------------------ checkpoints
    def state(self) -> dict[str, Any]:
        """Everything needed to rebuild the agent between tasks (no optimiser: fresh per task)."""
        out: dict[str, Any] = {
            "net_config": self.net.config_dict(),
            "net": self.net.state_dict(),
            "col": self.col,
        }
        if self.modules is not None:
            out["modules"] = self.modules.state_dict()
            out["modules_extra"] = self.modules.extra_state()
        if self.ewc is not None:
            out["ewc"] = self.ewc.state_dict()
        return out

    def load_state(self, data: dict[str, Any]) -> None:
        """Restore :meth:`state` output into this (freshly built) agent."""
        for a, s in _column_scales(data):
            if isinstance(self.net, ProgressiveNet):
                self.net.add_column(a, s)
            else:
                self.net.add_column(a)
        self.net.load_state_dict(data["net"])
        self.net.freeze_all()
        self.col = int(data["col"])
        if self.modules is not None:
            self.modules.load_state_dict(data["modules"])
            self.modules.load_extra_state(data["modules_extra"])
        if self.ewc is not None:
            self.ewc.load_state_dict(data["ewc"])

    def train_state(self) -> dict[str, Any]:
        """:meth:`state` plus what continuing the current task needs (mid-task checkpoints):
        the target network, Adam's state and the gradient-step counter."""
        assert self.target is not None and self.optimizer is not None
        return {
            **self.state(),
            "target": self.target.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "grad_steps": self.grad_steps,
        }

    def load_train_state(self, data: dict[str, Any]) -> None:
        """Restore :meth:`train_state` output into a freshly built agent, mid-task: earlier
        columns frozen, the last one trainable with its target network and Adam state."""
        for a, s in _column_scales(data):
            self.begin_task(a, s)
        self.net.load_state_dict(data["net"])
        self.net.refresh_frozen()  # the fused caches of the frozen columns hold copies
        if self.modules is not None:
            self.modules.load_state_dict(data["modules"])
            self.modules.load_extra_state(data["modules_extra"])
        if self.ewc is not None:
            self.ewc.load_state_dict(data["ewc"])
        assert self.target is not None and self.optimizer is not None
        self.target.load_state_dict(data["target"])
        assert self.flat is not None
        self.optimizer.load_state_dict(flatten_adam_state(data["optimizer"], self.flat.sizes))
        self._group = self.optimizer.param_groups[0]  # load_state_dict made new group dicts
        self.grad_steps = int(data["grad_steps"])


def _column_scales(data: dict[str, Any]) -> list[tuple[int, float]]:
    """(actions, lateral_scale) of every column of an agent :meth:`~BiarmAgent.state`
    (checkpoints written before ``network.lateral_scale`` existed: 1.0)."""
    cfg = data["net_config"]
    actions = [int(a) for a in cfg["actions"]]
    scales = [float(x) for x in cfg.get("lateral_scales", [1.0] * len(actions))]
    return list(zip(actions, scales, strict=True))
