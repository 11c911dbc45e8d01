"""FreeArt3D's protocol: CD, F-Score@0.05, AxisErr and PivotErr after its own normalization and alignment.

Facts, from ``PeterZs/FreeArt3D`` (the public copy of the authors' code) at commit
0320aebd0204bda8fe881dd83a90309f2ae80258:

- states (``preprocess_partnet_mesh.py``, ``process_state``): 6 meshes, state ``k`` with the target joint
  at ``lower + (upper - lower) * k / 5`` (no limit: revolute ``[-1.57079, 1.57079]``, prismatic ``[0,
  0.5]``); ``evaluate_partnet.py`` reads them in reverse (its ``qpos_id`` 0 is state 5, the upper limit);
  frame: the glTF meshes are Y-up, PartNet-Mobility's own mesh frame (spark-bench's world is that frame
  turned Z-up by the root joint: :data:`WORLD_TO_MESH` undoes it);
- normalization (``evaluate_partnet.py``, main loop): each state's mesh scaled so its longest side is
  **1**, then centred on its *surface* centroid (``trimesh``'s area-weighted ``Trimesh.centroid``);
- alignment (``auto_align_mesh_with_scale_and_rotz``, called with ``scale_min=0.5, scale_max=1.5``), per
  state: for each turn about the mesh frame's Z in ``linspace(0, 360, 12)`` (0 and 360 both: 11 distinct
  turns) and each scale in ``linspace(0.5, 1.5, 10)`` (**1.0 is not in the grid**: 0.944 and 1.056 are
  the nearest, so even a perfect prediction is rescaled), the turned prediction scaled to the ground
  truth's longest side times that scale; 2,000 samples of each (``mesh.sample``); Open3D point-to-point
  ICP (``eval_utils/utils_3d.py``, ``open3d_icp_api``) prediction -> truth at a correspondence distance
  of 0.08 then 0.05 (times the truth's longest side, 1), and truth -> prediction likewise; the start
  with the largest sum of the two fitnesses wins (its prediction -> truth transform);
- CD / F (``eval_utils/neucon_eval_utils.py``, ``eval_mesh(threshold=0.05, down_sample=None)``):
  100,000 samples of each mesh as float32; ``dist1`` = mean prediction -> truth distance, ``dist2`` =
  mean truth -> prediction (Euclidean); ``prec`` / ``recal`` the fractions below 0.05; ``fscore = 2 P R
  / (P + R)`` (NaN at 0: None here); each the mean over the 6 states; the CD reported here is ``dist1 +
  dist2`` (the code stores the two means, not their sum);
- joints (``eval_utils/joints.py``, ``Joint`` / ``eval_joint``; normalized with the qpos_id 0 state's
  scale, centroid and alignment): the ground truth's URDF origin and axis scaled and moved like its mesh;
  the prediction's through its scale, centroid, turn, scale and ICP transform with ``transform_points``
  on the origin **and the direction**, i.e. directions transformed with w = 1 (the ICP translation is
  added to the direction: reproduced); ``joint_axis_err`` = ``min(arccos(a . b), arccos(-a . b))``
  radians (NaN when rounding puts ``|a . b|`` above 1: reproduced); ``joint_orig_err`` for a revolute
  ground truth = ``|(o_p - o_g) . (a_p x a_g)| / |a_p x a_g|`` in the unit-longest-side frame (NaN for
  parallel axes, 0 / 0: reproduced, None here); none for a prismatic ground truth.

Adapted: FreeArt3D's objects have one joint (the first of its URDF) and move it alone; here every movable
joint moves through the states together and each ground-truth joint is paired with a predicted one by
spark-bench's part matching on the aligned upper-limit state (AxisErr / PivotErr are the means over the
pairs); its own outputs' OpenGL-to-OpenCV joint conversion (``method == 'ours'``) is not applied (an
asset's joints are already in its frame). Not reproduced: the CLIP similarity of rendered views (Blender
and CLIP). Not deterministic in the paper's code: ``mesh.sample`` is unseeded (since trimesh 4 a
generator seeded from OS entropy, which ``np.random.seed(0)`` does not reach) and ICP starts from those
samples; here one generator seeded by ``seed`` draws every sample in the code's order (per state and
start: prediction then truth; then the 100,000 of each), so the same generator behind trimesh's
``mesh.sample`` reproduces the paper's numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Joint
from spark_bench.metrics.align import rigid_fit
from spark_bench.metrics.matching import match_parts, part_cost_matrix
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.parts import (
    asset_parts,
    require_geometry,
    sample_trimesh_way,
    surface_centroid,
    triangles_extent,
)
from spark_bench.metrics.shape import build_tree, mutual_nearest_distances, query_nearest, thread_limit

#: spark-bench's world (Z-up, front -X) to PartNet-Mobility's mesh frame (Y-up, front +Z), FreeArt3D's.
WORLD_TO_MESH = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
#: States (``--num_states 6``).
N_STATES = 6
#: Turns about the mesh frame's Z, degrees (``np.linspace(0, 360, 12)``).
ANGLES_DEG = tuple(np.linspace(0, 360, 12))
#: Scales (``np.linspace(scale_min=0.5, scale_max=1.5, 10)``): 1.0 is not among them.
SCALES = tuple(np.linspace(0.5, 1.5, 10))
#: Samples per mesh for ICP (``ICP_POINTS=2000``) and for CD / F (``mesh.sample(100000)``).
ICP_POINTS, EVAL_POINTS = 2000, 100_000
#: ICP correspondence distances, times the truth's longest side (``0.08``, then ``0.05``).
ICP_COARSE, ICP_FINE = 0.08, 0.05
#: Open3D's default ``ICPConvergenceCriteria``: relative fitness, relative RMSE, iterations.
ICP_RELATIVE_FITNESS, ICP_RELATIVE_RMSE, ICP_MAX_ITERATIONS = 1e-6, 1e-6, 30
#: F-Score threshold (``eval_mesh(threshold=.05 * 1.0)``).
THRESHOLD = 0.05
#: Limits of a joint without any (``process_state``).
DEFAULT_LIMITS = {"revolute": (-1.57079, 1.57079), "prismatic": (0.0, 0.5)}
#: Samples per part for pairing the joints (spark-bench's matching, not the paper's).
MATCH_SAMPLES = 2048

INFO = ProtocolInfo(
    name="freeart3d",
    paper="FreeArt3D (Chen et al. 2025)",
    source="github.com/PeterZs/FreeArt3D @ 0320aebd: evaluate_partnet.py (main loop, "
           "auto_align_mesh_with_scale_and_rotz), eval_utils/neucon_eval_utils.py (eval_mesh), "
           "eval_utils/joints.py (Joint, eval_joint), eval_utils/utils_3d.py (open3d_icp_api), "
           "preprocess_partnet_mesh.py (process_state)",
    units={"chamfer_distance": "longest side 1", "dist1": "longest side 1", "dist2": "longest side 1",
           "f_score": "fraction", "precision": "fraction", "recall": "fraction", "axis_err": "rad",
           "pivot_err": "longest side 1"},
    columns=(("chamfer_distance", "CD↓"), ("f_score", "F-Score↑"), ("axis_err", "Axis Err.↓"),
             ("pivot_err", "Pivot Err.↓")),
    differs="Longest side 1 (spark-bench: 2, so PivotErr and CD are about half of spark-bench's for the "
            "same prediction), centred on the surface centroid of each state, aligned per state by a "
            "turn x scale grid (no scale 1.0) + Open3D ICP chosen by ICP fitness, CD / F averaged over 6 "
            "states with tau = 0.05, directions transformed as points (w = 1), PivotErr undefined "
            "(NaN) for parallel axes where spark-bench takes the point-to-line distance.",
    deterministic=False,
)


# ----- states and normalization --------------------------------------------------------------------------
def joint_limits(joint: Joint) -> tuple[float, float]:
    """The joint's limits as ``process_state`` reads them (its defaults when the URDF gives none)."""
    kind = "prismatic" if joint.type == JointType.PRISMATIC else "revolute"
    if joint.type == JointType.CONTINUOUS or not joint.has_limits:
        return DEFAULT_LIMITS[kind]
    return float(joint.lower), float(joint.upper)


