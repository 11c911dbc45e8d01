"""The joints of an asset as the papers' evaluation code reads them, and which predicted joint meets which.

The papers read a joint from its file: the URDF ``<origin xyz rpy>`` in the parent link's frame, the
``<axis>`` in the joint frame, the ``<limit>`` as written (Articulate-Anything, URDF-Anything), or the
MuJoCo ``jnt_pos`` / ``jnt_axis`` (Real2Code). :class:`JointRecord` keeps both that parent-local view and
the world-frame view at rest, in the *file's* length units: a PartNet-Mobility object that
:func:`spark_bench.data.load_object` brought to its real size is measured back in its file's units
(:func:`file_units_per_length`), because the papers' thresholds (0.05) are in those units.

Which predicted joint is compared with which ground-truth joint: the papers match by ids or semantic names
that a prediction from another method does not carry, so every protocol here uses spark-bench's own part
matching (Hungarian on part Chamfer distance in each asset's benchmark frame,
:mod:`spark_bench.metrics.matching`), except Real2Code, whose code searches joint permutations itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.articulation import axis_error, same_type
from spark_bench.metrics.geometry import (
    benchmark_transform,
    has_area,
    joint_axes,
    part_links,
    posed_triangles,
    transform_triangles,
    validate_asset,
)
from spark_bench.metrics.matching import match_parts, part_cost_matrix
from spark_bench.metrics.sampling import sample_triangles

#: Surface samples per part for the joint matching (as ``spark-bench metrics --match-samples``).
MATCH_SAMPLES = 10_000


@dataclass(frozen=True)
class JointRecord:
    """One movable joint as a paper's evaluation code reads it, lengths in the file's units.

    :param name: joint name
    :param type: URDF type (``revolute``, ``continuous``, ``prismatic``)
    :param local_xyz: ``<origin xyz>``: the joint frame's position in the parent link frame
    :param local_rpy: ``<origin rpy>`` (extrinsic x-y-z, as URDF and ``scipy``'s ``"xyz"``)
    :param local_axis: ``<axis>`` in the joint frame, unit length
    :param world_point: the joint frame's origin in the world at rest
    :param world_rotation: 3x3 rotation of the joint frame in the world at rest
    :param world_axis: unit axis direction in the world at rest
    :param lower: ``<limit lower>`` as the file gives it (0 without ``<limit>``)
    :param upper: ``<limit upper>`` as the file gives it (0 without ``<limit>``)
    :param links: the links of the joint's part
    """

    name: str
    type: str
    local_xyz: np.ndarray
    local_rpy: np.ndarray
    local_axis: np.ndarray
    world_point: np.ndarray
    world_rotation: np.ndarray
    world_axis: np.ndarray
    lower: float
    upper: float
    links: tuple[str, ...]

    @property
    def world_quaternion(self) -> np.ndarray:
        """The joint frame's world orientation as ``[x, y, z, w]`` (``scipy``'s ``as_quat``)."""
        return Rotation.from_matrix(self.world_rotation).as_quat()


def file_units_per_length(asset: ArticulatedAsset) -> float:
    """How many file length units one loaded length unit is: ``1 / metres-per-unit`` for a
    PartNet-Mobility object scaled to real size on loading, 1 for everything else.

    :param asset: an asset from :func:`spark_bench.data.load_object` (``source`` names its URDF)
    """
    from spark_bench.data.real_size import source_scale

    if not asset.source:
        return 1.0
    source = Path(asset.source)
    folder = source if source.is_dir() else source.parent
    if not folder.is_dir():
        return 1.0
    return 1.0 / source_scale(folder, asset.category).factor


def _limits_as_written(joint) -> tuple[float, float]:
    """The ``<limit>`` as the file wrote it; the papers read a missing one as ``lower = upper = 0``."""
    if not joint.has_limits or joint.type == JointType.CONTINUOUS:
        return 0.0, 0.0
    return float(joint.lower), float(joint.upper)


def joint_records(asset: ArticulatedAsset) -> list[JointRecord]:
    """Every movable joint of ``asset``, file order, lengths in the file's units.

    :param asset: the asset, as loaded
    """
    units = file_units_per_length(asset)
    poses = asset.link_poses(asset.rest_configuration())
    out = []
    for joint in asset.movable_joints():
        origin = np.asarray(joint.origin, dtype=np.float64)
        world = poses[joint.parent] @ origin
        axis = np.asarray(joint.axis, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        world_axis = world[:3, :3] @ axis
        lower, upper = _limits_as_written(joint)
        scale = units if joint.type == JointType.PRISMATIC else 1.0  # a prismatic limit is a length
        out.append(JointRecord(
            name=joint.name, type=joint.type, local_xyz=origin[:3, 3] * units,
            local_rpy=Rotation.from_matrix(origin[:3, :3]).as_euler("xyz"), local_axis=axis,
            world_point=world[:3, 3] * units, world_rotation=world[:3, :3].copy(),
            world_axis=world_axis / np.linalg.norm(world_axis), lower=lower * scale, upper=upper * scale,
            links=tuple(part_links(asset, joint.name))))
    return out


def _part_samples(asset: ArticulatedAsset, frame: np.ndarray, n: int, seed: int) -> list[np.ndarray | None]:
    rest = asset.rest_configuration()
    out = []
    for joint in asset.movable_joints():
        triangles = transform_triangles(frame, posed_triangles(asset, rest, part_links(asset, joint.name)))
        out.append(sample_triangles(triangles, n, seed) if has_area(triangles) else None)
    return out


def match_joints(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0,
                 n_samples: int | None = None) -> dict[str, str]:
    """``{ground-truth joint: predicted joint}`` by spark-bench's part matching (the pairs
    ``spark-bench metrics`` reports; unmatched ground-truth joints are absent).

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed of the part surfaces
    :param n_samples: surface samples per part (default :data:`MATCH_SAMPLES`)
    """
    n_samples = MATCH_SAMPLES if n_samples is None else n_samples
    validate_asset(pred)
    validate_asset(gt)
    p_frame, g_frame = benchmark_transform(pred), benchmark_transform(gt)
    p_axes, g_axes = joint_axes(pred, p_frame), joint_axes(gt, g_frame)
    if not p_axes or not g_axes:
        return {}
    cost = part_cost_matrix(_part_samples(pred, p_frame, n_samples, seed),
                            _part_samples(gt, g_frame, n_samples, seed))
    # the same tie-break as spark-bench metrics: a type mismatch weighs more than any axis angle
    tie = np.array([[0.5 * (not same_type(p.type, g.type)) + 0.4 * axis_error(p.direction, g.direction) / (np.pi / 2)
                     for g in g_axes] for p in p_axes])
    return {g_axes[pair.gt].name: p_axes[pair.pred].name for pair in match_parts(cost, tie)}


def paired_records(pred: ArticulatedAsset, gt: ArticulatedAsset,
                   seed: int = 0) -> tuple[list[tuple[JointRecord, JointRecord | None]], int]:
    """``([(ground-truth record, matched predicted record or None), ...], number of predicted records)``: every
    ground-truth joint with the predicted joint spark-bench's part matching pairs it with (:func:`match_joints`).

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed of the part matching
    """
    matched = match_joints(pred, gt, seed)
    p_records = {r.name: r for r in joint_records(pred)}
    return [(g, p_records.get(matched.get(g.name, ""))) for g in joint_records(gt)], len(p_records)


def part_aabb_center(asset: ArticulatedAsset, links: tuple[str, ...]) -> np.ndarray | None:
    """Centre of the world axis-aligned box of ``links`` at rest, file units; None without geometry.

    :param asset: the asset, as loaded
    :param links: the part's links
    """
    triangles = posed_triangles(asset, asset.rest_configuration(), links)
    if not len(triangles):
        return None
    points = triangles.reshape(-1, 3)
    return 0.5 * (points.min(0) + points.max(0)) * file_units_per_length(asset)


def record_to_dict(record: JointRecord) -> dict:
    """A :class:`JointRecord` as JSON-ready lists (the parity fixtures store joints this way)."""
    out = {}
    for key, value in record.__dict__.items():
        out[key] = np.asarray(value).tolist() if isinstance(value, np.ndarray) else value
    out["links"] = list(record.links)
    return out


def record_from_dict(data: dict) -> JointRecord:
    """The inverse of :func:`record_to_dict`.

    :param data: a dict as :func:`record_to_dict` writes it
    """
    arrays = ("local_xyz", "local_rpy", "local_axis", "world_point", "world_rotation", "world_axis")
    values = {k: (np.asarray(v, dtype=np.float64) if k in arrays else v) for k, v in data.items()}
    values["links"] = tuple(data["links"])
    values["lower"], values["upper"] = float(data["lower"]), float(data["upper"])
    return JointRecord(**values)
