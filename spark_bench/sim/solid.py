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

from dataclasses import dataclass

import numpy as np
import trimesh

from spark_bench.asset.mesh import vertex_components, weld
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.crossing import surface_model

#: Vertices closer than this (m) are one vertex when the pieces are looked for (the OBJ pieces' shared corners are
#: written once per piece, at the same coordinates).
WELD = 1e-6
#: The ray directions of the parity test: a point is inside a piece when at least two of the three say so (a ray
#: through an edge or a vertex can count a crossing twice or not at all); fixed, so that every run decides alike.
DIRECTIONS = np.array([[0.4395064455, 0.617598629942, 0.652231566745],
                       [-0.7071067812, 0.5, 0.5],
                       [0.2672612419, -0.5345224838, 0.8017837257]])
#: Surfaces counted along one ray at most (a ray along a seam could otherwise meet the same point again and again).
MAX_HITS = 256


@dataclass
class Solid:
    """A part's closed pieces as MuJoCo mesh geoms (one per piece, in the part's frame), for :func:`inside_pieces`.

    :param model: the compiled model (:func:`~spark_bench.sim.crossing.surface_model`)
    :param data: its data
    :param lower: ``(pieces, 3)`` each piece's box
    :param upper: ``(pieces, 3)``
    """

    model: object
    data: object
    lower: np.ndarray
    upper: np.ndarray


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


def closed_solid(meshes: list[tuple[np.ndarray, np.ndarray]]) -> Solid | None:
    """:func:`closed_pieces` of ``meshes`` made ready for :func:`inside_pieces`; None where the part is not closed, or
    where MuJoCo refuses a piece (the depth is then bounded as for a soup)."""
    pieces = closed_pieces(meshes)
    if pieces is None:
        return None
    try:
        model, data = surface_model([(piece.vertices, piece.faces) for piece in pieces])
    except ValueError:
        return None
    return Solid(model, data, np.array([piece.bounds[0] for piece in pieces]),
                 np.array([piece.bounds[1] for piece in pieces]))


def _crossings(solid: Solid, geom: int, start: np.ndarray, ray: np.ndarray) -> int:
    """How many surfaces of piece ``geom`` the segment ``start`` -> ``start + ray`` crosses (MuJoCo's ray-mesh test,
    which meets a triangle from either side)."""
    mujoco = mujoco_module()
    count, offset = 0, 0.0
    while count < MAX_HITS:
        hit = mujoco.mj_rayMesh(solid.model, solid.data, geom, start + offset * ray, ray * (1.0 - offset))
        if not 0.0 <= hit <= 1.0:
            return count
        count += 1
        offset += hit * (1.0 - offset) + 1e-9
        if offset >= 1.0:
            return count
    return count


def inside_pieces(points: np.ndarray, solid: Solid) -> np.ndarray:
    """Which of ``points`` lie inside any piece of ``solid`` (:func:`closed_solid`), by a vote of three rays' parity
    per piece (pieces that overlap are tested one by one: one parity over both would say "outside" where they
    overlap). The third ray is cast only where the first two disagree."""
    points = np.asarray(points, float).reshape(-1, 3)
    out = np.zeros(len(points), bool)
    for geom, (lower, upper) in enumerate(zip(solid.lower, solid.upper)):
        reach = 2.0 * float(np.linalg.norm(upper - lower)) + 1e-6
        for index in np.flatnonzero(~out & np.all((points >= lower) & (points <= upper), axis=1)):
            votes = [_crossings(solid, geom, points[index], reach * d) % 2 for d in DIRECTIONS[:2]]
            if votes[0] != votes[1]:
                votes.append(_crossings(solid, geom, points[index], reach * DIRECTIONS[2]) % 2)
            out[index] = sum(votes) >= 2
    return out
