"""CAGE's protocol: ID (squared CD over states), AID (part-box IoU over states), AOR and graph accuracy.

Facts, from ``3dlg-hcvc/cage`` at commit fb4a70c980848149e3938dab02f85145712831eb (the object is its
``object.json`` "diffuse_tree", written from an asset by
:func:`~spark_bench.metrics.protocols.parts.object_dict`), and SINGAPO's graph check:

- ID (``metrics/id.py``, ``ID``): 2,048 samples per part (PyTorch3D ``sample_points_from_meshes``), each
  part's mesh at its box centre, **no** centring or rescaling; the samples of all parts merged; at each of
  5 states (``linspace(0, 1, 5)``) the parts moved by ``objects/motions.py``'s ``transform_all_parts``
  (in place: a part moves with its own joint and its parent's only; revolute parts ``sign(range[1]) *
  90`` degrees * state, ``rotation_fix_range=True``; prismatic ``range[1] * state``); PyTorch3D's
  ``chamfer_distance`` of the merged samples, **squared** distances, ``mean(d_ab^2) + mean(d_ba^2)``
  (computed both ways and averaged: the same number); ID = the mean over the states;
- AID (``metrics/aid.py``, ``AID``; called as ``AID(requirement, candidate, num_states=5)`` by
  ``retrieval/obj_retrieval.py``, ``find_obj_candidates``: the requirement is the generated object): the
  candidate (here the ground truth) rescaled **per axis** to the requirement's (the prediction's)
  overall box size, no centring; both scaled by 10 (``sampling_scale_factor``: IoU does not change);
  each requirement part paired with the candidate part of nearest box centre (``find_part_mapping``,
  not one-to-one), the bases forced together; per pair and state the IoU of the moved boxes from
  10,000 uniform samples per box (``metrics/iou.py``, ``sampling_iou``: sampled even at rest, float64);
  the base left out (``iou_include_base=False``); AID = 1 - the mean IoU; handles are stripped by name
  (``compare_handles=False``: a part named "handle"; an asset's part names are link names, so none);
- AOR (``metrics/aor.py``, ``AOR``): on the prediction alone, 20 states, revolute parts through their
  **full** range (its own ``transform_all_parts``, float64, identity motions at state 0), the mean
  sampled IoU of sibling boxes per state, NaN pairs skipped, the mean over the states; -1 (no sibling
  pair) is None;
- graph accuracy (``preprocess.py``, ``_get_tree_hash``; SINGAPO's ``scripts/graph_pred/eval.py``,
  ``get_hash``, which computes the accuracy): networkx's ``weisfeiler_lehman_graph_hash`` (3 iterations,
  no labels) of the directed tree with an edge from each part to its parent; 1 when the prediction's
  hash equals the ground truth's, else 0 (a WL hash can collide for different trees: reproduced).

Not deterministic in the paper's code: the box samples come from the unseeded global ``np.random``
(here ``np.random.RandomState(seed)``, drawn in the same order: ``np.random.seed(seed)`` before the
paper's ``AID`` and ``AOR`` gives the same samples); ID samples points on the GPU (PyTorch3D, ``.cuda()``:
CUDA-only), here trimesh's sampler from a generator seeded by ``seed``, in float64 where PyTorch3D uses
float32. Units: the asset's own (world) units, squared for ID.
"""

from __future__ import annotations

import copy

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.parts import object_dict, require_geometry
from spark_bench.metrics.protocols.singapo import (
    aor,
    base_index,
    box_bounds,
    move_points,
    part_samples,
    part_transforms,
    sampled_iou,
    squared_cd,
)

#: States of ID and AID (``ID(num_states=5)``; ``find_obj_candidates(num_states=5)`` for AID).
N_STATES = 5
#: States of AOR (``AOR(num_states=20)``).
AOR_STATES = 20
#: Samples per part for ID (``ID(num_samples=2048)``).
PART_SAMPLES = 2048
#: AID's ``sampling_scale_factor``.
SAMPLING_SCALE = 10
#: networkx's ``weisfeiler_lehman_graph_hash`` defaults: iterations and digest size (bytes).
WL_ITERATIONS, WL_DIGEST = 3, 16

