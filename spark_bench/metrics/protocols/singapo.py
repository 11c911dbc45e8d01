"""SINGAPO's protocol: part-box RS/AS-IoU and cDist, per-part squared CD, and AOR, on part boxes.

Facts, from ``3dlg-hcvc/singapo`` at commit 2199ef8c223308e26f1e7928892e5f9786ff4fea (the object is its
``object.json`` "diffuse_tree" of parts, each an axis-aligned box at rest and a joint: written from an
asset by :func:`~spark_bench.metrics.protocols.parts.object_dict`):

- what is computed and with which options (``scripts/eval_metrics.py``, ``_get_metrics_per_sample``):
  ``CD(pred, .., gt, .., include_base=True)``, then ``AOR(pred)``, then ``IoU_cDist(pred, gt,
  compare_handles=True, iou_include_base=True)``; an AOR of -1 (no sibling pair) is None;
- IoU / cDist (``metrics/iou_cdist.py``, ``IoU_cDist`` / ``_get_scores``): both objects zero-centred on
  their overall box (``objects/dict_utils.py``, ``zero_center_object``); the prediction rescaled **per
  axis** to the ground truth's overall box size (``rescale_object`` with ``gt_size / gen_size``: box
  centres, sizes and joint origins, not directions); parts paired by Hungarian matching on box-centre
  distance (``hungarian_matching``; a surplus part takes its nearest part); 5 states ``linspace(0, 1,
  5)``; a part opens by ``range[1] * state`` from rest, revolute joints by ``sign(range[1]) * 90`` degrees
  * state whatever their range (``objects/motions.py``, ``transform_all_parts``, ``rotation_fix_range``);
  a part moves with its own joint and its parent's only (children, not grandchildren); per pair of parts
  the generalized IoU (``metrics/giou.py``, ``sampling_giou``) of the moved boxes, exact for two boxes
  at rest, else estimated from 10,000 uniform samples in each box (``np.random.rand``); cDist the
  distance between the moved box centres (``sampling_cDist``); RS = state 0, AS = mean over the states;
  ``RS-IoU = 1 - mean gIoU`` and likewise AS; the mean of the two directions (gen -> gt, gt -> gen);
- CD (``metrics/cd.py``, ``CD``): 2,048 samples per part (PyTorch3D ``sample_points_from_meshes``);
  per pair of parts PyTorch3D's ``chamfer_distance``: the **squared** distances, ``mean(d_ab^2) +
  mean(d_ba^2)``; summed over the parts, divided by the number of parts; the parts move as above;
  RS-CD at state 0, AS-CD the mean over 5 states; mean of the two directions;
- AOR (``metrics/aor.py``, ``AOR``): on the prediction alone, 10 states; per state the mean IoU
  (``metrics/iou.py``, ``sampling_iou``, plain IoU) of every pair of sibling parts, NaN pairs skipped;
  the mean over the states.

Quirks reproduced (each changes numbers): ``CD`` rescales with ``gen_size / gt_size`` (the inverse of
``IoU_cDist``'s) and applies it only to the prediction's part meshes (each about its own box centre,
then put at its *unscaled* box centre), not to its boxes or joints; it rescales the *caller's*
dictionary, so ``AOR`` and ``IoU_cDist`` then see the prediction scaled per axis by ``gen_size /
gt_size`` (``IoU_cDist`` undoes it; ``AOR`` does not); ``AOR`` passes ``transform_use_plucker`` where
``transform_all_parts`` takes ``rotation_fix_range``, so AOR turns revolute parts through their full
range; ``CD`` divides by all parts. Float32 where the code uses float32 (boxes, scale factors, the
stored transforms, the per-state arrays).

Not deterministic in the paper's code: the box samples come from the unseeded global ``np.random``
(here ``np.random.RandomState(seed)``, drawn in the same order, so ``np.random.seed(seed)`` before the
paper's ``AOR`` and ``IoU_cDist`` gives the same samples); CD samples points on the GPU (PyTorch3D,
``.cuda()``: CUDA-only), here trimesh's sampler from a generator seeded by ``seed``, distances in
float64 where PyTorch3D uses float32. Units: the asset's own (world) units, squared for CD.
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.transform import Rotation

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.parts import (
    asset_parts,
    object_dict,
    part_triangles,
    require_geometry,
    sample_trimesh_way,
)
from spark_bench.metrics.shape import mutual_nearest_distances

#: States of IoU / cDist / CD (``IoU_cDist(num_states=5)``, ``CD(num_states=5)``).
N_STATES = 5
#: States of AOR (``AOR(num_states=10)``).
AOR_STATES = 10
#: Samples per box for the sampled IoU (``num_samples=10000``).
BOX_SAMPLES = 10_000
#: Samples per part for CD (``CD(num_samples=2048)``).
PART_SAMPLES = 2048
#: ``hungarian_matching``'s cost of a padding cell.
_INF = 9999999

INFO = ProtocolInfo(
    name="singapo",
    paper="SINGAPO (Liu et al. 2025)",
    source="github.com/3dlg-hcvc/singapo @ 2199ef8c: scripts/eval_metrics.py, metrics/iou_cdist.py, "
           "metrics/giou.py, metrics/iou.py, metrics/cd.py, metrics/aor.py, objects/dict_utils.py, "
           "objects/motions.py",
    units={"RS-IoU": "1 - gIoU", "AS-IoU": "1 - gIoU", "RS-cDist": "asset units", "AS-cDist": "asset units",
           "RS-CD": "asset units^2", "AS-CD": "asset units^2", "AOR": "IoU fraction"},
    columns=(("RS-IoU", "RS-IoU↓"), ("AS-IoU", "AS-IoU↓"), ("RS-cDist", "RS-cDist↓"),
             ("AS-cDist", "AS-cDist↓"), ("RS-CD", "RS-CD↓"), ("AS-CD", "AS-CD↓"), ("AOR", "AOR↓")),
    differs="Scores part boxes, not surfaces: 1 - generalized IoU and centre distance of matched part "
            "boxes at rest (RS) and over 5 states (AS), the prediction rescaled per axis to the ground "
            "truth's box; squared per-part Chamfer distance on 2,048 points per part; revolute parts "
            "turned 90 degrees whatever their range; no axis / pivot error; AOR (sibling overlap) on "
            "the prediction alone.",
    deterministic=False,
)


# ----- the object dictionary, as objects/dict_utils.py treats it --------------------------------------
def zero_center(tree: list[dict]) -> None:
    """``zero_center_object``: move box centres and joint origins so the overall box is centred (float64)."""
    centers = np.array([p["aabb"]["center"] for p in tree], dtype=np.float64)
    halves = np.array([p["aabb"]["size"] for p in tree], dtype=np.float64) / 2
    shift = -((centers - halves).min(0) + (centers + halves).max(0)) / 2
    for part in tree:
        part["aabb"]["center"] = np.array(part["aabb"]["center"]) + shift
        if part["joint"]["type"] != JointType.FIXED:
            part["joint"]["axis"]["origin"] = np.array(part["joint"]["axis"]["origin"]) + shift


def overall_size(tree: list[dict]) -> np.ndarray:
    """``compute_overall_bbox_size`` (float32)."""
    centers = np.array([p["aabb"]["center"] for p in tree], dtype=np.float32)
    halves = np.array([p["aabb"]["size"] for p in tree], dtype=np.float32) / 2
    return (centers + halves).max(0) - (centers - halves).min(0)


def rescale(tree: list[dict], factor) -> None:
    """``rescale_object``: box centres, sizes and joint origins times ``factor`` (float32)."""
    for part in tree:
        part["aabb"]["center"] = np.array(part["aabb"]["center"], dtype=np.float32) * factor
        part["aabb"]["size"] = np.array(part["aabb"]["size"], dtype=np.float32) * factor
        if part["joint"]["type"] != JointType.FIXED:
            part["joint"]["axis"]["origin"] = np.array(part["joint"]["axis"]["origin"], dtype=np.float32) * factor


def box_bounds(part: dict, dtype=np.float32) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` of the part's box, as ``get_bbox_vertices`` builds it (SINGAPO float32, CAGE float64)."""
    center = np.array(part["aabb"]["center"], dtype=dtype)
    half = np.array(part["aabb"]["size"], dtype=dtype) / 2
    return center - half, center + half


