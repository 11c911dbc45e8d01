"""Boxes built in code, the building block of the tests' assets: a box mesh by its size and centre or by
its corners, a visual box, a visual box with the same box as a collision primitive, and an L-shaped solid.

Every helper that takes a size and a centre takes them in that order: ``(extents, center)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh

from spark_bench.asset.model import Collision, Visual
from spark_bench.asset.transforms import make_transform

#: The colour :func:`box_visual` paints a box unless told otherwise.
DEFAULT_RGBA = (0.6, 0.5, 0.4, 1.0)


def box_mesh(extents: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    """An axis-aligned box mesh.

    :param extents: its size along x, y, z
    :param center: where its centre lies
    """
    return trimesh.creation.box(extents=extents, transform=make_transform(translation=center))


def box_between(lo: Sequence[float], hi: Sequence[float],
                to_world: np.ndarray | None = None) -> trimesh.Trimesh:
    """The box mesh spanning the corners ``lo`` and ``hi``, optionally turned into another frame.

    :param lo: its lowest corner
    :param hi: its highest corner
    :param to_world: a 3x3 rotation applied to the box after it is built (None: the box stays where it is)
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation((lo + hi) / 2)
    if to_world is not None:
        box.apply_transform(np.block([[to_world, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]))
    return box


def box_visual(extents: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0),
               rgba: Sequence[float] = DEFAULT_RGBA) -> Visual:
    """A visual box (:func:`box_mesh`) painted ``rgba``.

    :param extents: its size along x, y, z
    :param center: where its centre lies
    :param rgba: its colour
    """
    return Visual(mesh=box_mesh(extents, center), rgba=rgba)


def box_part(extents: Sequence[float], center: Sequence[float],
             rgba: Sequence[float] = DEFAULT_RGBA) -> tuple[Visual, Collision]:
    """A visual box and the same box as a given collision primitive (used as it is by the simulation: no
    erosion, no relief cut, so the hulls are exactly what the test says).

    :param extents: its size along x, y, z
    :param center: where its centre lies
    :param rgba: the visual's colour
    """
    return (box_visual(extents, center, rgba),
            Collision("box", make_transform(translation=center), np.asarray(extents, float)))


def l_shape() -> trimesh.Trimesh:
    """A closed L-shaped solid (two boxes unioned): non-convex, 0.2 m arms along +x and +y from the origin."""
    along_x = box_mesh((0.2, 0.05, 0.05), (0.1, 0.025, 0.025))
    return along_x.union(box_mesh((0.05, 0.2, 0.05), (0.025, 0.1, 0.025)))


def v_shape() -> trimesh.Trimesh:
    """A closed V-shaped solid (two 0.2 m arms at +-30 degrees from +x, unioned): non-convex, and not an
    orthogonal polyhedron, so it goes to CoACD rather than being cut into exact boxes."""
    arms = []
    for degrees in (30.0, -30.0):
        arm = box_mesh((0.2, 0.05, 0.05), (0.1, 0.0, 0.025))
        arm.apply_transform(trimesh.transformations.rotation_matrix(np.radians(degrees), (0.0, 0.0, 1.0)))
        arms.append(arm)
    return arms[0].union(arms[1])
