"""PartCrafter's protocol: Chamfer distance, F-Score@0.1 and part-overlap IoU in its [-1, 1] frame.

Facts, from ``YumengHe/PartCrafter`` at commit 432a0625802f3a44292125b5f7b33b7a3ff61d7f:

- frame (``src/utils/data_utils.py``, ``normalize_mesh``, called by ``scene_to_parts``): the whole
  scene's axis-aligned box is centred at the origin and scaled so its longest side is **2**;
- samples (``configs/*.yaml``, ``val.metric.cd_num_samples``): **204,800** points per surface, drawn by
  ``trimesh``'s ``mesh.sample`` (``src/utils/metric_utils.py``, ``sample_from_mesh``);
- CD and F (``metric_utils.py``, ``compute_cd_and_f_score``): nearest-neighbour Euclidean (not
  squared) distances by scikit-learn's k-d tree; ``CD = mean(d_21) + mean(d_12)``; precision and recall
  are the fractions below ``threshold`` (``val.metric.f1_score_threshold`` = **0.1**), as float32 means;
  ``F = 2 P R / (P + R)``, **NaN** when ``P + R = 0`` (here: None; spark-bench's own F gives 0);
- per part (``src/train_partcrafter.py``, the validation loop): each ground-truth part against its
  predicted part; a missing predicted part is a one-vertex dummy mesh (every sample at the origin); a
  NaN CD or F becomes ``default_cd`` = 1e6 / ``default_f1`` = 0; the scene's numbers are the means over
  the parts (``parts_chamfer_distance``, ``parts_f_score``);
- IoU (``metric_utils.py``, ``compute_IoU_for_scene`` / ``compute_IoU`` / ``get_voxel_set``): the mean
  over pairs of the predicted parts of the IoU of their filled voxelizations (``mesh.voxelized(pitch =
  2 / 64).fill()``, voxel centres rounded to the grid); lower is better (parts should not overlap);
  it needs at least two parts (None otherwise: the code raises).

Reproduced: all of the above. Adapted: PartCrafter's parts come out in the ground truth's order, so it
pairs part ``n`` with part ``n``; an asset's parts (:mod:`.parts`) have no common order, so they are
paired by spark-bench's part matching (Hungarian on part Chamfer distance at rest). Not deterministic
in the paper's code: trimesh's sampler is unseeded (since trimesh 4 a generator seeded from OS entropy;
``np.random.seed`` does not reach it); here one generator seeded by ``seed`` draws every sample, in the
order the paper's functions draw them (prediction, then ground truth).
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.geometry import has_area, posed_triangles
from spark_bench.metrics.matching import match_parts, part_cost_matrix
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.parts import (
    asset_parts,
    part_triangles,
    require_geometry,
    sample_trimesh_way,
)
from spark_bench.metrics.shape import mutual_nearest_distances

#: Samples per surface (``configs/*.yaml``: ``val.metric.cd_num_samples``).
N_SAMPLES = 204_800
#: F-Score threshold in the [-1, 1] frame (``val.metric.f1_score_threshold``).
THRESHOLD = 0.1
#: Longest side of the normalized scene (``normalize_mesh(scale=2.0)``).
SCENE_SIZE = 2.0
#: Voxels along the scene's side for the part IoU (``compute_IoU(num_grids=64, scale=2.0)``).
IOU_GRIDS = 64
#: What a NaN part CD / F becomes in the per-part means (``val.metric.default_cd`` / ``default_f1``).
DEFAULT_CD, DEFAULT_F1 = 1e6, 0.0
#: Samples for pairing the parts (spark-bench's matching, not the paper's).
MATCH_SAMPLES = 4096

INFO = ProtocolInfo(
    name="partcrafter",
    paper="PartCrafter (Lin et al. 2025)",
    source="github.com/YumengHe/PartCrafter @ 432a0625: src/utils/metric_utils.py (compute_cd_and_f_score, "
           "compute_IoU_for_scene), src/utils/data_utils.py (normalize_mesh), src/train_partcrafter.py "
           "(per-part validation), configs/*.yaml (cd_num_samples 204800, f1_score_threshold 0.1)",
    units={"chamfer_distance": "[-1,1] scene frame", "f_score": "fraction", "iou": "fraction",
           "parts_chamfer_distance": "[-1,1] scene frame", "parts_f_score": "fraction"},
    columns=(("chamfer_distance", "CD↓"), ("f_score", "F-Score↑"), ("iou", "IoU↓"),
             ("parts_chamfer_distance", "Part CD↓"), ("parts_f_score", "Part F-Score↑")),
    differs="Same CD / F formula as spark-bench (Euclidean, two one-sided means) but in a frame whose "
            "longest side is 2 centred on the box at rest, with 204,800 unseeded trimesh samples, "
            "tau = 0.1, F undefined (NaN) where spark-bench gives 0, parts paired by index in the paper "
            "(here by part matching), and IoU between predicted parts (overlap, lower is better).",
    deterministic=False,
)


def scene_normalization(triangles: np.ndarray) -> tuple[np.ndarray, float]:
    """``(center, scale)`` of ``normalize_mesh``: the box centre and ``2 / longest side``."""
    points = triangles.reshape(-1, 3)
    low, high = points.min(0), points.max(0)
    return (low + high) / 2.0, SCENE_SIZE / float((high - low).max())


def cd_and_f(pred_points: np.ndarray, gt_points: np.ndarray, threshold: float = THRESHOLD
             ) -> tuple[float, float | None]:
    """``compute_cd_and_f_score`` on two samples: ``(CD, F)``, F None where the code gives NaN.

    :param pred_points: samples of the first mesh (the prediction)
    :param gt_points: samples of the second mesh (the ground truth)
    :param threshold: F-Score threshold
    """
    d_12, d_21 = mutual_nearest_distances(pred_points, gt_points)
    cd = float(np.mean(d_21) + np.mean(d_12))
    precision_1 = float(np.mean((d_12 < threshold).astype(np.float32)))
    precision_2 = float(np.mean((d_21 < threshold).astype(np.float32)))
    total = np.float32(precision_1) + np.float32(precision_2)
    if total == 0:
        return cd, None
    return cd, float(2 * np.float32(precision_1) * np.float32(precision_2) / total)


def _normalized(asset: ArticulatedAsset) -> tuple[np.ndarray, list[np.ndarray]]:
    """The asset's whole surface and its parts' surfaces at rest, in its normalized scene frame."""
    rest = asset.rest_configuration()
    whole = posed_triangles(asset, rest)
    center, scale = scene_normalization(whole)
    # the parts as scene_to_parts gets them: the Scene's transform S T applied, x s + (-c s) (the whole
    # mesh as normalize_mesh moves a Trimesh: (x - c) s)
    parts = [part_triangles(asset, part, rest) * scale + (-center * scale) for part in asset_parts(asset)]
    return (whole - center) * scale, [p for p in parts if has_area(p)]


def voxel_set(triangles: np.ndarray, grids: int = IOU_GRIDS) -> set:
    """``get_voxel_set``: the filled voxelization's centres, rounded to grid indices (pitch 2 / grids)."""
    import trimesh

    pitch = SCENE_SIZE / grids
    mesh = trimesh.Trimesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3))
    points = mesh.voxelized(pitch=pitch).fill().points
    return set(map(tuple, np.round(points / pitch).astype(int)))