def base_index(tree: list[dict]) -> int:
    """``get_base_part_idx``: the first part without a parent."""
    return next(i for i, p in enumerate(tree) if p["parent"] == -1)


def hungarian_mapping(tree_1: list[dict], tree_2: list[dict]) -> np.ndarray:
    """``hungarian_matching``: for each part of ``tree_1`` the index of its part in ``tree_2``."""
    size = max(len(tree_1), len(tree_2))
    cost = np.ones((size, size), dtype=np.float32) * _INF
    for i, a in enumerate(tree_1):
        for j, b in enumerate(tree_2):
            cost[i, j] = np.linalg.norm(np.array(a["aabb"]["center"], dtype=np.float32)
                                        - np.array(b["aabb"]["center"], dtype=np.float32))
    rows, cols = linear_sum_assignment(cost)
    valid = cost[rows, cols] < _INF
    mapping = np.zeros(len(tree_1), dtype=np.int64)
    mapping[rows[valid]] = cols[valid]
    if len(tree_1) > len(tree_2):
        surplus = rows[~valid]
        mapping[surplus] = cost[surplus, :].argmin(axis=1)
    return mapping[: len(tree_1)]


# ----- motions, as objects/motions.py applies them ------------------------------------------------------
def _visit_order(tree: list[dict]) -> list[int]:
    """Breadth-first from the base, reversed: children before parents."""
    order, frontier = [], [base_index(tree)]
    while frontier:
        current = frontier.pop(0)
        order.append(current)
        frontier += list(tree[current]["children"])
    return order[::-1]