INFO = ProtocolInfo(
    name="cage",
    paper="CAGE (Liu et al. 2024)",
    source="github.com/3dlg-hcvc/cage @ fb4a70c9: metrics/id.py, metrics/aid.py, metrics/aor.py, "
           "metrics/iou.py, objects/motions.py, objects/dict_utils.py, preprocess.py (_get_tree_hash); "
           "github.com/3dlg-hcvc/singapo @ 2199ef8c: scripts/graph_pred/eval.py (graph accuracy)",
    units={"ID": "asset units^2", "AID": "1 - IoU", "AOR": "IoU fraction", "graph_acc": "fraction"},
    columns=(("AOR", "AOR↓"), ("ID", "ID↓"), ("AID", "AID↓"), ("graph_acc", "Graph acc↑")),
    differs="Scores part boxes and merged part samples, not aligned surfaces: ID is a squared Chamfer "
            "distance in the asset's own units, over 5 states with revolute parts turned 90 degrees; "
            "AID is 1 - IoU of nearest-centre part boxes with the ground truth rescaled per axis to the "
            "prediction's box; graph accuracy compares Weisfeiler-Lehman hashes of the part trees; no "
            "axis / pivot error and no alignment.",
    deterministic=False,
)


def _rescale(tree: list[dict], factor) -> None:
    """CAGE's ``rescale_object`` (float64): box centres, sizes and joint origins times ``factor``."""
    for part in tree:
        part["aabb"]["center"] = np.array(part["aabb"]["center"]) * factor
        part["aabb"]["size"] = np.array(part["aabb"]["size"]) * factor
        if part["joint"]["type"] != JointType.FIXED:
            part["joint"]["axis"]["origin"] = np.array(part["joint"]["axis"]["origin"]) * factor


def _overall_size(tree: list[dict]) -> np.ndarray:
    """CAGE's ``compute_overall_bbox_size`` (float64)."""
    centers = np.array([p["aabb"]["center"] for p in tree], dtype=np.float64)
    halves = np.array([p["aabb"]["size"] for p in tree], dtype=np.float64) / 2
    return (centers + halves).max(0) - (centers - halves).min(0)


def nearest_mapping(tree_1: list[dict], tree_2: list[dict]) -> np.ndarray:
    """``find_part_mapping`` (not Hungarian): each part of ``tree_1`` to the first part of ``tree_2`` with
    the nearest box centre."""
    mapping = np.zeros(len(tree_1), dtype=np.int64)
    for i, a in enumerate(tree_1):
        best = np.inf
        for j, b in enumerate(tree_2):
            distance = np.linalg.norm(np.array(a["aabb"]["center"]) - np.array(b["aabb"]["center"]))
            if distance < best:
                mapping[i], best = j, distance
    return mapping


def aid(requirement: dict, candidate: dict, random: np.random.RandomState, n_states: int = N_STATES) -> float:
    """``AID(requirement, candidate, num_states)`` with its defaults: 1 - mean sampled part-box IoU.

    :param requirement: the object dictionary whose parts are scored (the prediction)
    :param candidate: the object dictionary it is compared with (the ground truth), rescaled per axis
    :param random: the legacy generator of the box samples
    :param n_states: articulation states
    """
    req, cand = copy.deepcopy(requirement["diffuse_tree"]), copy.deepcopy(candidate["diffuse_tree"])
    _rescale(cand, _overall_size(req) / _overall_size(cand))
    _rescale(req, SAMPLING_SCALE)
    _rescale(cand, SAMPLING_SCALE)
    req_base, cand_base = base_index(req), base_index(cand)
    mapping = nearest_mapping(req, cand)
    mapping[req_base] = cand_base
    req_boxes = [box_bounds(p, np.float64) for p in req]
    cand_boxes = [box_bounds(p, np.float64) for p in cand]
    iou = np.zeros((len(req), n_states))
    for k, state in enumerate(np.linspace(0, 1, n_states)):
        req_motions = part_transforms(req, state, True, False, np.float64)
        cand_motions = part_transforms(cand, state, True, False, np.float64)
        for i in range(len(req)):
            j = int(mapping[i])
            iou[i, k] = sampled_iou(req_boxes[i], cand_boxes[j], req_motions[i], cand_motions[j], random,
                                    False, exact_at_rest=False)
    per_part = np.delete(np.sum(iou, axis=1) / n_states, req_base)
    return float(1 - (np.mean(per_part) if len(per_part) else 0))


