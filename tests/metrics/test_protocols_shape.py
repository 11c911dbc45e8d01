"""The shape protocols (freeart3d, partcrafter, singapo, cage): known perturbations, the papers' quirks, and
parity with numbers the papers' own code computed (``fixtures/protocols_shape``, written by
``benchmarks/protocols/parity_shape.py --fixtures``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers_boxes import box_mesh

from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.ops import scale_asset
from spark_bench.asset.transforms import make_transform
from spark_bench.metrics.articulation import compare_joints
from spark_bench.metrics.geometry import benchmark_transform, joint_axes
from spark_bench.metrics.protocols import cage, freeart3d, partcrafter, singapo
from spark_bench.metrics.protocols.parts import asset_parts, object_dict

FIXTURES = Path(__file__).parent / "fixtures" / "protocols_shape"


def _fixture(name: str) -> dict:
    return json.loads((FIXTURES / f"fixture_{name}.json").read_text())


def door_box(pivot_shift: float = 0.0, turn: float = 0.0, upper: float = 0.0, door_type: str = "revolute",
             drawer: bool = False) -> ArticulatedAsset:
    """A 2x2x2 box (its own benchmark frame) with a door hinged about Z at (-1, -0.5, 0); the pivot moved by
    ``pivot_shift`` along X with the door's mesh moved back (the same surface at rest); the axis turned by
    ``turn`` about X (the direction of the shift); the door opens to ``upper``."""
    axis = np.array([0.0, -math.sin(turn), math.cos(turn)])
    links = {"base": Link("base", [Visual(box_mesh((2.0, 2.0, 2.0)))]),
             "door": Link("door", [Visual(box_mesh((0.02, 1.0, 1.6), (0.01 - pivot_shift, 0.5, 0.0)))])}
    joints = {"door_joint": Joint("door_joint", door_type, "base", "door",
                                  make_transform(translation=(-1.0 + pivot_shift, -0.5, 0.0)), axis, 0.0, upper)}
    if drawer:
        links["drawer"] = Link("drawer", [Visual(box_mesh((0.6, 0.6, 0.3), (-0.7, 0.5, 0.5)))])
        links["knob"] = Link("knob", [Visual(box_mesh((0.05, 0.1, 0.1), (-1.05, 0.5, 0.5)))])
        joints["drawer_joint"] = Joint("drawer_joint", "prismatic", "base", "drawer", np.eye(4),
                                       np.array([-1.0, 0.0, 0.0]), 0.0, 0.4)
        joints["knob_joint"] = Joint("knob_joint", "revolute", "drawer", "knob", np.eye(4),
                                     np.array([1.0, 0.0, 0.0]), 0.0, 1.0)
    return ArticulatedAsset("door_box", links, joints, source="door_box")


def _freeart3d_joint(pred: ArticulatedAsset, gt: ArticulatedAsset, alignment) -> tuple:
    """FreeArt3D's (AxisErr, PivotErr) of the door, both normalized at the upper-limit state."""
    norms = [freeart3d.normalization(freeart3d.state_triangles(a, 1.0)) for a in (pred, gt)]
    lines = [freeart3d.joint_lines(a)["door_joint"] for a in (pred, gt)]
    return freeart3d.eval_joint(lines[0].normalized(norms[0]).aligned(alignment), lines[1].normalized(norms[1]))


IDENTITY = freeart3d.Alignment(np.eye(4), 1.0, np.eye(4))


# ----- FreeArt3D ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("shift", [0.05, 0.2])
def test_freeart3d_pivot_error_is_half_of_sparks_with_the_identity_alignment(shift):
    """A pivot moved by d (axis turned 0.01 rad about the shift, so the lines are skew): spark-bench's PivotErr
    is d in its longest-side-2 frame, FreeArt3D's d / 2 in its longest-side-1 frame."""
    gt, pred = door_box(), door_box(pivot_shift=shift, turn=0.01)
    spark = compare_joints(joint_axes(pred, benchmark_transform(pred))[0], joint_axes(gt, benchmark_transform(gt))[0])
    axis_err, pivot_err = _freeart3d_joint(pred, gt, IDENTITY)
    assert spark.pivot_err == pytest.approx(shift, rel=1e-9)
    assert pivot_err == pytest.approx(spark.pivot_err / 2, rel=1e-9)
    assert axis_err == pytest.approx(0.01, abs=1e-9)


