"""Real2Code's protocol (Mandi et al., ICLR 2025): joint errors in degrees over the best joint
permutation, and squared Chamfer distances.

Read in ``MandiZhao/real2code`` at commit ``ecd50d27df34773ea82ec55c7af73ce33136c6fb``, files
``eval_utils/joint_eval.py`` and ``shape_complete/eval.py``. Each fact, with the function it comes from:

- **Frame and units** (``joint_eval.py``, ``get_joint_code``): MuJoCo's ``jnt_pos`` / ``jnt_axis`` of the
  compiled MJCF, no normalization; Real2Code's MJCF bodies sit at the world origin, so these are world
  coordinates at rest. Here: world-frame axis lines at rest in the file's units
  (:func:`~spark_bench.metrics.protocols.joints.file_units_per_length`).
- **Type** (``compute_joint_error``): MuJoCo's type numbers (3 hinge, 2 slide): ``revolute`` and
  ``continuous`` are both hinges. A type mismatch gives ``type = 0`` and no axis or position error.
- **Axis error** (``compute_joint_error``): ``min(arccos(a.b/|a||b|), arccos(-a.b/...)) * 180 / pi``:
  **degrees**.
- **Position error** (``compute_joint_error``): for a ground-truth hinge only,
  ``|(p_gt - p_pred).W| / |W|`` with ``W = a_pred x a_gt`` and, when ``W`` is all-close to 0, the
  fixed-direction fallback ``a_pred x (1, 0, 0)`` (``a_gt x (0, 1, 0)`` when ``a_pred`` is x).
- **Matching** (``permute_joint_error``): every permutation of the predicted joints, zipped with the
  ground-truth joints (the shorter list decides how many are scored); the permutation with the lowest
  ``mean([mean(1 - type), mean(axis err), mean(pos err)])`` (degrees and lengths added; an empty list
  counts 0) wins; no prediction at all: every ground-truth joint a type failure. Reproduced with its
  consequence: a few degrees of axis error cost more than a type failure (cost 1/3), so two joints of
  different types each 0.2 rad off (11.5 degrees) are paired the wrong way round (type accuracy 0).
- **Shape** (``shape_complete/eval.py``, ``chamfer_distance``, ``points_chamfer_distance``): 100,000 surface
  samples per mesh, CD = mean squared nearest distance one way plus the other way (**squared**, summed);
  ``chamfer_norm``: the same after centring both samples on the ground truth's sample mean and dividing
  each axis by the ground truth's sample extent on that axis. Here: the whole object at rest
  (``get_whole_part_chamfer``'s "whole") and each part of the joints the best permutation pairs (its
  "part", averaged).

Not reproduced: NaN from ``arccos`` of a dot product that rounds above 1 (the paper's code does not clip;
here it is clipped, so an axis compared with itself gives 0, not NaN); the random sampling
(``trimesh.sample`` on the global NumPy state: here seeded, so reruns agree); more than
:data:`MAX_PERMUTED` predicted joints (the paper's code would enumerate n! permutations; here
spark-bench's part matching is used instead, and a note says so); the shape-completion meshes themselves.
"""

from __future__ import annotations

from itertools import permutations

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.metrics.geometry import has_area, posed_triangles
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.joints import (
    JointRecord,
    file_units_per_length,
    joint_records,
    match_joints,
)
from spark_bench.metrics.sampling import sample_triangles
from spark_bench.metrics.shape import build_tree, nearest_distances

#: Surface samples per mesh (``chamfer_distance``'s ``num_points``).
N_SAMPLES = 100_000
#: Above this many predicted joints, spark-bench's part matching replaces the permutation search.
MAX_PERMUTED = 7
HINGE, SLIDE = 3, 2
#: MuJoCo joint type numbers of the URDF types (``mjtJoint``: 3 hinge, 2 slide).
MUJOCO_TYPE = {"revolute": HINGE, "continuous": HINGE, "prismatic": SLIDE}

INFO = ProtocolInfo(
    name="real2code",
    paper="Mandi et al., Real2Code, ICLR 2025",
    source="github.com/MandiZhao/real2code @ ecd50d27; eval_utils/joint_eval.py (compute_joint_error, "
           "permute_joint_error), shape_complete/eval.py (chamfer_distance, points_chamfer_distance)",
    units={"type_acc": "fraction", "rot_err_deg": "deg", "pos_err": "file units", "axis_err": "deg",
           "pivot_err": "file units", "chamfer": "file units squared", "chamfer_norm": "unit box squared",
           "part_chamfer": "file units squared", "part_chamfer_norm": "unit box squared",
           "n_joints": "count"},
    columns=(("chamfer", "Whole CD"), ("part_chamfer", "Part CD"), ("type_acc", "Type acc."),
             ("rot_err_deg", "Axis err (deg)"), ("pos_err", "Pos. err")),
    differs="World frame at rest, file units, no normalization (spark-bench: benchmark frame, longest side "
            "2); axis error in degrees (spark-bench: radians); joints paired by the permutation with the "
            "lowest mean of (1 - type, degrees, position) errors; Chamfer distance squared and summed over "
            "both directions (spark-bench: unsquared mean of the two means); chamfer_norm divides each "
            "axis by the ground truth's extent.",
    deterministic=False)


def _degrees(a: np.ndarray, b: np.ndarray) -> float:
    cosine = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)) * 180 / np.pi)


