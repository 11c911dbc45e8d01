"""What the metrics read from an asset: checked, posed surfaces and joint axes in the benchmark frame.

Everything here returns plain arrays: triangles as (F, 3, 3) world-frame vertex rows (posed by
forward kinematics), the 4x4 similarity into the benchmark frame, and joint axis lines.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from spark_bench.asset.model import ArticulatedAsset, Configuration
from spark_bench.asset.transforms import transform_points
from spark_bench.data.case import benchmark_frame
from spark_bench.errors import InputError
from spark_bench.metrics.articulation import JointAxis
from spark_bench.metrics.sampling import triangle_areas


def _where(asset: ArticulatedAsset) -> str:
    return asset.source or asset.name or "asset"


def validate_asset(asset: ArticulatedAsset) -> None:
    """Raise :class:`InputError` for NaN/inf anywhere the metrics read, or a zero joint axis.

    :param asset: the asset to check
    """
    where = _where(asset)
    for link in asset.links.values():
        for visual in link.visuals:
            vertices = np.asarray(visual.mesh.vertices, dtype=np.float64)
            if not np.isfinite(vertices).all():
                raise InputError(where, f"link {link.name!r}: mesh {visual.source or ''} has NaN or infinite vertices")
            faces = np.asarray(visual.mesh.faces)
            if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
                raise InputError(where, f"link {link.name!r}: mesh {visual.source or ''} has faces with bad vertex indices")
    for joint in asset.joints.values():
        if not np.isfinite(np.asarray(joint.origin, dtype=np.float64)).all():
            raise InputError(where, f"joint {joint.name!r}: origin has NaN or infinite values")
        if not joint.is_movable:
            continue
        axis = np.asarray(joint.axis, dtype=np.float64)
        if not np.isfinite(axis).all() or np.linalg.norm(axis) <= 0.0:
            raise InputError(where, f"joint {joint.name!r}: axis {axis.tolist()} is NaN or zero")
        if not (np.isfinite(joint.rest_value) and np.isfinite(joint.open_value)):
            raise InputError(where, f"joint {joint.name!r}: limits [{joint.lower}, {joint.upper}] are not finite")


def posed_triangles(asset: ArticulatedAsset, q: Configuration | None = None,
                    links: Iterable[str] | None = None) -> np.ndarray:
    """The visual surface of ``links`` (default: all) at configuration ``q``, world frame, (F, 3, 3).

    :param asset: the asset
    :param q: joint values by name (missing joints at rest)
    :param links: which links to include
    """
    poses = asset.link_poses(q)
    chunks = []
    for name in links if links is not None else asset.links:
        for visual in asset.links[name].visuals:
            faces = np.asarray(visual.mesh.faces, dtype=np.int64).reshape(-1, 3)
            if len(faces):
                vertices = transform_points(poses[name], np.asarray(visual.mesh.vertices, dtype=np.float64))
                chunks.append(vertices[faces])
    return np.concatenate(chunks) if chunks else np.zeros((0, 3, 3))


def has_area(triangles: np.ndarray) -> bool:
    """Whether the triangles have a positive total area (something to sample)."""
    return len(triangles) > 0 and bool(triangle_areas(triangles).sum() > 0.0)


def benchmark_transform(asset: ArticulatedAsset) -> np.ndarray:
    """4x4 similarity from the asset's world frame into its benchmark frame
    (:func:`spark_bench.data.case.benchmark_frame`), for an asset the metrics can measure.

    :raises InputError: when the asset has no surface or a flat-to-a-point box
    """
    rest = posed_triangles(asset, asset.rest_configuration())
    if not has_area(rest):
        raise InputError(_where(asset), "empty mesh: the asset has no surface to measure")
    try:
        return benchmark_frame(asset)
    except ValueError as exc:
        raise InputError(_where(asset), str(exc)) from None


def transform_triangles(matrix: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to (F, 3, 3) triangles."""
    return triangles @ matrix[:3, :3].T + matrix[:3, 3]


def part_links(asset: ArticulatedAsset, joint: str) -> list[str]:
    """The part of a movable joint: the links it moves and no movable joint below it moves; when
    those carry no geometry (a helper link between two chained joints), every link it moves."""
    links = asset.part_of_joint(joint)
    if not any(asset.links[name].has_geometry for name in links):
        links = asset.moving_links(joint)
    return links


#: GAPartNet part classes of parts that do not move on their own (a handle fixed to a door or drawer):
#: never the class of a joint.
FIXED_PART_CLASSES = ("line_fixed_handle", "round_fixed_handle")


def part_class(asset: ArticulatedAsset, joint: str) -> str | None:
    """The GAPartNet part class of what a movable joint moves (``hinge_door``, ``slider_drawer``,
    ``hinge_lid``, ...), from the links' ``link_annotation_gapartnet.json`` annotations
    (:attr:`~spark_bench.asset.model.Link.annotations`): the first link of the joint's own part, child
    first, annotated ``is_gapart`` with a class that is not a fixed handle; None when there is none (an
    object without GAPartNet annotations, a part GAPartNet does not annotate).

    :param asset: the asset (its links carry the annotations)
    :param joint: a movable joint's name
    """
    for name in asset.part_of_joint(joint):
        notes = asset.links[name].annotations
        category = notes.get("category")
        if notes.get("is_gapart", True) and isinstance(category, str) and category \
                and category not in FIXED_PART_CLASSES:
            return category
    return None


def joint_axes(asset: ArticulatedAsset, frame: np.ndarray) -> list[JointAxis]:
    """World-frame axis lines of the movable joints at rest, mapped by ``frame``: the full transform
    for the points on the axes, its rotation only for the directions.

    :param asset: the asset
    :param frame: 4x4 similarity (benchmark frame, alignment) applied to the asset
    """
    linear = np.asarray(frame, dtype=np.float64)[:3, :3]
    frames = asset.joint_frames(asset.rest_configuration())
    out = []
    for joint in asset.movable_joints():
        point, direction = frames[joint.name]
        direction = linear @ direction  # a similarity's linear part is s R: rescaling leaves R
        out.append(JointAxis(joint.name, joint.type, transform_points(frame, point[None])[0],
                             direction / np.linalg.norm(direction)))
    return out