def test_freeart3d_parallel_axes_have_no_pivot_error_and_a_prismatic_truth_none():
    """Parallel axes: FreeArt3D's formula is 0 / 0 (NaN: None), where spark-bench takes the point-to-line
    distance; a prismatic ground truth has no origin error."""
    axis_err, pivot_err = _freeart3d_joint(door_box(pivot_shift=0.1), door_box(), IDENTITY)
    assert pivot_err is None and axis_err is not None and axis_err < 1e-7
    assert _freeart3d_joint(door_box(door_type="prismatic"), door_box(door_type="prismatic"), IDENTITY)[1] is None


def test_freeart3d_transforms_directions_with_w_1():
    """The quirk reproduced: the ICP translation is added to the joint direction as to a point."""
    tsfm = np.eye(4)
    tsfm[:3, 3] = [0.3, 0.0, 0.0]
    line = freeart3d.JointLine("revolute", np.zeros(3), np.array([0.0, 0.0, 1.0]))
    moved = line.aligned(freeart3d.Alignment(np.eye(4), 1.0, tsfm))
    assert np.allclose(moved.direction, [0.3, 0.0, 1.0]) and np.allclose(moved.origin, [0.3, 0.0, 0.0])


def test_freeart3d_scale_grid_lacks_one_so_a_perfect_prediction_is_rescaled():
    """1.0 is not in linspace(0.5, 1.5, 10): the self-pair is aligned at 0.944 or 1.056 and its CD is not 0."""
    assert min(abs(s - 1.0) for s in freeart3d.SCALES) == pytest.approx(1 / 18, rel=1e-9)
    assert len(set(np.round(np.asarray(freeart3d.ANGLES_DEG) % 360, 9))) == 11  # 0 and 360 both
    asset = door_box()
    triangles = freeart3d.state_triangles(asset, 1.0)
    normalized = freeart3d.normalization(triangles).apply(triangles)
    rng = np.random.default_rng(0)
    alignment = freeart3d.auto_align(normalized, normalized, rng, angles=(0.0,))
    assert round(alignment.grid_scale, 3) in (0.944, 1.056)
    metrics = freeart3d.eval_mesh(alignment.apply(normalized), normalized, rng, n=4000)
    assert metrics["dist1"] + metrics["dist2"] > 1e-3


def test_freeart3d_icp_eval_mesh_and_eval_joint_match_the_papers_code():
    """Open3D's ICP, ``eval_mesh`` and ``eval_joint`` on the fixture's inputs: the same numbers to 1e-6."""
    fixture = _fixture("freeart3d")
    for case in fixture["icp"]:
        matrix, fitness = freeart3d.icp(np.array(case["source"]), np.array(case["target"]), case["threshold"],
                                        np.array(case["initial"]))
        assert fitness == pytest.approx(case["paper"]["fitness"], abs=1e-12)
        assert np.allclose(matrix, case["paper"]["transformation"], atol=1e-6)
    for case in fixture["eval_mesh"]:
        ours = freeart3d.eval_points(np.array(case["pred"], np.float32), np.array(case["gt"], np.float32))
        ours["fscore"] = None if math.isnan(ours["fscore"]) else ours["fscore"]
        for key, value in case["paper"].items():
            assert (ours[key] is None) == (value is None) and (value is None or ours[key] == pytest.approx(value, abs=1e-9))
    for case in fixture["eval_joint"]:
        lines = [freeart3d.JointLine(c["type"], np.array(c["axis"]["origin"], float), np.array(c["axis"]["direction"], float))
                 for c in (case["pred"], case["gt"])]
        axis_err, orig_err = freeart3d.eval_joint(
            lines[0].aligned(freeart3d.Alignment(np.array(case["transform"]), 1.0, np.eye(4))), lines[1])
        assert axis_err == pytest.approx(case["paper"]["joint_axis_err"], abs=1e-9)
        assert (orig_err is None) == (case["paper"]["joint_orig_err"] is None)
        if orig_err is not None:
            assert orig_err == pytest.approx(case["paper"]["joint_orig_err"], abs=1e-9)


