"""The image encoder of the SB3 baselines on the Kuka image (SPEC §4, thesis Table 4.1).

It lives apart from :mod:`evodevo.baselines.sb3_kuka` so that the SB3 file reader
(:mod:`evodevo.baselines.sb3_files`) can name it among the classes a saved policy may use.

>>> import gymnasium as gym, numpy as np, torch
>>> space = gym.spaces.Box(0, 255, (3, 48, 48), np.uint8)
>>> KukaCnn(space, [16, 32], 64)(torch.zeros(2, 3, 48, 48)).shape
torch.Size([2, 64])
"""

from __future__ import annotations

import gymnasium as gym
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

__all__ = ["KukaCnn"]

_KERNELS = ((8, 4), (4, 2), (3, 1))
"""(kernel, stride) of the first, second and third conv (Table 4.1)."""


class KukaCnn(BaseFeaturesExtractor):
    """Table 4.1's image encoder: convs (kernels 8/4/3, strides 4/2/1) → ReLU → linear → ReLU.

    Args:
        observation_space: channel-first image space (SB3 transposes the env's HWC images).
        channels: output channels of each conv (1 to 3 layers).
        features_dim: size of the linear layer.
    """

    def __init__(
        self, observation_space: gym.spaces.Box, channels: list[int], features_dim: int
    ) -> None:
        super().__init__(observation_space, features_dim)
        layers: list[nn.Module] = []
        cin = int(observation_space.shape[0])
        for cout, (k, s) in zip(channels, _KERNELS, strict=False):
            layers += [nn.Conv2d(cin, cout, k, stride=s), nn.ReLU()]
            cin = cout
        self.cnn = nn.Sequential(*layers, nn.Flatten())
        with torch.no_grad():
            n_flat = self.cnn(torch.zeros(1, *observation_space.shape)).shape[1]
        self.linear = nn.Sequential(nn.Linear(n_flat, features_dim), nn.ReLU())

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        return self.linear(self.cnn(observations))  # type: ignore[no-any-return]
