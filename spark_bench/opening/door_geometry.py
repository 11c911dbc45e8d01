"""What the scripted opener reads of a rotational part's shape at rest: whether it swings about a hinge at
its side (a door, a lid) or turns in place about an axis through itself (a cap, a dial), and a door's free
edge and inside face, where the hand pushes a door that slipped out of the fingers open from inside
(:class:`spark_bench.opening.opener.ScriptedOpener`). Plain arrays in, plain values out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.asset.transforms import unit

#: Surface points within this distance (m) of the grasp's height along the hinge define the door's free edge and
#: its inside face there (:func:`door_edge`); the inside face is read within :data:`EDGE_BAND` (m) of the edge.
HEIGHT_BAND = 0.1
EDGE_BAND = 0.1
#: A part swings like a door (:mod:`spark_bench.opening.opener`: a door's guarded re-grasp, the push from inside)
#: when it hangs on one side of its axis: the centroid of its surface, across the axis, lies at least this
#: fraction of the grasp's distance from the axis (a door's is about half). A part around its axis (a bottle's cap, a dial, a wheel)
#: turns in place: its re-grasp is a drawer's, in front of the grasp at once (backing out and waiting as for a
#: door lost shared bottle 3763's cap on 4 of 5 seeds).
SIDE_HUNG = 0.25


@dataclass
class DoorEdge:
    """A door's free edge at the grasp's height, world frame at rest, as the push from inside needs it.

    :param point: on the free edge, at the grasp point's height along the hinge and its level along ``outward``
    :param depth: how far (m) behind the grasp point (against ``outward``) the door's inside face lies near
        its free edge
    """

    point: np.ndarray
    depth: float


def door_edge(points: np.ndarray, grasp, outward, axis, pivot) -> DoorEdge | None:
    """The free edge of a door (:class:`DoorEdge`) from its surface at rest and a planned hinge: the point
    farthest from the hinge, in the direction from the hinge to the grasp, among the surface points within
    :data:`HEIGHT_BAND` of the grasp's height; None when there are none or the door has no thickness there.

    :param points: points on the part's surface, world frame at rest
    :param grasp: the grasp point at rest
    :param outward: the part's outward direction at rest
    :param axis: the planned hinge's direction
    :param pivot: a point on the planned hinge
    """
    points = np.asarray(points, float).reshape(-1, 3)
    grasp, n, axis = np.asarray(grasp, float), unit(outward), unit(axis)
    radial = grasp - np.asarray(pivot, float)
    radial = radial - (radial @ axis) * axis
    if len(points) == 0 or np.linalg.norm(radial) < 1e-6:
        return None
    u = unit(radial)
    rel = points - grasp
    band = np.abs(rel @ axis) < HEIGHT_BAND
    if not band.any():
        return None
    r, h = rel[band] @ u, rel[band] @ n
    reach = float(r.max())
    depth = -float(h[r > reach - EDGE_BAND].min())
    if depth <= 0:
        return None
    return DoorEdge(point=grasp + reach * u, depth=depth)


def turns_in_place(points: np.ndarray, grasp, axis, pivot) -> bool:
    """Whether a rotational part turns in place about an axis through itself (a cap, a dial, a wheel)
    rather than swinging about a hinge at its side (a door, a lid): the centroid of its surface, across the
    axis, lies nearer the axis than :data:`SIDE_HUNG` of the grasp's distance from it.

    :param points: points on the part's surface, world frame at rest
    :param grasp: the grasp point at rest
    :param axis: the planned axis's direction
    :param pivot: a point on the planned axis
    """
    points = np.asarray(points, float).reshape(-1, 3)
    axis, pivot = unit(axis), np.asarray(pivot, float)

    def across(v: np.ndarray) -> float:
        return float(np.linalg.norm(v - (v @ axis) * axis))

    reach = across(np.asarray(grasp, float) - pivot)
    if len(points) == 0 or reach < 1e-9:
        return False
    return across(points.mean(axis=0) - pivot) < SIDE_HUNG * reach