# ----- SINGAPO ----------------------------------------------------------------------------------------------
def test_singapo_cd_is_squared():
    """Per-part CD is PyTorch3D's squared distances: two points 0.3 apart give 2 * 0.09, and the whole
    object scaled by 2 (same samples, scaled) gives 4 times the CD."""
    assert singapo.squared_cd(np.zeros((1, 3)), np.array([[0.3, 0.0, 0.0]])) == pytest.approx(0.18, rel=1e-12)
    gt, pred = door_box(upper=1.0, drawer=True), door_box(pivot_shift=0.1, upper=1.0, drawer=True)
    base, _ = singapo.chamfer(pred, object_dict(pred), gt, object_dict(gt), np.random.default_rng(3))
    big_pred, big_gt = scale_asset(pred, 2.0), scale_asset(gt, 2.0)
    big, _ = singapo.chamfer(big_pred, object_dict(big_pred), big_gt, object_dict(big_gt), np.random.default_rng(3))
    assert base["AS-CD"] > 0 and big["AS-CD"] == pytest.approx(4 * base["AS-CD"], rel=1e-5)


def test_singapo_self_pair_and_per_axis_rescaling():
    """The self-pair: gIoU distances and cDist 0 (float32 rounding); a prediction scaled and moved is
    rescaled per axis and recentred: the same box scores (CD's side effect undone by IoU_cDist)."""
    asset = door_box(upper=1.0, drawer=True)
    result = singapo.score(asset, asset)
    for key in ("RS-IoU", "AS-IoU"):
        assert abs(result.metrics[key]) < 1e-5
    for key in ("RS-cDist", "AS-cDist"):
        assert result.metrics[key] < 1e-6
    assert result.metrics["AOR"] is not None and result.metrics["AOR"] >= 0.0
    assert set(result.metrics) == {key for key, _ in singapo.INFO.columns}
    moved = scale_asset(asset, 1.7)
    scores = singapo.iou_cdist(object_dict(moved), object_dict(asset), np.random.RandomState(0))
    assert abs(scores["RS-IoU"]) < 1e-5 and scores["RS-cDist"] < 1e-5


def test_singapo_and_cage_match_the_papers_code_on_the_fixture_dictionaries():
    """AOR, RS/AS-IoU, RS/AS-cDist (SINGAPO) and AID, AOR (CAGE) on the fixtures' object dictionaries after
    ``np.random.seed(seed)``: the papers' numbers to 1e-6; graph hashes equal to networkx 3.4's."""
    for case in _fixture("singapo")["cases"][:6]:
        gen, gt = json.loads(json.dumps(case["pred_dict"])), case["gt_dict"]
        gen_c, gt_c = json.loads(json.dumps(gen)), json.loads(json.dumps(gt))
        singapo.zero_center(gen_c["diffuse_tree"])
        singapo.zero_center(gt_c["diffuse_tree"])
        factor = singapo.overall_size(gen_c["diffuse_tree"]) / singapo.overall_size(gt_c["diffuse_tree"])
        singapo.rescale(gen["diffuse_tree"], factor)
        random = np.random.RandomState(case["seed"])
        ours = {"AOR": singapo.aor(gen, random), **singapo.iou_cdist(gen, gt, random)}
        for key, value in case["paper"].items():
            if key.startswith("hash"):
                assert cage.tree_hash(case[f"{key[5:]}_dict"]) == value
            elif value is None:
                assert ours[key] is None
            else:
                assert ours[key] == pytest.approx(value, abs=1e-6), key
    for case in _fixture("cage")["cases"][:6]:
        random = np.random.RandomState(case["seed"])
        aid = cage.aid(case["pred_dict"], case["gt_dict"], random)
        aor = singapo.aor(case["pred_dict"], random, cage.AOR_STATES, False, False, np.float64, False)
        assert aid == pytest.approx(case["paper"]["AID"], abs=1e-6)
        assert (aor is None) == (case["paper"]["AOR"] is None)
        if aor is not None:
            assert aor == pytest.approx(case["paper"]["AOR"], abs=1e-6)