def joint_error(pred: JointRecord, gt: JointRecord) -> dict:
    """``compute_joint_error``: ``{"type", "rot" (degrees), "pos"}``, None where not defined.

    :param pred: the predicted joint
    :param gt: the ground-truth joint
    """
    gt_type = MUJOCO_TYPE[gt.type]
    if MUJOCO_TYPE[pred.type] != gt_type:
        return {"type": 0, "rot": None, "pos": None, "gt_type": gt_type}
    a_pred, a_gt = pred.world_axis, gt.world_axis
    pos = None
    if gt_type == HINGE:
        w = np.cross(a_pred, a_gt)
        if np.allclose(w, 0):
            w = np.cross(a_pred, [1, 0, 0]) if not np.allclose(a_pred, [1, 0, 0]) else np.cross(a_gt, [0, 1, 0])
        pos = float(abs(np.dot(gt.world_point - pred.world_point, w)) / np.linalg.norm(w))
    rot = min(_degrees(a_pred, a_gt), _degrees(-a_pred, a_gt))
    return {"type": 1, "rot": rot, "pos": pos, "gt_type": gt_type}


def _permutation_cost(errors: list[dict]) -> float:
    parts = []
    for key in ("type", "rot", "pos"):
        values = [1 - e[key] if key == "type" else e[key] for e in errors]
        values = [v for v in values if v is not None]
        parts.append(float(np.mean(values)) if values else 0.0)
    return float(np.mean(parts))


def best_permutation(pred: list[JointRecord], gt: list[JointRecord]
                     ) -> list[tuple[JointRecord, JointRecord, dict]]:
    """``permute_joint_error``: ``(predicted joint, ground-truth joint, errors)`` per scored ground-truth
    joint, in ground-truth order, for the permutation of the predictions with the lowest cost (first on ties).

    :param pred: predicted joints (at most :data:`MAX_PERMUTED`)
    :param gt: ground-truth joints
    """
    best, best_cost = [], np.inf
    for perm in permutations(pred):
        errors = [joint_error(p, g) for p, g in zip(perm, gt)]
        cost = _permutation_cost(errors)
        if cost < best_cost:  # np.argmin keeps the first of equal costs
            best, best_cost = list(zip(perm, gt, errors)), cost
    return best


def squared_chamfer(gt_points: np.ndarray, pred_points: np.ndarray) -> tuple[float, float]:
    """``chamfer_distance``'s ``(chamfer, chamfer_norm)`` on two samples (ground truth first).

    :param gt_points: ground-truth samples
    :param pred_points: predicted samples
    """
    def one(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.mean(np.square(nearest_distances(b, build_tree(a)))) +
                     np.mean(np.square(nearest_distances(a, build_tree(b)))))

    centre = gt_points.mean(0)
    extent = gt_points.max(0) - gt_points.min(0)
    return one(gt_points, pred_points), one((gt_points - centre) / extent, (pred_points - centre) / extent)


def _samples(asset: ArticulatedAsset, links, seed: int) -> np.ndarray | None:
    triangles = posed_triangles(asset, asset.rest_configuration(), links) * file_units_per_length(asset)
    return sample_triangles(triangles, N_SAMPLES, seed) if has_area(triangles) else None


def _pairs(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int, notes: list[str]):
    p_records, g_records = joint_records(pred), joint_records(gt)
    if not p_records:
        return [(None, g, {"type": 0, "rot": None, "pos": None}) for g in g_records]
    if len(p_records) <= MAX_PERMUTED:
        return best_permutation(p_records, g_records)
    notes.append(f"{len(p_records)} predicted joints: paired by spark-bench's part matching, not by "
                 f"Real2Code's search over every permutation")
    by_name = {r.name: r for r in p_records}
    matched = match_joints(pred, gt, seed)
    return [(by_name[matched[g.name]], g, joint_error(by_name[matched[g.name]], g))
            for g in g_records if g.name in matched]


def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """Real2Code's joint errors and squared Chamfer distances of ``pred`` against ``gt``.

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: surface sampling seed
    """
    notes: list[str] = []
    pairs = _pairs(pred, gt, seed, notes)
    errors = [e for _, _, e in pairs]
    n_gt = len(gt.movable_joints())
    gt_whole, pred_whole = _samples(gt, None, seed), _samples(pred, None, seed)
    for points, asset in ((gt_whole, gt), (pred_whole, pred)):
        if points is None:
            raise InputError(asset.source or asset.name, "empty mesh: no surface to sample")
    whole = squared_chamfer(gt_whole, pred_whole)
    parts = []
    for p, g, _ in pairs:
        if p is not None and (gp := _samples(gt, g.links, seed)) is not None and \
                (pp := _samples(pred, p.links, seed)) is not None:
            parts.append(squared_chamfer(gp, pp))
    rot, pos = _mean(e["rot"] for e in errors), _mean(e["pos"] for e in errors)
    metrics: dict[str, float | None] = {
        "type_acc": _mean(e["type"] for e in errors), "rot_err_deg": rot, "pos_err": pos,
        "axis_err": rot, "pivot_err": pos, "chamfer": whole[0], "chamfer_norm": whole[1],
        "part_chamfer": _mean(c for c, _ in parts), "part_chamfer_norm": _mean(n for _, n in parts),
        "n_joints": float(len(errors))}
    if len(errors) < n_gt:
        notes.append(f"{n_gt - len(errors)} ground-truth joint(s) not scored (fewer predicted "
                     f"joints; Real2Code zips the lists)")
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