def state_triangles(asset: ArticulatedAsset, fraction: float, links=None) -> np.ndarray:
    """The surface with every movable joint at ``lower + (upper - lower) * fraction``, mesh frame."""
    q = {}
    for joint in asset.movable_joints():
        lower, upper = joint_limits(joint)
        q[joint.name] = lower + (upper - lower) * fraction
    from spark_bench.metrics.geometry import posed_triangles

    return posed_triangles(asset, q, links) @ WORLD_TO_MESH.T


@dataclass
class Normalization:
    """One state's normalization: ``x -> x * scale - centroid`` (the centroid after scaling).

    :param scale: ``1 / longest side``
    :param centroid: surface centroid of the scaled mesh
    """

    scale: float
    centroid: np.ndarray

    def apply(self, triangles: np.ndarray) -> np.ndarray:
        return triangles * self.scale - self.centroid


def normalization(triangles: np.ndarray) -> Normalization:
    """``apply_scale(1 / extents.max())`` then ``apply_translation(-centroid)``."""
    scale = 1.0 / triangles_extent(triangles)
    return Normalization(scale, surface_centroid(triangles * scale))


# ----- Open3D's point-to-point ICP --------------------------------------------------------------------------
def _correspondences(points: np.ndarray, tree, threshold: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """``(source rows, target rows, fitness, inlier RMSE)`` as Open3D's
    ``GetRegistrationResultAndCorrespondences`` finds them (nearest target point within ``threshold``)."""
    distance, index = query_nearest(tree, points)
    inlier = distance < threshold
    rows = np.flatnonzero(inlier)
    if len(rows) == 0:
        return rows, rows, 0.0, 0.0
    return rows, index[rows], len(rows) / len(points), float(np.sqrt(np.sum(distance[rows] ** 2) / len(rows)))


def icp(source: np.ndarray, target: np.ndarray, threshold: float, initial: np.ndarray | None = None,
        tree=None) -> tuple[np.ndarray, float]:
    """Open3D's ``registration_icp`` (point to point, no scaling, default criteria): ``(4x4, fitness)``.

    :param source: (N, 3) points moved onto ``target``
    :param target: (M, 3) points
    :param threshold: maximum correspondence distance
    :param initial: the starting transform (identity)
    :param tree: a k-d tree on ``target`` (built when None)
    """
    tree = build_tree(target) if tree is None else tree
    matrix = np.eye(4) if initial is None else np.array(initial, dtype=np.float64)
    moved = source @ matrix[:3, :3].T + matrix[:3, 3]
    rows, cols, fitness, rmse = _correspondences(moved, tree, threshold)
    for _ in range(ICP_MAX_ITERATIONS):
        update = rigid_fit(moved[rows], target[cols]) if len(rows) else np.eye(4)
        matrix = update @ matrix
        moved = moved @ update[:3, :3].T + update[:3, 3]
        previous = (fitness, rmse)
        rows, cols, fitness, rmse = _correspondences(moved, tree, threshold)
        if abs(previous[0] - fitness) < ICP_RELATIVE_FITNESS and abs(previous[1] - rmse) < ICP_RELATIVE_RMSE:
            break
    return matrix, fitness


def _homogeneous(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``transform_points``: ``[p, 1] @ M^T``, divided by w."""
    points = np.concatenate([points, np.ones((len(points), 1))], axis=1) @ matrix.T
    return points[:, :3] / points[:, 3:]


def rotation_z(angle_deg: float) -> np.ndarray:
    """``Rt_to_pose(rotz_np(np.deg2rad(angle))[0])``: 4x4 turn about Z."""
    c, s = np.cos(np.deg2rad(angle_deg)), np.sin(np.deg2rad(angle_deg))
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


@dataclass
class Alignment:
    """The alignment of one state: ``x -> tsfm(turn(x) * fit * grid_scale)``.

    :param turn: 4x4 turn about the mesh frame's Z
    :param fit: the truth's longest side over the turned prediction's
    :param tsfm: 4x4 ICP transform
    :param grid_scale: the grid scale of the winning start
    """

    turn: np.ndarray
    fit: float
    tsfm: np.ndarray
    grid_scale: float = 1.0

    @property
    def scale(self) -> float:
        """The scale ``auto_align_mesh_with_scale_and_rotz`` returns (``final_scale * scale1``)."""
        return self.grid_scale * self.fit

    def apply(self, triangles: np.ndarray) -> np.ndarray:
        flat = triangles.reshape(-1, 3)
        return _homogeneous(_homogeneous(flat, self.turn) * self.fit * self.grid_scale,
                            self.tsfm).reshape(triangles.shape)


def auto_align(gt: np.ndarray, pred: np.ndarray, rng: np.random.Generator, angles=ANGLES_DEG,
               scales=SCALES) -> Alignment:
    """``auto_align_mesh_with_scale_and_rotz``: the grid start whose ICP fitnesses sum highest.

    :param gt: normalized ground-truth triangles
    :param pred: normalized predicted triangles
    :param rng: the generator of the ICP samples (prediction then truth, per start)
    :param angles: turns, degrees
    :param scales: grid scales
    """
    with thread_limit(1):  # 2,000-point queries: threads cost more than they save
        return _auto_align(gt, pred, rng, angles, scales)


def _auto_align(gt: np.ndarray, pred: np.ndarray, rng: np.random.Generator, angles, scales) -> Alignment:
    gt_side = triangles_extent(gt)
    best = None
    for angle in angles:
        turn = rotation_z(angle)
        turned = _homogeneous(pred.reshape(-1, 3), turn).reshape(pred.shape)
        fit = gt_side / triangles_extent(turned)
        for scale in scales:
            start = turned * fit * scale
            pred_points = sample_trimesh_way(start, ICP_POINTS, rng)
            gt_points = sample_trimesh_way(gt, ICP_POINTS, rng)
            pred_tree, gt_tree = build_tree(pred_points), build_tree(gt_points)
            forward, _ = icp(pred_points, gt_points, ICP_COARSE * gt_side, tree=gt_tree)
            forward, fitness = icp(pred_points, gt_points, ICP_FINE * gt_side, forward, gt_tree)
            backward, _ = icp(gt_points, pred_points, ICP_COARSE * gt_side, tree=pred_tree)
            _, fitness_back = icp(gt_points, pred_points, ICP_FINE * gt_side, backward, pred_tree)
            if best is None or fitness + fitness_back > best[0]:
                best = (fitness + fitness_back, angle, scale, forward)
    _, angle, scale, forward = best
    turn = rotation_z(angle)
    turned = _homogeneous(pred.reshape(-1, 3), turn)
    return Alignment(turn, gt_side / float((turned.max(0) - turned.min(0)).max()), forward, float(scale))


def eval_mesh(pred: np.ndarray, gt: np.ndarray, rng: np.random.Generator, n: int = EVAL_POINTS,
              threshold: float = THRESHOLD) -> dict[str, float]:
    """``eval_mesh``: ``n`` float32 samples of each mesh (prediction first), then :func:`eval_points`."""
    pred_points = sample_trimesh_way(pred, n, rng).astype(np.float32)
    gt_points = sample_trimesh_way(gt, n, rng).astype(np.float32)
    return eval_points(pred_points, gt_points, threshold)


def eval_points(pred_points: np.ndarray, gt_points: np.ndarray, threshold: float = THRESHOLD) -> dict[str, float]:
    """``eval_mesh`` on given samples: ``fscore`` (NaN when P + R = 0), ``dist1`` (mean prediction ->
    truth distance), ``dist2`` (truth -> prediction), ``prec``, ``recal``."""
    to_gt, to_pred = mutual_nearest_distances(np.asarray(pred_points, np.float64), np.asarray(gt_points, np.float64))
    precision, recall = float(np.mean(to_gt < threshold)), float(np.mean(to_pred < threshold))
    with np.errstate(invalid="ignore", divide="ignore"):
        fscore = float(np.float64(2 * precision * recall) / np.float64(precision + recall))
    return {"fscore": fscore, "dist1": float(np.mean(to_gt)), "dist2": float(np.mean(to_pred)),
            "prec": precision, "recal": recall}


# ----- joints -------------------------------------------------------------------------------------------------
@dataclass
class JointLine:
    """A joint as ``eval_utils/joints.py``'s ``Joint`` holds it (the direction is not kept unit).

    :param type: ``revolute`` (continuous counts as revolute) or ``prismatic``
    :param origin: a point on the axis
    :param direction: the axis direction (any length)
    """

    type: str
    origin: np.ndarray
    direction: np.ndarray

    def normalized(self, norm: Normalization) -> JointLine:
        """``apply_scale`` (origin and direction) then ``apply_translation`` (origin only)."""
        return JointLine(self.type, self.origin * norm.scale - norm.centroid, self.direction * norm.scale)

    def aligned(self, alignment: Alignment) -> JointLine:
        """``apply_transform(turn)``, ``apply_scale(scale)``, ``apply_transform(tsfm)``: both the origin and
        the direction through ``transform_points`` (w = 1: the ICP translation reaches the direction)."""
        both = np.stack([self.origin, self.direction])
        both = _homogeneous(_homogeneous(both, alignment.turn) * alignment.scale, alignment.tsfm)
        return JointLine(self.type, both[0], both[1])


def joint_lines(asset: ArticulatedAsset) -> dict[str, JointLine]:
    """Each movable joint's URDF axis line (every joint at 0), mesh frame."""
    frames = asset.joint_frames({j.name: 0.0 for j in asset.movable_joints()})
    return {name: JointLine("prismatic" if asset.joints[name].type == JointType.PRISMATIC else "revolute",
                            point @ WORLD_TO_MESH.T, direction @ WORLD_TO_MESH.T)
            for name, (point, direction) in frames.items()}


def eval_joint(pred: JointLine, gt: JointLine) -> tuple[float | None, float | None]:
    """``eval_joint``: ``(joint_axis_err radians, joint_orig_err)``, None where the code gives NaN (a
    prismatic ground truth has no origin error; parallel axes divide 0 by 0)."""
    a = pred.direction / np.linalg.norm(pred.direction)
    b = gt.direction / np.linalg.norm(gt.direction)
    with np.errstate(invalid="ignore", divide="ignore"):
        norms = np.linalg.norm(a) * np.linalg.norm(b)
        axis_err = min(np.arccos(np.dot(a, b) / norms), np.arccos(np.dot(a, -b) / norms))
        orig_err = np.nan
        if gt.type == JointType.REVOLUTE:
            normal = np.cross(a, b)
            orig_err = np.linalg.norm(np.dot(pred.origin - gt.origin, normal)) / np.linalg.norm(normal)
    return (None if np.isnan(axis_err) else float(axis_err)), (None if np.isnan(orig_err) else float(orig_err))


def joint_pairs(pred: ArticulatedAsset, gt: ArticulatedAsset, pred_norm: Normalization, gt_norm: Normalization,
           alignment: Alignment) -> list[tuple[str, str]]:
    """``(pred joint, gt joint)`` pairs: spark-bench's part matching on the aligned upper-limit state."""
    rng = np.random.default_rng(0)

    def samples(asset, transform):
        out = {}
        for part in asset_parts(asset):
            if part.joint is not None:
                triangles = transform(state_triangles(asset, 1.0, part.links))
                out[part.joint.name] = sample_trimesh_way(triangles, MATCH_SAMPLES, rng)
        return out

    pred_parts = samples(pred, lambda t: alignment.apply(pred_norm.apply(t)))
    gt_parts = samples(gt, gt_norm.apply)
    pred_names, gt_names = list(pred_parts), list(gt_parts)
    if not pred_names or not gt_names:
        return []
    cost = part_cost_matrix([pred_parts[n] for n in pred_names], [gt_parts[n] for n in gt_names])
    return [(pred_names[p.pred], gt_names[p.gt]) for p in match_parts(cost)]


def joint_errors(pred: ArticulatedAsset, gt: ArticulatedAsset, pred_norm: Normalization,
                 gt_norm: Normalization, alignment: Alignment, notes: list[str],
                 pairs: list[tuple[str, str]] | None = None) -> dict[str, float | None]:
    """Mean AxisErr and PivotErr over the paired joints, after the qpos_id 0 state's normalization and
    alignment.

    :param pred: the predicted asset
    :param gt: the ground-truth asset
    :param pred_norm: the prediction's normalization at the upper-limit state
    :param gt_norm: the ground truth's normalization at the upper-limit state
    :param alignment: the prediction's alignment at the upper-limit state
    :param notes: where to say what was left out
    :param pairs: ``(pred joint, gt joint)`` pairs (default: :func:`joint_pairs`)
    """
    pred_lines, gt_lines = joint_lines(pred), joint_lines(gt)
    if pairs is None:
        pairs = joint_pairs(pred, gt, pred_norm, gt_norm, alignment)
    if len(pairs) < len(gt_lines):
        notes.append(f"{len(gt_lines) - len(pairs)} ground-truth joint(s) without a predicted joint: not scored")
    axis, pivot = [], []
    for pred_name, gt_name in pairs:
        axis_err, orig_err = eval_joint(pred_lines[pred_name].normalized(pred_norm).aligned(alignment),
                                        gt_lines[gt_name].normalized(gt_norm))
        axis.append(axis_err)
        if gt_lines[gt_name].type == JointType.REVOLUTE:
            pivot.append(orig_err)
            if orig_err is None:
                notes.append(f"joint {gt_name}: PivotErr undefined (parallel axes: 0 / 0 in FreeArt3D's code)")
        if axis_err is None:
            notes.append(f"joint {gt_name}: AxisErr undefined (|a . b| > 1 by rounding: NaN in FreeArt3D's code)")
    axis, pivot = [v for v in axis if v is not None], [v for v in pivot if v is not None]
    return {"axis_err": float(np.mean(axis)) if axis else None,
            "pivot_err": float(np.mean(pivot)) if pivot else None}


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0, angles=ANGLES_DEG, scales=SCALES,
          n_states: int = N_STATES) -> ProtocolResult:
    """FreeArt3D's CD (``dist1 + dist2``), F-Score@0.05, AxisErr and PivotErr of ``pred`` against ``gt``.

    :param pred: the predicted asset
    :param gt: the ground-truth asset
    :param seed: seed of the one generator every sample is drawn from
    :param angles: the alignment's turns (degrees); the paper's grid by default
    :param scales: the alignment's scales; the paper's grid (without 1.0) by default
    :param n_states: states (the paper's 6)
    """
    require_geometry(gt)
    require_geometry(pred, "prediction")
    rng = np.random.default_rng(seed)
    notes: list[str] = []
    per_state: dict[str, list[float]] = {}
    joints: dict[str, float | None] = {}
    for qpos_id in range(n_states):
        fraction = (n_states - 1 - qpos_id) / (n_states - 1)
        gt_raw, pred_raw = state_triangles(gt, fraction), state_triangles(pred, fraction)
        gt_norm, pred_norm = normalization(gt_raw), normalization(pred_raw)
        gt_tri, pred_tri = gt_norm.apply(gt_raw), pred_norm.apply(pred_raw)
        alignment = auto_align(gt_tri, pred_tri, rng, angles, scales)
        if qpos_id == 0:
            pairs = joint_pairs(pred, gt, pred_norm, gt_norm, alignment)
            notes.append("joint pairs (prediction -> ground truth): "
                         + ", ".join(f"{p}->{g}" for p, g in pairs))
            joints = joint_errors(pred, gt, pred_norm, gt_norm, alignment, notes, pairs)
            notes.append(f"upper-limit state: turn {np.degrees(np.arctan2(alignment.turn[1, 0], alignment.turn[0, 0])):.1f}"
                         f" deg, grid scale {alignment.grid_scale:.4f} (1.0 is not in FreeArt3D's grid)")
        for key, value in eval_mesh(alignment.apply(pred_tri), gt_tri, rng).items():
            per_state.setdefault(key, []).append(value)
    mean = {key: float(np.mean(values)) for key, values in per_state.items()}
    f_score = None if np.isnan(mean["fscore"]) else mean["fscore"]
    metrics = {"chamfer_distance": mean["dist1"] + mean["dist2"], "f_score": f_score, **joints,
               "dist1": mean["dist1"], "dist2": mean["dist2"], "precision": mean["prec"], "recall": mean["recal"]}
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
