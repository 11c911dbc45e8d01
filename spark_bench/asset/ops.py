"""Whole-asset operations: uniform scaling, translation, and the benchmark-frame normalization."""

from __future__ import annotations

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset


def scale_asset(asset: ArticulatedAsset, scale: float, copy: bool = True) -> ArticulatedAsset:
    """``asset`` uniformly scaled by ``scale`` about the world origin.

    Uniform scaling commutes with rigid motions, so scaling every translation (mesh vertices, joint
    origins, collision shapes, prismatic limits) scales the world geometry at every configuration.

    :param copy: scale a copy (False: ``asset`` itself, which the caller owns)
    """
    _check_scale(scale)
    return _scale_in_place(asset.copy() if copy else asset, scale)


def _check_scale(scale: float) -> None:
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be positive and finite, got {scale}")


def _scale_in_place(out: ArticulatedAsset, scale: float) -> ArticulatedAsset:
    """:func:`scale_asset` on ``out`` itself (a copy the caller owns: one deep copy per chain of moves)."""
    for link in out.links.values():
        for visual in link.visuals:
            visual.mesh.vertices = visual.mesh.vertices * scale
        for col in link.collisions:
            col.origin = col.origin.copy()
            col.origin[:3, 3] *= scale
            col.size = np.asarray(col.size, dtype=float) * scale
            if col.mesh is not None:
                col.mesh.vertices = col.mesh.vertices * scale
    for joint in out.joints.values():
        joint.origin = joint.origin.copy()
        joint.origin[:3, 3] *= scale
        if joint.type == JointType.PRISMATIC:
            joint.lower *= scale
            joint.upper *= scale
    return out


def translate_asset(asset: ArticulatedAsset, offset) -> ArticulatedAsset:
    """A copy of ``asset`` moved by ``offset`` in the world frame (see :func:`move_asset`)."""
    matrix = np.eye(4)
    matrix[:3, 3] = np.asarray(offset, dtype=float)
    return move_asset(asset, matrix)


def move_asset(asset: ArticulatedAsset, rigid: np.ndarray) -> ArticulatedAsset:
    """A copy of ``asset`` moved by the 4x4 rigid transform ``rigid`` in the world frame.

    The root link stays at the identity; its meshes and collision shapes, and the origins of the joints
    hanging from it, are moved, so the asset's files need no extra world transform. Joint axes are in
    their joints' frames and move with them.
    """
    return _move_in_place(asset.copy(), rigid)


def _move_in_place(out: ArticulatedAsset, rigid: np.ndarray) -> ArticulatedAsset:
    """:func:`move_asset` on ``out`` itself (a copy the caller owns)."""
    rigid = np.asarray(rigid, dtype=float)
    rotation, offset = rigid[:3, :3], rigid[:3, 3]
    root = out.root
    for visual in out.links[root].visuals:
        visual.mesh.vertices = visual.mesh.vertices @ rotation.T + offset
    for col in out.links[root].collisions:
        col.origin = rigid @ col.origin  # a mesh shape's vertices are in this frame: they move with it
    for joint in out.joints.values():
        if joint.parent == root:
            joint.origin = rigid @ joint.origin
    return out


def similarity_asset(asset: ArticulatedAsset, matrix: np.ndarray) -> ArticulatedAsset:
    """A copy of ``asset`` under the 4x4 similarity ``matrix`` (uniform scale, rotation, translation):
    scaled about the world origin first (:func:`scale_asset`), then moved rigidly (:func:`move_asset`).

    :raises ValueError: when ``matrix`` is not a similarity with a positive scale
    """
    matrix = np.asarray(matrix, dtype=float)
    linear = matrix[:3, :3]
    scale = float(np.cbrt(np.linalg.det(linear)))
    if not np.isfinite(scale) or scale <= 0 or not np.allclose(linear.T @ linear, scale ** 2 * np.eye(3),
                                                               atol=1e-9 * max(1.0, scale ** 2)):
        raise ValueError("expected a similarity transform (uniform scale > 0, rotation, translation)")
    rigid = np.eye(4)
    rigid[:3, :3], rigid[:3, 3] = linear / scale, matrix[:3, 3]
    return _move_in_place(scale_asset(asset, scale), rigid)


def denormalization(center, scale: float) -> np.ndarray:
    """The 4x4 similarity from the benchmark frame back to the source's world frame (metres):
    ``p_world = p_bench / scale + center`` (the inverse of :func:`normalization`'s map)."""
    out = np.eye(4) / float(scale)
    out[3, 3] = 1.0
    out[:3, 3] = np.asarray(center, dtype=float)
    return out


def normalization(asset: ArticulatedAsset, q=None) -> tuple[np.ndarray, float]:
    """``(center, scale)`` of the benchmark frame: ``p_bench = (p_world - center) * scale``.

    The world axis-aligned box at ``q`` (default: rest) is centered and scaled by ``2 / max extent``.
    """
    bounds = asset.bounds(q)
    extent = float((bounds[1] - bounds[0]).max())
    if not np.isfinite(extent) or extent <= 0:
        raise ValueError(f"{asset.name}: degenerate bounding box {bounds.tolist()}")
    return bounds.mean(0), 2.0 / extent


def apply_normalization(asset: ArticulatedAsset, center, scale: float, copy: bool = True) -> ArticulatedAsset:
    """``asset`` mapped by ``p_bench = (p_world - center) * scale`` (:func:`normalization`'s map).

    :param asset: the object (world frame)
    :param center: the world point that maps to 0
    :param scale: the uniform scale (> 0)
    :param copy: False maps ``asset`` itself (a caller that owns it saves a deep copy of every mesh)
    """
    _check_scale(float(scale))
    shift = np.eye(4)
    shift[:3, 3] = -np.asarray(center, dtype=float)
    return _scale_in_place(_move_in_place(asset.copy() if copy else asset, shift), float(scale))


def normalize_asset(asset: ArticulatedAsset, copy: bool = True) -> tuple[ArticulatedAsset, np.ndarray, float]:
    """The asset in the benchmark frame (docs/conventions.md): rest pose, box centered at 0, fitting [-1, 1]^3.

    :param asset: the object (world frame)
    :param copy: False normalizes ``asset`` itself (a caller that made it and needs only the result saves a
        deep copy of every mesh: seconds for a real object's R=200 remesh)
    :returns: ``(normalized asset, center, scale)`` with ``p_bench = (p_world - center) * scale``
    """
    center, scale = normalization(asset)
    out = apply_normalization(asset, center, scale, copy=copy)
    out.meta = {**out.meta, "normalization": {"center": center.tolist(), "scale": scale}}
    return out, center, scale
