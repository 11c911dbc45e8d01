"""Where a part's own mesh tells inside from outside: its closed pieces, and which points lie inside them.

PartNet-Mobility meshes are mostly triangle soups (faces wound either way, panels open at their edges), and for
those no test says whether a point lies inside the part's solid; the contact rule then bounds a point's
penetration by its distance to the part's surface (:func:`~spark_bench.sim.phantom.surface_depth`). Many parts,
though, are closed once the duplicated vertices and faces of their OBJ pieces are merged (a bucket's wire handle, a
lever, a knob): for those a ray's parity says where the solid is, and a point that lies in a recess the part's hull
fills (the inside of a wire handle's bend) is not counted as inside the part (conv-11: bucket 100465's handle was
held by rim points up to 2.4 mm from the wire inside the hull of its bend, none inside the wire).
"""

from __future__ import annotations

import numpy as np
import trimesh
from trimesh.ray.ray_triangle import RayMeshIntersector
from trimesh.ray.ray_util import contains_points

from spark_bench.sim.hulls import vertex_components, weld

#: Vertices closer than this (m) are one vertex when the pieces are looked for (the OBJ pieces' shared corners are
#: written once per piece, at the same coordinates).
WELD = 1e-6
#: The ray directions of the parity test: a point is inside a piece when at least two of the three say so (a ray
#: through an edge or a vertex can count a crossing twice or not at all); fixed, so that every run decides alike.
DIRECTIONS = np.array([[0.4395064455, 0.617598629942, 0.652231566745],
                       [-0.7071067812, 0.5, 0.5],
                       [0.2672612419, -0.5345224838, 0.8017837257]])


def closed_pieces(meshes: list[tuple[np.ndarray, np.ndarray]]) -> list[trimesh.Trimesh] | None:
    """The pieces of a part's meshes (in each mesh, the parts sharing no vertex once its vertices within
    :data:`WELD` are merged and its faces listed twice are dropped), when every piece is closed (each edge shared by
    exactly two faces); None when any piece is open: then no point can be told inside or outside the part.

    Each mesh (one visual, one OBJ piece) is welded on its own: two closed pieces that touch along an edge, welded
    together, would share that edge four times and look open.

    :param meshes: ``(vertices, faces)`` per mesh, in one frame
    """
    pieces = []
    for vertices, faces in meshes:
        if len(faces) == 0:
            continue
        mesh = weld(trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces, np.int64), process=False), WELD)
        mesh.update_faces(mesh.unique_faces())
        mesh.remove_unreferenced_vertices()
        if len(mesh.faces) == 0:
            continue
        for piece in vertex_components(mesh):
            if not piece.is_watertight:
                return None
            pieces.append(piece)
    return pieces or None


def inside_pieces(points: np.ndarray, pieces: list[trimesh.Trimesh]) -> np.ndarray:
    """Which of ``points`` lie inside any of the closed ``pieces`` (:func:`closed_pieces`), by a vote of three rays'
    parity per piece (pieces that overlap are tested one by one: one parity over both would say "outside" where
    they overlap)."""
    points = np.asarray(points, float).reshape(-1, 3)
    out = np.zeros(len(points), bool)
    for piece in pieces:
        todo = np.flatnonzero(~out & trimesh.bounds.contains(piece.bounds, points))
        if len(todo) == 0:
            continue
        # trimesh's own triangle intersector, not ``piece.ray``: that is Embree's (single precision) wherever the
        # optional embreex is installed, and the verdicts would then depend on the machine
        rays = RayMeshIntersector(piece)
        votes = sum(contains_points(rays, points[todo], check_direction=d).astype(int) for d in DIRECTIONS)
        out[todo[votes >= 2]] = True
    return out