def part_transforms(tree: list[dict], state: float, fix_range: bool = True, skip_rest: bool = True,
                    dtype=np.float32) -> list[list[dict]]:
    """``transform_all_parts`` (dry run): per part, the motions that move it at ``state`` in [0, 1].

    :param tree: the diffuse tree
    :param state: the joint state
    :param fix_range: revolute parts turn ``sign(range[1]) * 90`` degrees at state 1 (else ``range[1]``)
    :param skip_rest: SINGAPO returns no motion at state 0 (CAGE records identity motions there)
    :param dtype: the stored matrices' type (SINGAPO: float32, CAGE: float64)
    """
    out: list[list[dict]] = [[] for _ in tree]
    if skip_rest and state == 0.0:
        return out
    for i in _visit_order(tree):
        joint = tree[i]["joint"]
        matrix = np.eye(4, dtype=dtype)
        origin = np.array([np.nan] * 3, dtype=dtype)
        if joint["type"] == JointType.PRISMATIC:
            matrix[:3, 3] = np.array(joint["axis"]["direction"], dtype=dtype) * joint["range"][1] * state
            kind = "translation"
        elif joint["type"] in (JointType.REVOLUTE, JointType.CONTINUOUS):
            if joint["type"] == JointType.CONTINUOUS:
                radians = np.radians(360 * state)
            elif fix_range:
                radians = np.radians(np.sign(joint["range"][1]) * 90 * state)
            else:
                radians = np.radians(joint["range"][1] * state)
            origin = np.array(joint["axis"]["origin"], dtype=dtype)
            # the norm of the stored values (float64), as the code divides by it
            direction = np.array(joint["axis"]["direction"], dtype=dtype) / np.linalg.norm(joint["axis"]["direction"])
            matrix[:3, :3] = Rotation.from_rotvec(radians * direction).as_matrix()
            kind = "rotation"
        else:
            continue
        record = {"type": kind, "matrix": matrix, "origin": origin}
        for index in [i] + list(tree[i]["children"]):
            out[index].append(record)
    return out


