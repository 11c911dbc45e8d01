"""Collision hulls as PhysX takes them: at most :data:`MAX_VERTICES` vertices and :data:`MAX_POLYGONS` polygons a
convex mesh (PhysX's cooking limits; SAPIEN cooks with ``vertexLimit = 255``, and a hull over it is silently
made another shape).

A hull over either limit is split in two by the plane through its centroid across its longest extent, and each
half again until every piece is within both (:func:`split_for_physx`): the pieces are convex, cover exactly the
hull (a plane cut of a convex hull is convex: :func:`~spark_bench.sim.relief.cut_hull`) and add no volume, where
simplifying would move the surface. Boxes and spheres are PhysX primitives; a cylinder becomes the 24-sided prism
MuJoCo's mesh of it has (PhysX has no cylinder primitive of its own).

Pure geometry: importing this module does not import SAPIEN, so the URDF and USD exports
(:mod:`spark_bench.sim.export`) split their hulls with it on a machine without SAPIEN (:func:`piece_names` names
the pieces).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from spark_bench.sim.relief import cut_hull
from spark_bench.sim.shapes import CollisionShape

#: PhysX's limit on the vertices of a cooked convex mesh.
MAX_VERTICES = 255
#: PhysX's limit on the polygons (coplanar faces merged) of a cooked convex mesh.
MAX_POLYGONS = 255
#: Splits of one hull at most (a piece still over a limit after that many is an error of the hull).
MAX_DEPTH = 8


@dataclass
class HullLimits:
    """What PhysX's hull limits did to an object's hulls.

    :param hulls: hulls given to PhysX (after splitting)
    :param split: per link, the hulls that were over a limit, as ``"k: V vertices, P polygons -> n pieces"``
    :param largest: the most vertices and polygons of a hull given to PhysX
    """

    hulls: int = 0
    split: dict[str, list[str]] = field(default_factory=dict)
    largest: tuple[int, int] = (0, 0)

    @property
    def n_split(self) -> int:
        """Hulls that were over a limit (each split into pieces)."""
        return sum(len(found) for found in self.split.values())

    def to_dict(self) -> dict:
        return {"hulls": self.hulls, "split": self.split, "largest_vertices": self.largest[0],
                "largest_polygons": self.largest[1]}


def polygon_count(vertices: np.ndarray, faces: np.ndarray) -> int:
    """Polygons of a convex mesh as PhysX counts them: coplanar adjacent triangles merged into one."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    facets = mesh.facets
    in_facets = int(sum(len(f) for f in facets))
    return len(facets) + len(mesh.faces) - in_facets


def hull_size(shape: CollisionShape) -> tuple[int, int]:
    """``(vertices, polygons)`` of a mesh hull's convex hull (a primitive counts as ``(0, 0)``)."""
    if shape.kind != "mesh":
        return 0, 0
    hull = trimesh.convex.convex_hull(np.asarray(shape.vertices, float))
    return len(hull.vertices), polygon_count(hull.vertices, hull.faces)


def within_limits(size: tuple[int, int]) -> bool:
    return size[0] <= MAX_VERTICES and size[1] <= MAX_POLYGONS


def _halves(shape: CollisionShape) -> list[CollisionShape]:
    """``shape`` cut in two by the plane through its vertices' centroid across their longest principal axis."""
    points = np.asarray(shape.vertices, float)
    centre = points.mean(axis=0)
    _, _, axes = np.linalg.svd(points - centre, full_matrices=False)
    normal = axes[0]
    offset = float(normal @ centre)
    out = []
    for n, d in ((normal, offset), (-normal, -offset)):
        piece = cut_hull(shape, n, d)
        out.append(shape if piece is None else piece[0])
    return out


def split_for_physx(shape: CollisionShape, depth: int = 0, size: tuple[int, int] | None = None) -> list[CollisionShape]:
    """``shape`` as pieces within PhysX's limits (itself when it is; a primitive is left as it is).

    :param size: its :func:`hull_size`, where the caller has it already
    :raises ValueError: a piece is still over a limit after :data:`MAX_DEPTH` splits
    """
    if shape.kind != "mesh":
        return [shape]
    size = hull_size(shape) if size is None else size
    if within_limits(size):
        return [shape]
    if depth >= MAX_DEPTH:
        raise ValueError(f"a hull is still over PhysX's limits after {MAX_DEPTH} splits: {size}")
    return [piece for half in _halves(shape) for piece in split_for_physx(half, depth + 1)]


def physx_shapes(shapes: dict[str, list[CollisionShape]]) -> tuple[dict[str, list[tuple[int, CollisionShape]]],
                                                                    HullLimits]:
    """Every link's hulls as PhysX takes them: ``{link: [(index of the hull it came from, piece), ...]}`` and
    what was split.

    :param shapes: the prepared collision shapes per link (:attr:`PreparedObject.shapes`)
    """
    report = HullLimits()
    out: dict[str, list[tuple[int, CollisionShape]]] = {}
    largest = [0, 0]
    for link, link_shapes in shapes.items():
        pieces = []
        for index, shape in enumerate(link_shapes):
            size = hull_size(shape)
            parts = split_for_physx(shape, size=size)
            if len(parts) > 1:
                report.split.setdefault(link, []).append(
                    f"{index}: {size[0]} vertices, {size[1]} polygons -> {len(parts)} pieces")
                sizes = [hull_size(p) for p in parts]
            else:
                sizes = [size]
            for size in sizes:
                largest = [max(largest[0], size[0]), max(largest[1], size[1])]
            pieces += [(index, part) for part in parts]
        out[link] = pieces
        report.hulls += len(pieces)
    report.largest = (largest[0], largest[1])
    return out, report


def piece_names(pieces: list[tuple[int, CollisionShape]]) -> list[str]:
    """A name for each of one link's hulls as PhysX takes them (:func:`physx_shapes`' list for the link): ``k`` for
    hull ``k`` kept whole (the name of the MJCF's hull, whose file it shares), ``k_j`` for piece ``j`` of a split
    hull ``k``."""
    counts = Counter(index for index, _ in pieces)
    seen: Counter = Counter()
    out = []
    for index, _ in pieces:
        if counts[index] == 1:
            out.append(str(index))
        else:
            out.append(f"{index}_{seen[index]}")
            seen[index] += 1
    return out


def _outside(points: np.ndarray, hull_points: np.ndarray) -> float:
    """How far the farthest of ``points`` lies outside the convex hull of ``hull_points`` (m, 0 when inside)."""
    try:
        planes = ConvexHull(hull_points).equations  # unit outward normals: n . x + d <= 0 inside
    except QhullError:  # a flat hull: nothing to measure against
        return 0.0
    return float(max(0.0, np.max(points @ planes[:, :3].T + planes[:, 3])))


def cooked_deviation(given: np.ndarray, cooked: np.ndarray) -> float:
    """How far a cooked hull's surface moved from the hull it was cooked from (m): the farthest vertex of either
    outside the other (PhysX's cooking merges near-coplanar faces and drops the vertices between them)."""
    given, cooked = np.asarray(given, float), np.asarray(cooked, float)
    return max(_outside(given, cooked), _outside(cooked, given))
