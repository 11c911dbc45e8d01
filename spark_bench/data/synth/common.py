"""Small helpers shared by the category builders."""

from __future__ import annotations

import re

import numpy as np

from spark_bench.data.synth import palette
from spark_bench.data.synth.handles import HANDLE_STYLES
from spark_bench.data.synth.primitives import RGBA, Solid, box, cylinder
from spark_bench.data.synth.spec import ObjectSpec

X, Y, Z = np.eye(3)


def body_label(category: str) -> str:
    """PartNet-Mobility style label of a category's static body: ``Refrigerator`` -> ``refrigerator_body``."""
    if category == "StorageFurniture":
        return "furniture_body"
    return re.sub(r"(?<!^)(?=[A-Z])", "_", category).lower() + "_body"


def new_object(category: str, semantic: str = "heavy") -> ObjectSpec:
    """An object with an empty body part named ``body``.

    :param semantic: the body's PartNet-Mobility word: ``heavy`` (furniture, appliances), ``free``
        (portable objects) or ``static`` (fixed to a building: doors, windows)
    """
    spec = ObjectSpec(category)
    spec.add("body", body_label(category), [], semantic=semantic)
    return spec


def choice(rng: np.random.Generator, options, weights=None):
    """One of ``options`` (a sequence), optionally weighted."""
    p = None if weights is None else np.asarray(weights, float) / np.sum(weights)
    return options[int(rng.choice(len(options), p=p))]


def handle_style(rng: np.random.Generator, allow=HANDLE_STYLES) -> str:
    weights = {"bar": 4, "square_bar": 2, "loop": 2, "knob": 2, "edge": 1, "recessed": 1}
    options = [s for s in HANDLE_STYLES if s in allow]
    return choice(rng, options, [weights[s] for s in options])


def legs(rng: np.random.Generator, x0: float, x1: float, z0: float, z1: float, height: float, color: RGBA,
         density: float, round_legs: bool | None = None, size: float | None = None) -> list[Solid]:
    """Four legs from the floor (y = 0) to ``height`` inside the rectangle x0..x1, z0..z1."""
    size = size if size is not None else rng.uniform(0.035, 0.06)
    round_legs = bool(rng.integers(2)) if round_legs is None else round_legs
    out = []
    for x in (x0 + 0.5 * size, x1 - 0.5 * size):
        for z in (z0 + 0.5 * size, z1 - 0.5 * size):
            if round_legs:
                out.append(cylinder((x, 0.5 * height, z), 0.5 * size, height, Y, color, density))
            else:
                out.append(box((x - 0.5 * size, 0, z - 0.5 * size), (x + 0.5 * size, height, z + 0.5 * size),
                               color, density))
    return out


def wood_style_colors(rng: np.random.Generator) -> tuple[RGBA, RGBA, RGBA]:
    """(body, fronts, handles) colours of wooden furniture; fronts are sometimes a second colour."""
    body = palette.jitter(rng, palette.WOOD[palette.pick(rng, palette.WOOD)])
    front = body if rng.uniform() < 0.6 else palette.jitter(rng, palette.WOOD[palette.pick(rng, palette.WOOD)])
    return body, front, palette.contrasting(rng, front)


def appliance_colors(rng: np.random.Generator) -> tuple[RGBA, RGBA]:
    """(shell, handle) colours of a white-goods appliance."""
    shell = palette.jitter(rng, palette.APPLIANCE[palette.pick(rng, palette.APPLIANCE)], 0.015)
    return shell, palette.contrasting(rng, shell, {**palette.METAL, "plastic_black": palette.PLASTIC["black"]}, 0.25)