def forward(points: np.ndarray, motions: list[dict]) -> np.ndarray:
    """``_apply_forward_transformations``: the motions in order, in homogeneous coordinates."""
    if not motions:
        return points
    out = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    for motion in motions:
        if motion["type"] == "rotation":
            shift = np.append(motion["origin"], 0)
            out = (motion["matrix"] @ (out - shift).T).T + shift
        else:
            out = (motion["matrix"] @ out.T).T
    return out[..., :3]


def backward(points: np.ndarray, motions: list[dict]) -> np.ndarray:
    """``_apply_backward_transformations``: the inverse motions in reverse order."""
    if not motions:
        return points
    out = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    for motion in motions[::-1]:
        inverse = np.eye(4)
        inverse[:3, :3] = motion["matrix"][:3, :3].T
        inverse[:3, 3] = -(motion["matrix"][:3, :3].T @ motion["matrix"][:3, 3])
        if motion["type"] == "rotation":
            shift = np.append(motion["origin"], 0)
            out = (inverse @ (out - shift).T).T + shift
        else:
            out = (inverse @ out.T).T
    return out[..., :3]


# ----- box overlap, as metrics/iou.py and metrics/giou.py estimate it --------------------------------------
def _volume(low: np.ndarray, high: np.ndarray):
    return np.prod(high - low)


def exact_iou(box_1, box_2, generalized: bool) -> float:
    """``iou_aabb`` / ``giou_aabb``: the (generalized) IoU of two boxes at rest."""
    (low_1, high_1), (low_2, high_2) = box_1, box_2
    inter = np.prod(np.clip(np.minimum(high_1, high_2) - np.maximum(low_1, low_2), a_min=0, a_max=None))
    union = _volume(low_1, high_1) + _volume(low_2, high_2) - inter
    iou = inter / union if union > 0 else 0
    if not generalized:
        return iou
    hull = _volume(np.minimum(low_1, low_2), np.maximum(high_1, high_2))
    return iou - (hull - union) / hull if hull > 0 else iou


def sampled_iou(box_1, box_2, motions_1, motions_2, random: np.random.RandomState,
                generalized: bool, n: int = BOX_SAMPLES, exact_at_rest: bool = True) -> float:
    """``sampling_iou`` / ``sampling_giou``: (generalized) IoU of two moved boxes from ``n`` uniform samples
    in each (exact when neither moves).

    :param box_1: ``(low, high)`` of the first box at rest
    :param box_2: ``(low, high)`` of the second box at rest
    :param motions_1: the first box's motions (:func:`part_transforms`)
    :param motions_2: the second box's motions
    :param random: the legacy generator the samples come from (``np.random.rand`` in the paper's code)
    :param generalized: gIoU (``sampling_giou``) or IoU (``sampling_iou``)
    :param n: samples per box
    :param exact_at_rest: the exact IoU when neither box moves (SINGAPO; CAGE always samples)
    """
    if exact_at_rest and not motions_1 and not motions_2:
        return exact_iou(box_1, box_2, generalized)
    (low_1, high_1), (low_2, high_2) = box_1, box_2
    volume_1, volume_2 = _volume(low_1, high_1), _volume(low_2, high_2)
    hull = _volume(np.minimum(low_1, low_2), np.maximum(high_1, high_2))
    points_1 = random.rand(n, 3) * (high_1 - low_1) + low_1
    points_2 = random.rand(n, 3) * (high_2 - low_2) + low_2
    in_2 = backward(forward(points_1, motions_1), motions_2)
    in_1 = backward(forward(points_2, motions_2), motions_1)
    count_1 = np.sum(np.all(in_2 >= low_2, axis=1) & np.all(in_2 <= high_2, axis=1))
    count_2 = np.sum(np.all(in_1 >= low_1, axis=1) & np.all(in_1 <= high_1, axis=1))
    inter = (volume_1 * count_1 + volume_2 * count_2) / 2
    union = volume_1 * n + volume_2 * n - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        iou = inter / union
        if not generalized:
            return iou
        return iou - (hull * n - union) / (hull * n) if hull > 0 else iou


