"""The box around a compiled MuJoCo model's geoms at its current pose: where the renderer aims its camera, what
the checks' strips frame, and what a ray cast can possibly hit (:mod:`spark_bench.sim.crossing`)."""

from __future__ import annotations

import numpy as np


def model_bounds(model, data, group: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """World bounding box of the geoms (of ``group``) at the current pose, from their bounding boxes."""
    lows, highs = [], []
    for g in range(model.ngeom):
        if group is not None and model.geom_group[g] != group:
            continue
        center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        rotation = data.geom_xmat[g].reshape(3, 3)
        world_center = data.geom_xpos[g] + rotation @ center
        world_half = np.abs(rotation) @ half
        lows.append(world_center - world_half)
        highs.append(world_center + world_half)
    if not lows:
        return np.zeros(3) - 0.5, np.zeros(3) + 0.5
    return np.min(lows, axis=0), np.max(highs, axis=0)
