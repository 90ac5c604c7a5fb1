"""The fixed random CNN encoder and the sensor vector s = [visual(4), proprio(4)] (SPEC §2.2).

Conv(3→16, 8×8, stride 4) → ReLU → Conv(16→32, 4×4, stride 2) → ReLU → AdaptiveAvgPool(2×2)
→ flatten (128) → L2-normalise. The weights are drawn once per run from the run seed with a
``torch.Generator`` (never the global RNG), never trained, saved with the run as ``encoder.pt``
and reloaded for every later evaluation. The evolved projection P (part of the genome) maps the
128 features to the 4 visual sensor values.

>>> enc = Encoder.from_seed(0)
>>> import numpy as np
>>> enc.features(np.zeros((2, 48, 48, 3), np.uint8)).shape
(2, 128)
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from evodevo.errors import CheckpointError
from evodevo.runs import atomic_write_bytes
from evodevo.safe_io import load_torch_tensors
from evodevo.seeding import torch_gen

__all__ = ["Encoder", "ENCODER_KEY", "sensor_vector"]

ENCODER_KEY = 1
"""Key of the encoder's seed stream under the run seed (``torch_gen(seed, ENCODER_KEY)``)."""

_LAYERS = (("conv1", 3, 16, 8, 4), ("conv2", 16, 32, 4, 2))


class Encoder(nn.Module):
    """Fixed random CNN, image (B, 48, 48, 3) uint8 → unit-norm features (B, 128)."""

    def __init__(self, state: dict[str, torch.Tensor]) -> None:
        super().__init__()
        for name, cin, cout, k, _ in _LAYERS:
            w, b = state.get(f"{name}.weight"), state.get(f"{name}.bias")
            if (
                w is None
                or b is None
                or tuple(w.shape) != (cout, cin, k, k)
                or tuple(b.shape) != (cout,)
            ):
                raise CheckpointError(
                    f"encoder weights {name} are missing or have the wrong shape; "
                    "encoder.pt does not belong to this encoder"
                )
            self.register_buffer(f"{name}_weight", w.detach().clone().float())
            self.register_buffer(f"{name}_bias", b.detach().clone().float())
        self.pool = nn.AdaptiveAvgPool2d((2, 2))

    @classmethod
    def from_seed(cls, seed: int) -> Encoder:
        """Draw the weights from ``seed`` (PyTorch's default conv scale: U(±1/sqrt(fan_in)))."""
        gen = torch_gen(seed, ENCODER_KEY)
        state: dict[str, torch.Tensor] = {}
        for name, cin, cout, k, _ in _LAYERS:
            bound = 1.0 / math.sqrt(cin * k * k)
            state[f"{name}.weight"] = (torch.rand((cout, cin, k, k), generator=gen) * 2 - 1) * bound
            state[f"{name}.bias"] = (torch.rand((cout,), generator=gen) * 2 - 1) * bound
        return cls(state)

    def weights(self) -> dict[str, torch.Tensor]:
        """The weights by layer name (what :meth:`save` writes)."""
        out: dict[str, torch.Tensor] = {}
        for name, *_ in _LAYERS:
            out[f"{name}.weight"] = self.get_buffer(f"{name}_weight")
            out[f"{name}.bias"] = self.get_buffer(f"{name}_bias")
        return out

    def save(self, path: str | Path) -> None:
        """Atomically write the weights to ``path`` (``encoder.pt``)."""
        buf = io.BytesIO()
        torch.save({k: v.clone() for k, v in self.weights().items()}, buf)
        atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> Encoder:
        """Load an encoder written by :meth:`save` (PyTorch's weights-only reader: a file
        holding anything but tensors is refused without running code from it)."""
        return cls(load_torch_tensors(path, "encoder", "every GRN run saves its encoder.pt"))

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        """(B, 3, 48, 48) float in [0, 1] → (B, 128) unit-norm features."""
        w = self.weights()
        h = F.relu(F.conv2d(images, w["conv1.weight"], w["conv1.bias"], stride=_LAYERS[0][4]))
        h = F.relu(F.conv2d(h, w["conv2.weight"], w["conv2.bias"], stride=_LAYERS[1][4]))
        h = self.pool(h).flatten(1)
        return F.normalize(h, p=2.0, dim=1)

    def features(self, images: np.ndarray) -> np.ndarray:
        """Encode a batch of uint8 (B, H, W, 3) images in one forward pass."""
        x = torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2).float() / 255.0
        with torch.no_grad():
            return self.forward(x).numpy().astype(np.float64)


def sensor_vector(
    features: np.ndarray | None,
    P: np.ndarray,
    proprio: np.ndarray,
    visual_noise: np.ndarray | None = None,
    blind: bool = False,
) -> np.ndarray:
    """``s = [features P (+ noise), proprio]`` for a batch.

    Args:
        features: encoder output (B, 128), or None when ``blind``.
        P: batched projections (B, 128, n_visual).
        proprio: (B, n_proprio).
        visual_noise: noise (B, n_visual) added to the visual part (zeros/None for clean).
        blind: replace the visual part by zeros (the blind-GRN control).
    """
    n_b, n_visual = proprio.shape[0], P.shape[-1]
    if blind or features is None:
        visual = np.zeros((n_b, n_visual))
    else:
        visual = np.einsum("bf,bfv->bv", features, P)
        if visual_noise is not None:
            visual = visual + visual_noise
    return np.concatenate([visual, proprio.astype(np.float64)], axis=1)