# ----- the three metrics ----------------------------------------------------------------------------------
def _scores_one_way(src: list[dict], tgt: list[dict], mapping: np.ndarray, random: np.random.RandomState,
                    n_states: int) -> dict[str, float]:
    """``iou_cdist._get_scores``: 1 - gIoU and cDist of each ``src`` part against its mapped part."""
    src_boxes, tgt_boxes = [box_bounds(p) for p in src], [box_bounds(p) for p in tgt]
    iou = np.zeros((len(src), n_states), dtype=np.float32)
    dist = np.zeros((len(src), n_states), dtype=np.float32)
    for k, state in enumerate(np.linspace(0, 1, n_states)):
        src_motions, tgt_motions = part_transforms(src, state), part_transforms(tgt, state)
        for i in range(len(src)):
            j = int(mapping[i])
            iou[i, k] = sampled_iou(src_boxes[i], tgt_boxes[j], src_motions[i], tgt_motions[j], random, True)
            centers = [forward(np.array(part["aabb"]["center"], dtype=np.float32).reshape(1, 3), motions)
                       for part, motions in ((src[i], src_motions[i]), (tgt[j], tgt_motions[j]))]
            dist[i, k] = np.linalg.norm(centers[0] - centers[1])
    as_iou, rs_iou = np.sum(iou, axis=1) / n_states, iou[:, 0]
    as_dist, rs_dist = np.sum(dist, axis=1) / n_states, dist[:, 0]
    return {"AS-IoU": 1.0 - float(np.mean(as_iou)), "AS-cDist": float(np.mean(as_dist)),
            "RS-IoU": 1.0 - float(np.mean(rs_iou)), "RS-cDist": float(np.mean(rs_dist))}


def iou_cdist(gen: dict, gt: dict, random: np.random.RandomState, n_states: int = N_STATES) -> dict[str, float]:
    """``IoU_cDist(gen, gt, compare_handles=True, iou_include_base=True)``: RS/AS-IoU and RS/AS-cDist.

    :param gen: the prediction's object dictionary
    :param gt: the ground truth's object dictionary
    :param random: the legacy generator of the box samples
    :param n_states: articulation states
    """
    gen_tree, gt_tree = copy.deepcopy(gen["diffuse_tree"]), copy.deepcopy(gt["diffuse_tree"])
    zero_center(gen_tree)
    zero_center(gt_tree)
    rescale(gen_tree, overall_size(gt_tree) / overall_size(gen_tree))
    gen_to_gt, gt_to_gen = hungarian_mapping(gen_tree, gt_tree), hungarian_mapping(gt_tree, gen_tree)
    one = _scores_one_way(gen_tree, gt_tree, gen_to_gt, random, n_states)
    two = _scores_one_way(gt_tree, gen_tree, gt_to_gen, random, n_states)
    return {key: (one[key] + two[key]) / 2 for key in one}


