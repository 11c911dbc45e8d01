"""Where a compiled MuJoCo model is at its current pose: the box around its geoms (where the renderer aims its
camera, what the checks' strips frame, what a ray cast can possibly hit: :mod:`spark_bench.sim.crossing`) and each
body's pose (the contact rule's paths and cuts: :mod:`spark_bench.sim.phantom`, :mod:`spark_bench.sim.rest_trim`)."""

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


def body_pose(data, body: int) -> np.ndarray:
    """4x4 world pose of body ``body`` at the current pose."""
    out = np.eye(4)
    out[:3, :3] = data.xmat[body].reshape(3, 3)
    out[:3, 3] = data.xpos[body]
    return out