def id_distance(pred: ArticulatedAsset, gen: dict, gt: ArticulatedAsset, truth: dict,
                              rng: np.random.Generator, n_states: int = N_STATES) -> float:
    """``ID``: mean over states of the squared Chamfer distance of the merged moved part samples.

    :param pred: the predicted asset (its part meshes)
    :param gen: its object dictionary
    :param gt: the ground-truth asset
    :param truth: its object dictionary
    :param rng: the generator of the part samples
    :param n_states: articulation states
    """
    gen_points = part_samples(pred, gen["diffuse_tree"], rng, n=PART_SAMPLES)
    gt_points = part_samples(gt, truth["diffuse_tree"], rng, n=PART_SAMPLES)
    values = []
    for state in np.linspace(0, 1, n_states):
        a = move_points(gen_points, gen["diffuse_tree"], state, np.float64).reshape(-1, 3)
        b = move_points(gt_points, truth["diffuse_tree"], state, np.float64).reshape(-1, 3)
        values.append((squared_cd(a, b) + squared_cd(b, a)) * 0.5)
    return float(np.mean(values))


def _blake(label: str) -> str:
    from hashlib import blake2b

    return blake2b(label.encode("ascii"), digest_size=WL_DIGEST).hexdigest()


def tree_hash(obj: dict) -> str:
    """``_get_tree_hash`` / ``get_hash``: the Weisfeiler-Lehman hash of the part tree (a directed graph with
    an edge from each part to its parent), as networkx 3.1-3.4's ``weisfeiler_lehman_graph_hash`` computes
    it (the versions the papers ran: CAGE pins ``networkx~=3.1``; 3.5 changed directed hashes): initial
    labels the total degrees, each of :data:`WL_ITERATIONS` steps hashes a node's label followed by its
    successors' (its parent's) sorted labels, the result hashes the sorted label counts of every step."""
    from collections import Counter

    tree = obj["diffuse_tree"]
    parents = {node["id"]: node["parent"] for node in tree}
    degree = {node["id"]: int(node["parent"] != -1) for node in tree}
    for node in tree:
        if node["parent"] != -1:
            degree[node["parent"]] += 1
    labels = {node: str(value) for node, value in degree.items()}
    counts: list = []
    for _ in range(WL_ITERATIONS):
        labels = {node: _blake(labels[node] + ("" if parents[node] == -1 else labels[parents[node]]))
                  for node in labels}
        counts.extend(sorted(Counter(labels.values()).items(), key=lambda item: item[0]))
    return _blake(str(tuple(counts)))


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """CAGE's AOR, ID, AID and graph accuracy of ``pred`` against ``gt``.

    :param pred: the predicted asset
    :param gt: the ground-truth asset
    :param seed: seed of the box samples (legacy ``RandomState``: AID, then AOR) and of the part samples
    """
    require_geometry(gt)
    require_geometry(pred, "prediction")
    gen, truth = object_dict(pred), object_dict(gt)
    random = np.random.RandomState(seed)
    metrics = {"AID": aid(gen, truth, random),
               "AOR": aor(gen, random, AOR_STATES, fix_range=False, skip_rest=False, dtype=np.float64,
                          exact_at_rest=False),
               "ID": id_distance(pred, gen, gt, truth, np.random.default_rng(seed)),
               "graph_acc": float(tree_hash(gen) == tree_hash(truth))}
    notes = [] if metrics["AOR"] is not None else ["AOR: no two sibling parts (the code returns -1)"]
    metrics = {key: metrics[key] for key, _ in INFO.columns}
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
