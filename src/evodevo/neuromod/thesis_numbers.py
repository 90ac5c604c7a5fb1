"""The thesis' reported numbers (Chapter 3, Tables 3.2-3.5), printed beside ours (SPEC §6).

Copied from ``reference/thesis.txt``; values are (mean, std) over the thesis' runs.
Retention in Table 3.5 is a fraction (1.0 = 100 %).
"""

from __future__ import annotations

__all__ = ["TABLE_3_2", "TABLE_3_3_MS", "TABLE_3_4", "TABLE_3_5"]

#: Table 3.2: final return of baseline PNN and BIARM, (mean, std).
TABLE_3_2: dict[str, dict[str, tuple[float, float]]] = {
    "CartPole-v1": {"pnn": (491.00, 11.94), "biarm": (500.00, 0.00)},
    "Acrobot-v1": {"pnn": (-94.50, 24.96), "biarm": (-93.50, 18.91)},
    "MountainCar-v0": {"pnn": (-165.90, 46.31), "biarm": (-119.80, 28.02)},
    "LunarLander-v3": {"pnn": (-417.17, 412.62), "biarm": (233.37, 34.38)},
}

#: Table 3.3: time per training step in milliseconds (baseline, BIARM).
TABLE_3_3_MS: dict[str, tuple[float, float]] = {
    "CartPole-v1": (0.45, 0.68),
    "Acrobot-v1": (0.52, 0.89),
    "MountainCar-v0": (0.41, 0.71),
    "LunarLander-v3": (0.63, 1.18),
}

#: Table 3.4: ablations, final return (mean, std) per variant.
TABLE_3_4: dict[str, dict[str, tuple[float, float]]] = {
    "CartPole-v1": {
        "biarm": (500.00, 0.00),
        "no-da": (195.77, 148.93),
        "no-5ht": (173.29, 198.46),
        "no-ne": (233.33, 212.19),
        "no-ach": (247.78, 210.25),
    },
    "Acrobot-v1": {
        "biarm": (-93.50, 18.91),
        "no-da": (-109.82, 20.67),
        "no-5ht": (-110.78, 21.01),
        "no-ne": (-110.27, 24.56),
        "no-ach": (-106.48, 22.55),
    },
    "MountainCar-v0": {
        "biarm": (-119.80, 28.02),
        "no-da": (-125.90, 32.98),
        "no-5ht": (-126.26, 26.96),
        "no-ne": (-139.63, 31.10),
        "no-ach": (-133.39, 29.71),
    },
    "LunarLander-v3": {
        "biarm": (233.37, 34.38),
        "no-da": (-18.63, 190.72),
        "no-5ht": (218.15, 97.80),
        "no-ne": (202.99, 135.61),
        "no-ach": (-39.61, 152.67),
    },
}

#: Table 3.5: initial (mean, std), final (mean, std), retention fraction.
TABLE_3_5: dict[str, dict[str, tuple[tuple[float, float], tuple[float, float], float]]] = {
    "CartPole-v1": {
        "biarm": ((500.00, 0.00), (500.00, 0.00), 1.0),
        "pnn": ((496.20, 5.31), (491.00, 11.94), 0.9895),
    },
    "Acrobot-v1": {
        "biarm": ((-88.20, 3.84), (-93.50, 18.91), 0.943),
        "pnn": ((-86.80, 10.71), (-94.50, 24.96), 0.9185),
    },
    "MountainCar-v0": {
        "biarm": ((-117.20, 29.84), (-119.80, 28.02), 0.9782),
        "pnn": ((-150.60, 49.33), (-165.90, 46.31), 0.9078),
    },
    "LunarLander-v3": {
        "biarm": ((233.37, 34.38), (233.37, 34.38), 1.0),
        "pnn": ((-380.88, 346.54), (-417.17, 412.62), 0.9130),
    },
}