# ----- CAGE ----------------------------------------------------------------------------------------------------
def test_cage_self_pair_and_graph_accuracy():
    """The self-pair: AID 0 and graph accuracy 1; a prediction missing a part: graph accuracy 0."""
    asset = door_box(upper=1.0, drawer=True)
    result = cage.score(asset, asset)
    assert result.metrics["AID"] < 1e-3 and result.metrics["graph_acc"] == 1.0
    assert result.metrics["ID"] < 0.01
    fewer = door_box(upper=1.0)
    assert cage.tree_hash(object_dict(fewer)) != cage.tree_hash(object_dict(asset))
    assert len(asset_parts(asset)) == 4 and [p.parent for p in asset_parts(asset)] == [-1, 0, 0, 2]


# ----- PartCrafter ---------------------------------------------------------------------------------------------
def test_partcrafter_f_is_none_where_there_is_no_geometry_or_no_point_in_reach():
    """No predicted geometry, or no point within 0.1 either way: NaN in PartCrafter's code, None here
    (spark-bench's own F-Score says 0)."""
    gt = door_box()
    empty = ArticulatedAsset("empty", {"base": Link("base")}, {}, source="empty")
    result = partcrafter.score(empty, gt, n_samples=1000)
    assert result.metrics["f_score"] is None and result.metrics["chamfer_distance"] is None
    cd, f = partcrafter.cd_and_f(np.zeros((10, 3)), np.ones((10, 3)))
    assert f is None and cd == pytest.approx(2 * math.sqrt(3), rel=1e-12)
    assert partcrafter.cd_and_f(np.eye(3), np.eye(3)) == (0.0, 1.0)


def test_partcrafter_cd_and_f_match_the_papers_code():
    """``compute_cd_and_f_score`` on the fixture's samples: the same CD and F (None where NaN)."""
    for case in _fixture("partcrafter")["cd_f"]:
        cd, f = partcrafter.cd_and_f(np.array(case["pred"]), np.array(case["gt"]))
        assert cd == pytest.approx(case["paper"]["chamfer_distance"], abs=1e-9)
        assert (f is None) == (case["paper"]["f_score"] is None)
        if f is not None:
            assert f == pytest.approx(case["paper"]["f_score"], abs=1e-7)


def test_partcrafter_scores_a_scaled_prediction_in_its_own_frame(monkeypatch):
    """Each scene normalized on its own box (longest side 2): a prediction scaled by 0.5 scores like the
    truth itself, per part too (the same samples, scaled back)."""
    monkeypatch.setattr(partcrafter, "parts_iou", lambda parts: None)  # voxelizing takes seconds: tested below
    gt = door_box(upper=1.0)
    one = partcrafter.score(gt, gt, n_samples=20_000, seed=1).metrics
    two = partcrafter.score(scale_asset(gt, 0.5), gt, n_samples=20_000, seed=1).metrics
    assert two["chamfer_distance"] == pytest.approx(one["chamfer_distance"], rel=1e-6)
    assert one["f_score"] == pytest.approx(1.0, abs=1e-3) and one["parts_f_score"] == pytest.approx(1.0, abs=1e-3)


def test_partcrafter_part_iou_is_the_voxel_overlap_of_predicted_parts():
    """Two cubes, one half inside the other: the IoU of their filled voxelizations (pitch 2 / 64); one
    part: None (the paper's code raises)."""
    cube = box_mesh((0.5, 0.5, 0.5))
    triangles = cube.vertices[cube.faces]
    iou = partcrafter.parts_iou([triangles, triangles + [0.25, 0.0, 0.0]])
    assert iou == pytest.approx(1 / 3, abs=0.03)
    assert partcrafter.parts_iou([triangles]) is None
