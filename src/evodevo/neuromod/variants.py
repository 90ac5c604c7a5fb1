"""The variants of Chapter 3 and the continual-learning baselines, as settings (SPEC §1.2, §1.5).

A variant says which network learns the task sequence (``architecture``), whether laterals
are gated (BIARM) or plain (PNN), whether the modules run and modulate the learning rate,
which modules are ablated (held at 0.5), and whether a consolidation penalty protects earlier
tasks (``consolidation``). Every variant except ``sb3-dqn`` runs through the same training
loop (:mod:`evodevo.neuromod.trainer`); ``sb3-dqn`` is Stable-Baselines3's own DQN, one fresh
model per task (:mod:`evodevo.baselines.sb3_dqn_tasks`), the "what a standard library gets"
reference.

* ``progressive``: one column per task, earlier columns frozen (SPEC §1.2).
* ``shared``: ONE 2x128 ReLU body on the padded input (Eq. 3.10) and one linear Q-head per
  task (:mod:`evodevo.neuromod.shared_net`); the body keeps learning through the sequence
  (``finetune``), optionally held near each earlier task's optimum by EWC (Eq. 2.4,
  :mod:`evodevo.neuromod.ewc`).
* ``sb3``: a single-task SB3 DQN per task.
* ``clamped``: BIARM with all four states held at rest (every module ablated, SPEC §1.5):
  gated laterals whose context gate and learning rate stay at their resting values -- the
  control that separates modulation from BIARM's architecture and resting learning rate.
* ``lr-only`` and ``gates-only``: BIARM with one of the two paths of modulation held at rest
  (E2's follow-up arms): ``lr-only`` modulates the learning rate (Eq. 3.7) while every gate
  reads the resting states; ``gates-only`` modulates the gates (Eq. 3.8) while Eq. 3.7 reads the
  resting states. The modules run in both. With ``modules.learning: learned`` the module
  networks of ``lr-only`` get no gradient (their only path to the loss is the gate).
* ``single``: progressive columns that never read each other (``lateral=False``): the
  single-task reference per task that forward transfer is measured against (SPEC §6).

>>> VARIANTS["no-da"].ablated
('DA',)
>>> get_variant("pnn").modulated
False
>>> get_variant("ewc").consolidation
'ewc'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from evodevo.errors import EvodevoError
from evodevo.neuromod.config import MODULE_NAMES

__all__ = ["Variant", "VARIANTS", "CONTINUAL_BASELINES", "get_variant"]

Architecture = Literal["progressive", "shared", "sb3"]


@dataclass(frozen=True)
class Variant:
    """One row of Tables 3.2 / 3.4 / 3.5 (and the continual baselines).

    Attributes:
        name: CLI name.
        gated: BIARM gated laterals ``U (alpha * V h)``; else PNN laterals ``U h``.
        modulated: neuromodulator modules run and drive Eq. 3.7 and the context gate.
        ablated: modules held at ``modules.ablated_value`` (SPEC §1.5).
        architecture: ``progressive`` columns, one ``shared`` body with per-task heads, or
            an ``sb3`` DQN per task.
        consolidation: ``ewc`` adds the Eq. 2.4 penalty on the shared body; ``none`` is
            plain fine-tuning.
        lr_modulated: with ``modulated``, Eq. 3.7 reads the live states; ``False``: the
            resting states (``modules.ablated_value``), as ``clamped`` does.
        gates_modulated: with ``modulated``, the gates (Eq. 3.8) read the live states;
            ``False``: the resting states.
        lateral: a new column reads the earlier ones (PNN, BIARM); ``False`` is the
            single-task reference of SPEC §6 (``single``): the PNN code with every lateral
            input scaled by 0, so each task's column learns alone -- with the same seeds,
            episodes, initial weights and protocol as the PNN column it is the reference of.
    """

    name: str
    gated: bool
    modulated: bool
    ablated: tuple[str, ...] = ()
    architecture: Architecture = "progressive"
    consolidation: Literal["none", "ewc"] = "none"
    lateral: bool = True
    lr_modulated: bool = True
    gates_modulated: bool = True


VARIANTS: dict[str, Variant] = {
    "biarm": Variant("biarm", True, True),
    "pnn": Variant("pnn", False, False),
    "no-da": Variant("no-da", True, True, ("DA",)),
    "no-5ht": Variant("no-5ht", True, True, ("5HT",)),
    "no-ne": Variant("no-ne", True, True, ("NE",)),
    "no-ach": Variant("no-ach", True, True, ("ACh",)),
    "clamped": Variant("clamped", True, True, MODULE_NAMES),
    "lr-only": Variant("lr-only", True, True, gates_modulated=False),
    "gates-only": Variant("gates-only", True, True, lr_modulated=False),
    "finetune": Variant("finetune", False, False, architecture="shared"),
    "ewc": Variant("ewc", False, False, architecture="shared", consolidation="ewc"),
    "sb3-dqn": Variant("sb3-dqn", False, False, architecture="sb3"),
    "single": Variant("single", False, False, lateral=False),
}

#: The continual-learning baselines, in table order.
CONTINUAL_BASELINES: tuple[str, ...] = ("finetune", "ewc", "sb3-dqn")


def get_variant(name: str) -> Variant:
    """The :class:`Variant` called ``name``, or an :class:`EvodevoError` listing the choices."""
    try:
        return VARIANTS[name]
    except KeyError:
        raise EvodevoError(
            f"unknown variant {name!r}; choose one of {', '.join(VARIANTS)}"
        ) from None
