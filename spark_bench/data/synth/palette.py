"""Colour palettes and densities of the materials generated objects are made of.

Colours are sampled per object (a palette entry) and jittered per part, so two fronts of one cabinet
differ slightly, as real renders do; handles and knobs take a colour that contrasts with what they sit on.
"""

from __future__ import annotations

import numpy as np

from spark_bench.data.synth.primitives import RGBA

WOOD = {
    "oak": (0.72, 0.55, 0.36), "walnut": (0.42, 0.28, 0.18), "birch": (0.84, 0.73, 0.55),
    "cherry": (0.58, 0.32, 0.2), "white": (0.92, 0.91, 0.88), "grey": (0.55, 0.56, 0.58),
    "black": (0.14, 0.14, 0.15), "sage": (0.56, 0.63, 0.53), "navy": (0.2, 0.27, 0.4),
}
METAL = {
    "steel": (0.72, 0.73, 0.75), "chrome": (0.86, 0.87, 0.89), "black": (0.09, 0.09, 0.1),
    "brass": (0.78, 0.63, 0.32), "bronze": (0.45, 0.33, 0.22), "graphite": (0.3, 0.31, 0.33),
}
PLASTIC = {
    "black": (0.1, 0.1, 0.11), "white": (0.93, 0.93, 0.92), "grey": (0.5, 0.51, 0.53),
    "red": (0.75, 0.15, 0.13), "blue": (0.17, 0.33, 0.65), "green": (0.2, 0.5, 0.3),
    "yellow": (0.9, 0.75, 0.15), "teal": (0.1, 0.5, 0.52),
}
APPLIANCE = {
    "white": (0.94, 0.94, 0.93), "steel": (0.7, 0.71, 0.72), "black": (0.12, 0.12, 0.13),
    "cream": (0.9, 0.87, 0.78), "silver": (0.8, 0.8, 0.82), "red": (0.68, 0.12, 0.1),
}
CERAMIC = {"white": (0.96, 0.96, 0.95), "bone": (0.92, 0.9, 0.84), "grey": (0.75, 0.76, 0.77)}
GLASS: RGBA = (0.13, 0.17, 0.2, 1.0)
DARK: RGBA = (0.06, 0.06, 0.07, 1.0)

# kg/m^3; appliance shells and foam-filled doors are modelled as solid slabs, hence low densities
DENSITY = {"wood": 650.0, "metal": 2700.0, "plastic": 950.0, "appliance": 350.0, "glass": 2500.0,
           "ceramic": 2300.0, "rubber": 1100.0}


def rgba(rgb, alpha: float = 1.0) -> RGBA:
    return (round(float(rgb[0]), 4), round(float(rgb[1]), 4), round(float(rgb[2]), 4), alpha)


def pick(rng: np.random.Generator, table: dict, exclude: tuple[str, ...] = ()) -> str:
    """A random entry name of a palette table."""
    names = [n for n in table if n not in exclude]
    return names[int(rng.integers(len(names)))]


def jitter(rng: np.random.Generator, rgb, amount: float = 0.03) -> RGBA:
    """``rgb`` with a small random change per channel (clipped to [0, 1])."""
    return rgba(np.clip(np.asarray(rgb[:3]) + rng.uniform(-amount, amount, 3), 0.0, 1.0))


def luminance(rgb) -> float:
    return float(0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2])


def contrasting(rng: np.random.Generator, base, table: dict = METAL, min_difference: float = 0.3) -> RGBA:
    """A colour of ``table`` whose luminance differs from ``base`` by at least ``min_difference``."""
    names = [n for n, c in table.items() if abs(luminance(c) - luminance(base)) >= min_difference]
    if not names:  # no entry contrasts enough: take the farthest one
        names = [max(table, key=lambda n: abs(luminance(table[n]) - luminance(base)))]
    return jitter(rng, table[names[int(rng.integers(len(names)))]], 0.02)
