"""Clearance checks between the rigid parts of an articulated object, on convex collision pieces.

Every link's collision geometry is a set of convex pieces (boxes, cylinders as circumscribed prisms,
convex meshes). Two pieces of different *rigid groups* (links joined by fixed joints form one group)
must be separated; the separating-axis test on convex polytopes decides it exactly (no FCL needed).
The checks run at the rest pose, at the open pose, and along each joint's range with the other joints
at rest and at open.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.data.synth.primitives import box_corners, prism_points


@dataclass(frozen=True)
class Polytope:
    """A convex polytope in its own frame.

    :param points: (n, 3) vertices
    :param normals: (f, 3) distinct face normal directions
    :param edges: (e, 3) distinct edge directions
    """

    points: np.ndarray
    normals: np.ndarray
    edges: np.ndarray


@dataclass(frozen=True)
class Piece:
    """One convex piece of a link: ``local`` is its pose in the link frame."""

    link: str
    group: str
    polytope: Polytope
    local: np.ndarray


@dataclass(frozen=True)
class Overlap:
    """Two links whose pieces are not separated by more than the tolerance in a configuration."""

    config: str
    link_a: str
    link_b: str
    separation: float


_AXES = np.eye(3)


@lru_cache(maxsize=512)
def box_polytope(sx: float, sy: float, sz: float) -> Polytope:
    return Polytope(box_corners((sx, sy, sz)), _AXES, _AXES)


@lru_cache(maxsize=512)
def prism_polytope(r_bottom: float, r_top: float, length: float) -> Polytope:
    """Circumscribed polygonal prism (or frustum) of a circular one, axis local z."""
    return hull_polytope(prism_points(r_bottom, r_top, length))


def hull_polytope(points: np.ndarray) -> Polytope:
    """The convex hull of ``points`` with its distinct face normals and true (non-coplanar) edges."""
    hull = trimesh.convex.convex_hull(np.asarray(points, dtype=float))
    normals = _distinct_directions(hull.face_normals)
    sharp = hull.face_adjacency_angles > 1e-6
    ends = hull.vertices[hull.face_adjacency_edges[sharp]]
    edges = _distinct_directions(ends[:, 1] - ends[:, 0])
    return Polytope(np.asarray(hull.vertices), normals, edges)


def _distinct_directions(vectors: np.ndarray) -> np.ndarray:
    v = np.asarray(vectors, dtype=float)
    v = v[np.linalg.norm(v, axis=1) > 1e-12]
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    # a direction and its opposite give the same separating axis
    flip = (v[:, 0] < -1e-9) | ((np.abs(v[:, 0]) <= 1e-9) & (v[:, 1] < -1e-9)) | (
        (np.abs(v[:, 0]) <= 1e-9) & (np.abs(v[:, 1]) <= 1e-9) & (v[:, 2] < 0))
    v[flip] *= -1
    _, keep = np.unique(np.round(v, 6), axis=0, return_index=True)
    return v[np.sort(keep)]


def separation(a: Polytope, pose_a: np.ndarray, b: Polytope, pose_b: np.ndarray) -> float:
    """Largest gap between the projections of two placed polytopes over the separating axes.

    Positive: separated by at least that distance; zero or negative: touching or overlapping.
    """
    ra, rb = pose_a[:3, :3], pose_b[:3, :3]
    pa = a.points @ ra.T + pose_a[:3, 3]
    pb = b.points @ rb.T + pose_b[:3, 3]
    ea, eb = a.edges @ ra.T, b.edges @ rb.T
    cross = np.cross(ea[:, None, :], eb[None, :, :]).reshape(-1, 3)
    axes = np.concatenate([a.normals @ ra.T, b.normals @ rb.T, cross])
    norms = np.linalg.norm(axes, axis=1)
    axes = axes[norms > 1e-9] / norms[norms > 1e-9, None]
    proj_a, proj_b = pa @ axes.T, pb @ axes.T
    gaps = np.maximum(proj_b.min(0) - proj_a.max(0), proj_a.min(0) - proj_b.max(0))
    return float(gaps.max())


def find_overlaps(pieces: Sequence[Piece], poses: dict[str, np.ndarray], tolerance: float = 0.0,
                  config: str = "") -> list[Overlap]:
    """Pairs of links in different rigid groups whose pieces are not separated by more than ``tolerance``.

    :param pieces: every convex piece of the object
    :param poses: world pose (4x4) of each link
    :param tolerance: required gap in metres (0: touching counts as overlapping)
    :param config: a name for the configuration, copied into the results
    """
    if not pieces:
        return []
    world = [poses[p.link] @ p.local for p in pieces]
    boxes = np.array([_aabb(p.polytope.points, t) for p, t in zip(pieces, world)])  # (n, 2, 3)
    lo, hi = boxes[:, 0] - tolerance, boxes[:, 1] + tolerance
    touching = np.all((lo[:, None, :] <= hi[None, :, :]) & (lo[None, :, :] <= hi[:, None, :]), axis=2)
    groups = np.array([p.group for p in pieces])
    candidates = np.argwhere(np.triu(touching & (groups[:, None] != groups[None, :]), k=1))
    worst: dict[tuple[str, str], float] = {}
    for i, j in candidates:
        gap = separation(pieces[i].polytope, world[i], pieces[j].polytope, world[j])
        if gap <= tolerance:
            key = tuple(sorted((pieces[i].link, pieces[j].link)))
            worst[key] = min(gap, worst.get(key, np.inf))
    return [Overlap(config, a, b, g) for (a, b), g in sorted(worst.items())]


def _aabb(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    world = points @ pose[:3, :3].T + pose[:3, 3]
    return np.stack([world.min(0), world.max(0)])


def check_configurations(joints: Sequence[tuple[str, float, float]], samples: int = 7
                         ) -> list[tuple[str, dict[str, float]]]:
    """Named joint configurations to check: rest, open, and each joint swept with the others at rest/open.

    :param joints: ``(name, rest value, open value)`` of every movable joint
    :param samples: values per sweep, both ends included
    """
    rest = {name: lo for name, lo, _ in joints}
    opened = {name: hi for name, _, hi in joints}
    out, seen = [("rest", rest), ("open", opened)], set()
    seen.update(tuple(sorted(c.items())) for _, c in out)
    for name, lo, hi in joints:
        for base_name, base in (("rest", rest), ("open", opened)):
            for value in np.linspace(lo, hi, samples):
                config = dict(base)
                config[name] = float(value)
                key = tuple(sorted(config.items()))
                if key not in seen:
                    seen.add(key)
                    out.append((f"{name}={value:.3f}, others at {base_name}", config))
    return out


def first_overlap(pieces: Sequence[Piece], link_poses: Callable[[dict[str, float]], dict[str, np.ndarray]],
                  joints: Sequence[tuple[str, float, float]], tolerance: float = 0.0, samples: int = 7
                  ) -> tuple[str, dict[str, float], Overlap] | None:
    """The first configuration of :func:`check_configurations` with an overlap: (name, values, overlap)."""
    for name, config in check_configurations(joints, samples):
        hits = find_overlaps(pieces, link_poses(config), tolerance, name)
        if hits:
            return name, config, min(hits, key=lambda h: h.separation)
    return None


def check_clearance(pieces: Sequence[Piece], link_poses: Callable[[dict[str, float]], dict[str, np.ndarray]],
                    joints: Sequence[tuple[str, float, float]], tolerance: float = 0.0,
                    samples: int = 7) -> list[Overlap]:
    """Every overlap over :func:`check_configurations`.

    :param pieces: the object's convex pieces
    :param link_poses: joint values -> world pose of every link
    :param joints: ``(name, rest value, open value)`` of every movable joint
    """
    out = []
    for name, config in check_configurations(joints, samples):
        out.extend(find_overlaps(pieces, link_poses(config), tolerance, name))
    return out


# ----- adapters ------------------------------------------------------------------------------
def spec_pieces(spec) -> list[Piece]:
    """The convex pieces of an :class:`~spark_bench.data.synth.spec.ObjectSpec` (poses in object coordinates)."""
    groups = spec.rigid_group()
    out = []
    for part in spec.parts:
        for solid in part.solids:
            out.append(Piece(part.name, groups[part.name], solid_polytope(solid), solid.pose))
    return out


def solid_polytope(solid) -> Polytope:
    size = tuple(round(float(v), 9) for v in solid.size)
    if solid.kind == "box":
        return box_polytope(*size)
    if solid.kind == "cylinder":
        return prism_polytope(size[0], size[0], size[1])
    return prism_polytope(*size)


def asset_pieces(asset) -> list[Piece]:
    """The convex pieces of an :class:`~spark_bench.asset.model.ArticulatedAsset`'s collision shapes.

    Links joined by fixed joints share a rigid group. Links without collision shapes are skipped.
    """
    group = {name: name for name in asset.links}
    for joint in asset.topological_joints():
        if joint.type == JointType.FIXED:
            group[joint.child] = group[joint.parent]
    out = []
    for name, link in asset.links.items():
        for shape in link.collisions:
            size = tuple(round(float(v), 9) for v in np.atleast_1d(shape.size))
            if shape.kind == "box":
                poly = box_polytope(*size)
            elif shape.kind == "cylinder":
                poly = prism_polytope(size[0], size[0], size[1])
            else:
                poly = hull_polytope(shape.to_trimesh().vertices)
                out.append(Piece(name, group[name], poly, np.eye(4)))
                continue
            out.append(Piece(name, group[name], poly, np.asarray(shape.origin, dtype=float)))
    return out


def asset_overlaps(asset, tolerance: float = 0.0, samples: int = 7) -> list[Overlap]:
    """:func:`check_clearance` of a loaded asset (rest, open, and every joint's sweep)."""
    joints = [(j.name, j.rest_value, j.open_value) for j in asset.movable_joints()]
    return check_clearance(asset_pieces(asset), asset.link_poses, joints, tolerance, samples)