def parts_iou(parts: list[np.ndarray]) -> float | None:
    """``compute_IoU_for_scene``: mean voxel IoU over pairs of parts; None for fewer than two parts."""
    if len(parts) < 2:
        return None
    sets = [voxel_set(p) for p in parts]
    ious = []
    for i in range(len(sets)):
        for j in range(i + 1, len(sets)):
            union = sets[i] | sets[j]
            ious.append(len(sets[i] & sets[j]) / len(union) if union else 0.0)
    return float(np.mean(ious))


def _per_part(pred_parts: list[np.ndarray], gt_parts: list[np.ndarray], rng: np.random.Generator,
              n_samples: int, notes: list[str]) -> tuple[float, float]:
    """Mean part CD and F over the ground-truth parts (the validation loop's defaults for NaN)."""
    match_rng = np.random.default_rng(0)
    cost = part_cost_matrix([sample_trimesh_way(p, MATCH_SAMPLES, match_rng) for p in pred_parts],
                            [sample_trimesh_way(g, MATCH_SAMPLES, match_rng) for g in gt_parts])
    partner = {pair.gt: pair.pred for pair in match_parts(cost)}
    cds, fs = [], []
    for j, gt in enumerate(gt_parts):
        if j in partner:
            pred_points = sample_trimesh_way(pred_parts[partner[j]], n_samples, rng)
        else:  # PartCrafter's dummy mesh: every sample at the origin
            pred_points = np.zeros((n_samples, 3))
            notes.append(f"ground-truth part {j} has no predicted part: scored against a point at the origin")
        cd, f = cd_and_f(pred_points, sample_trimesh_way(gt, n_samples, rng))
        cds.append(DEFAULT_CD if np.isnan(cd) else cd)
        fs.append(DEFAULT_F1 if f is None else f)
    return float(np.mean(cds)), float(np.mean(fs))


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0,
          n_samples: int = N_SAMPLES) -> ProtocolResult:
    """PartCrafter's CD, F-Score@0.1, part IoU and per-part CD / F of ``pred`` against ``gt``.

    :param pred: the predicted asset
    :param gt: the ground-truth asset
    :param seed: seed of the one generator every sample is drawn from
    :param n_samples: samples per surface (the paper's 204,800; CD depends on it)
    """
    rng = np.random.default_rng(seed)
    notes: list[str] = []
    require_geometry(gt)
    gt_whole, gt_parts = _normalized(gt)
    if not has_area(posed_triangles(pred, pred.rest_configuration())):
        notes.append("the prediction has no geometry: PartCrafter's code has no number (NaN)")
        metrics = {name: None for name in INFO.units}
        return ProtocolResult(INFO.name, metrics, dict(INFO.units), notes)
    pred_whole, pred_parts = _normalized(pred)
    cd, f = cd_and_f(sample_trimesh_way(pred_whole, n_samples, rng), sample_trimesh_way(gt_whole, n_samples, rng))
    if f is None:
        notes.append("F-Score undefined (no point within 0.1 either way): NaN in PartCrafter's code")
    parts_cd, parts_f = _per_part(pred_parts, gt_parts, rng, n_samples, notes)
    metrics = {"chamfer_distance": cd, "f_score": f, "iou": parts_iou(pred_parts),
               "parts_chamfer_distance": parts_cd, "parts_f_score": parts_f}
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