def aor(obj: dict, random: np.random.RandomState, n_states: int = AOR_STATES, fix_range: bool = False,
        skip_rest: bool = True, dtype=np.float32, exact_at_rest: bool = True) -> float | None:
    """``AOR(obj)``: mean over states of the mean sampled IoU of sibling boxes; None where the code gives -1.

    :param obj: the object dictionary
    :param random: the legacy generator of the box samples
    :param n_states: articulation states (SINGAPO 10, CAGE 20)
    :param fix_range: whether revolute parts turn 90 degrees (SINGAPO's AOR passes False, by position)
    :param skip_rest: no motion at state 0 (SINGAPO) or identity motions (CAGE)
    :param dtype: the type of the boxes and stored motions (SINGAPO float32, CAGE float64)
    :param exact_at_rest: the exact IoU of two boxes that do not move (SINGAPO; CAGE always samples)
    """
    tree = obj["diffuse_tree"]
    boxes = [box_bounds(p, dtype) for p in tree]
    per_state = []
    for state in np.linspace(0, 1, n_states):
        motions = part_transforms(tree, state, fix_range, skip_rest, dtype)
        ious = []
        for node in tree:
            children = node["children"]
            for a in range(len(children) - 1):
                for b in range(a + 1, len(children)):
                    i, j = children[a], children[b]
                    value = sampled_iou(boxes[i], boxes[j], motions[i], motions[j], random, False,
                                        exact_at_rest=exact_at_rest)
                    if not np.isnan(value):
                        ious.append(value)
        if ious:
            per_state.append(np.mean(ious))
    return float(np.mean(per_state)) if per_state else None


def move_points(points: np.ndarray, tree: list[dict], state: float, dtype=np.float32) -> np.ndarray:
    """``transform_all_parts(dry_run=False)`` on (K, N, 3) float32 part samples: in the visit order, each
    moving part's joint moves the points of the part and of its children, in place (float32 storage;
    ``dtype``: the joint values' type, SINGAPO float32, CAGE float64). State 0 moves nothing."""
    points = np.array(points, dtype=np.float32)
    if state == 0.0:
        return points
    for i in _visit_order(tree):
        joint = tree[i]["joint"]
        moved = [i] + list(tree[i]["children"])
        if joint["type"] == JointType.PRISMATIC:
            points[moved] += np.array(joint["axis"]["direction"], dtype=dtype) * joint["range"][1] * state
        elif joint["type"] in (JointType.REVOLUTE, JointType.CONTINUOUS):
            if joint["type"] == JointType.CONTINUOUS:
                radians = np.radians(360 * state)
            else:
                radians = np.radians(np.sign(joint["range"][1]) * 90 * state)
            origin = np.array(joint["axis"]["origin"], dtype=dtype)
            direction = np.array(joint["axis"]["direction"], dtype=dtype) / np.linalg.norm(joint["axis"]["direction"])
            rotation = Rotation.from_rotvec(radians * direction).as_matrix()
            offset = points[moved] - origin
            points[moved] = np.matmul(rotation, offset.transpose([0, 2, 1])).transpose([0, 2, 1]) + origin
    return points


def squared_cd(points_a: np.ndarray, points_b: np.ndarray) -> float:
    """PyTorch3D's ``chamfer_distance`` of two samples: ``mean(d_ab^2) + mean(d_ba^2)``."""
    d_ab, d_ba = mutual_nearest_distances(np.asarray(points_a, np.float64), np.asarray(points_b, np.float64))
    return float(np.mean(d_ab ** 2) + np.mean(d_ba ** 2))


def _cd_one_way(src_points, tgt_points, src_tree, tgt_tree, mapping, n_states: int) -> tuple[float, float]:
    """``cd._get_scores`` with ``include_base=True``: (AS-CD, RS-CD) of ``src`` against ``tgt``."""
    values = np.zeros(n_states, dtype=np.float32)
    for k, state in enumerate(np.linspace(0, 1, n_states)):
        src_moved, tgt_moved = move_points(src_points, src_tree, state), move_points(tgt_points, tgt_tree, state)
        total = 0.0
        for i in range(len(mapping)):
            one = squared_cd(src_moved[i], tgt_moved[int(mapping[i])])
            two = squared_cd(tgt_moved[int(mapping[i])], src_moved[i])
            total += (one + two) * 0.5
        values[k] = total / len(mapping)
    return float(np.mean(values)), float(values[0])


