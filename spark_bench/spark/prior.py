"""Structure-prior backends without a VLM: ``annotation`` (ground truth + a seeded noise model) and ``file``.

``annotation`` stands in for the VLM when none is configured: it reads the case's ground truth, keeps
only what a VLM could answer (part list, canonical axis, coarse origin, type, large/small range), then
corrupts it with :class:`NoiseModel`. Rows made with it say ``prior=annotation``.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.data.readers import read_json
from spark_bench.spark.geometry import group_parts
from spark_bench.spark.structure import (
    CANONICAL_AXES,
    DEFAULT_UPPER,
    OBJECT_TO_WORLD,
    PriorJoint,
    PriorLink,
    PriorStructure,
    axis_vector,
    nearest_axis_name,
    parse_structure,
)

#: Upper limits at or above these are a ``large`` motion range (rad, benchmark units).
LARGE_RANGE_FROM = {"revolute": 0.5, "prismatic": 0.15}


@dataclass
class NoiseModel:
    """Seeded corruption of a ground-truth coarse URDF, applied independently to each movable joint.

    In this order, with a generator seeded by ``(seed, crc32(case id))`` so a case always gets the same
    prior:

    1. type flip, probability ``p_type``: revolute <-> prismatic (fixed joints are never flipped);
    2. axis replaced, probability ``p_axis``: by one of the four canonical directions perpendicular to
       the true one, uniformly (AxisErr pi/2 for that joint);
    3. axis sign flipped, probability ``p_sign``: the opposite direction (AxisErr 0, since the metric
       ignores the sign, but the part opens the wrong way);
    4. origin offset: isotropic Gaussian, ``sigma_origin`` per coordinate (benchmark units);
    5. limit error, probability ``p_range``: the large/small range swapped.

    Expected errors before optimization are about ``AxisErr = p_axis pi/2``, ``TypeErr = p_type`` and
    ``PivotErr = 1.25 sigma_origin`` for revolute pairs (the mean norm of a 2D Gaussian offset). The
    defaults are calibrated on ``synth-v1`` (all 50 cases) to the paper's "w/o joint optimization" row
    (Table 4: AxisErr 0.3148, PivotErr 0.2388, TypeErr 0.20) by
    :func:`~spark_bench.spark.diagnostics.calibrate_noise` (6 iterations, mean over seeds 0-7, joints
    matched by part name): from (0.2, 0.2, 0.19) it settled at ``p_type = 0.213``, ``p_axis = 0.204``,
    ``sigma_origin = 0.203``, where the expected prior errors are AxisErr 0.3135, PivotErr 0.2388,
    TypeErr 0.201 (``python benchmarks/measure_joint_opt.py --bench synth-v1 --calibrate`` redoes it). One
    seed's draw on 50 objects scatters around these means.

    :param p_type: probability of a type flip
    :param p_axis: probability of a wrong (perpendicular) axis
    :param p_sign: probability of a reversed axis
    :param sigma_origin: standard deviation of the origin offset per coordinate
    :param p_range: probability of a swapped motion range
    :param seed: base seed, combined with the case id
    """

    p_type: float = 0.213
    p_axis: float = 0.204
    p_sign: float = 0.1
    sigma_origin: float = 0.203
    p_range: float = 0.1
    seed: int = 0

    def rng(self, case_id: str) -> np.random.Generator:
        return np.random.default_rng([int(self.seed), zlib.crc32(case_id.encode())])


def ground_truth_structure(gt: ArticulatedAsset, upper_table: dict | None = None) -> PriorStructure:
    """What a perfect VLM would answer for ``gt``: parts, types, snapped axes, pivots, ranges (no noise)."""
    table = upper_table or DEFAULT_UPPER
    parts = group_parts(gt)
    part_of_link = {link: part.name for part in parts for link in part.links}
    frames = gt.joint_frames()
    links = [PriorLink(p.name, p.label) for p in parts]
    joints = []
    for part in parts[1:]:
        joint = gt.joints[part.joint]
        point, direction = frames[joint.name]
        jtype = "prismatic" if joint.type == "prismatic" else "revolute"
        big = joint.type == "continuous" or joint.upper - joint.lower >= LARGE_RANGE_FROM[jtype]
        motion_range = "large" if big else "small"
        joints.append(PriorJoint(
            name=joint.name, type=jtype, parent=part_of_link[joint.parent], child=part.name,
            axis=nearest_axis_name(OBJECT_TO_WORLD.T @ direction),
            origin=[float(v) for v in OBJECT_TO_WORLD.T @ point], range=motion_range,
            upper=float(table[jtype][motion_range])))
    return PriorStructure(links, joints, source="annotation")


def perturb_structure(structure: PriorStructure, noise: NoiseModel, case_id: str,
                      upper_table: dict | None = None) -> PriorStructure:
    """``structure`` corrupted by ``noise`` (see :class:`NoiseModel`), deterministic per case id."""
    table = upper_table or DEFAULT_UPPER
    rng = noise.rng(case_id)
    joints = []
    for pj in structure.joints:
        pj = PriorJoint(**asdict(pj))
        draws = rng.random(4)
        offset = rng.normal(0.0, noise.sigma_origin, 3)
        pick = int(rng.integers(4))
        if pj.type != "fixed":
            if draws[0] < noise.p_type:
                pj.type = "prismatic" if pj.type == "revolute" else "revolute"
            if draws[1] < noise.p_axis:
                true = axis_vector(pj.axis)
                perpendicular = [n for n in CANONICAL_AXES if abs(float(axis_vector(n) @ true)) < 0.5]
                pj.axis = perpendicular[pick % len(perpendicular)]
            if draws[2] < noise.p_sign:
                pj.axis = next(n for n in CANONICAL_AXES if np.allclose(axis_vector(n), -axis_vector(pj.axis)))
            pj.origin = [float(np.clip(v + d, -1.5, 1.5)) for v, d in zip(pj.origin, offset)]
            if draws[3] < noise.p_range:
                pj.range = "small" if pj.range == "large" else "large"
            pj.upper = float(table[pj.type][pj.range])
        joints.append(pj)
    return PriorStructure(list(structure.links), joints, source="annotation")


def annotation_prior(gt: ArticulatedAsset, case_id: str, noise: NoiseModel,
                     upper_table: dict | None = None) -> PriorStructure:
    """The ``annotation`` backend: the ground truth's coarse URDF, corrupted by ``noise``."""
    return perturb_structure(ground_truth_structure(gt, upper_table), noise, case_id, upper_table)


def file_prior(folder: str | Path, case_id: str, known_links: list[str] | None = None,
               upper_table: dict | None = None) -> PriorStructure:
    """The ``file`` backend: ``<folder>/<case id>.json`` holds a coarse-URDF answer (e.g. a recorded
    VLM run's ``prior.json``)."""
    path = Path(folder) / f"{case_id}.json"
    data = read_json(path, missing="no prior answer file for this case")
    out = parse_structure(data, path, known_links, upper_table)
    out.source = "file"
    return out