def part_samples(asset: ArticulatedAsset, tree: list[dict], rng: np.random.Generator, scale=None,
                 n: int = PART_SAMPLES) -> np.ndarray:
    """``cd._load_and_combine_plys`` then sampling: each part's surface at rest, moved from its own box
    centre to its (zero-centred) dictionary box centre, optionally scaled per axis about that centre
    first; ``n`` samples per part, float32 (K, n, 3).

    :param asset: the asset the dictionary was written from (its parts in the same order)
    :param tree: the zero-centred diffuse tree
    :param rng: the generator of the samples
    :param scale: per-axis scale of the part meshes (``CD``'s ``scale_factor``), None: none
    :param n: samples per part
    """
    rest = asset.rest_configuration()
    out = np.zeros((len(tree), n, 3), dtype=np.float32)
    for part, node in zip(asset_parts(asset), tree):
        triangles = part_triangles(asset, part, rest)
        points = triangles.reshape(-1, 3)
        centered = triangles - (points.min(0) + points.max(0)) / 2
        if scale is not None:
            centered = centered * np.asarray(scale, dtype=np.float64)
        out[node["id"]] = sample_trimesh_way(centered + np.asarray(node["aabb"]["center"], np.float64), n, rng)
    return out


def chamfer(gen_asset: ArticulatedAsset, gen: dict, gt_asset: ArticulatedAsset, gt: dict,
            rng: np.random.Generator, n_states: int = N_STATES) -> tuple[dict[str, float], np.ndarray]:
    """``CD(gen, .., gt, .., include_base=True)``: ``({"AS-CD", "RS-CD"}, the per-axis factor it rescales
    the caller's prediction dictionary by)``.

    :param gen_asset: the predicted asset (its part meshes)
    :param gen: its object dictionary
    :param gt_asset: the ground-truth asset
    :param gt: its object dictionary
    :param rng: the generator of the part samples
    :param n_states: articulation states
    """
    gen_tree, gt_tree = copy.deepcopy(gen["diffuse_tree"]), copy.deepcopy(gt["diffuse_tree"])
    zero_center(gen_tree)
    zero_center(gt_tree)
    factor = overall_size(gen_tree) / overall_size(gt_tree)  # gen / gt: the inverse of IoU_cDist's
    gen_to_gt, gt_to_gen = hungarian_mapping(gen_tree, gt_tree), hungarian_mapping(gt_tree, gen_tree)
    gen_points = part_samples(gen_asset, gen_tree, rng, factor)
    gt_points = part_samples(gt_asset, gt_tree, rng)
    one = _cd_one_way(gen_points, gt_points, gen_tree, gt_tree, gen_to_gt, n_states)
    two = _cd_one_way(gt_points, gen_points, gt_tree, gen_tree, gt_to_gen, n_states)
    return {"AS-CD": (one[0] + two[0]) / 2, "RS-CD": (one[1] + two[1]) / 2}, factor


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """SINGAPO's RS/AS-IoU, RS/AS-cDist, RS/AS-CD and AOR of ``pred`` against ``gt``, in the order
    ``scripts/eval_metrics.py`` computes them (CD, AOR, IoU_cDist), with its side effects.

    :param pred: the predicted asset
    :param gt: the ground-truth asset
    :param seed: seed of the box samples (legacy ``RandomState``) and of the part samples (``Generator``)
    """
    require_geometry(gt)
    require_geometry(pred, "prediction")
    gen, truth = object_dict(pred), object_dict(gt)
    cd, factor = chamfer(pred, gen, gt, truth, np.random.default_rng(seed))
    rescale(gen["diffuse_tree"], factor)  # CD's side effect on the caller's prediction dictionary
    random = np.random.RandomState(seed)
    overlap = aor(gen, random)
    metrics = {**iou_cdist(gen, truth, random), **cd, "AOR": overlap}
    notes = [] if overlap is not None else ["AOR: no two sibling parts (the code returns -1)"]
    metrics = {key: metrics[key] for key, _ in INFO.columns}
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
