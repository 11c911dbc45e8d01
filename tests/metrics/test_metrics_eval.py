"""compute_metrics and ``spark-bench metrics`` on small assets built in code, with hand-worked numbers,
degenerate inputs, and a real PartNet-Mobility object against itself."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers_assets import box_cabinet
from helpers_boxes import box_mesh

from spark_bench import CONVENTION_VERSION
from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import make_transform
from spark_bench.errors import InputError
from spark_bench.metrics import compute_metrics
from spark_bench.metrics.align import rotation_z
from spark_bench.metrics.report import format_table

N = 20_000  # samples per shape: enough for 1e-3 agreement with the analytic values


def plates(heights) -> ArticulatedAsset:
    """Flat 2x2 squares (zero-thickness boxes) at the given heights, all in the base link."""
    plates = [Visual(box_mesh((2.0, 2.0, 0.0), (0, 0, z))) for z in heights]
    return ArticulatedAsset("plates", {"base": Link("base", plates)}, {}, source="plates")


def rotated(asset: ArticulatedAsset, angle: float, scale: float = 1.0, shift=(0.0, 0.0, 0.0)) -> ArticulatedAsset:
    """The asset turned about world Z, scaled and moved (base meshes and root joints)."""
    out = asset.copy()
    matrix = make_transform(scale * rotation_z(angle), shift)
    for link in out.links.values():
        for visual in link.visuals:
            visual.mesh.vertices = visual.mesh.vertices * scale
    for visual in out.links[out.root].visuals:
        visual.mesh.vertices = visual.mesh.vertices @ rotation_z(angle).T + shift
    for joint in out.joints.values():
        origin = joint.origin.copy()
        origin[:3, 3] *= scale
        if joint.parent == out.root:
            origin = matrix @ joint.origin
            origin[:3, :3] = rotation_z(angle) @ joint.origin[:3, :3]
        joint.origin = origin
        if joint.type == "prismatic":
            joint.lower, joint.upper = joint.lower * scale, joint.upper * scale
    return out


# ----- against itself ---------------------------------------------------------------------------
def assert_zero(result):
    d = result.to_dict()
    for key in ("cd", "cd_open", "part_cd", "axis_err", "pivot_err", "type_err"):
        assert d[key] == 0.0, key
    for key in ("fscore@0.1", "fscore@0.5", "fscore_open@0.1", "part_fscore@0.5"):
        assert d[key] == 1.0, key
    assert d["n_missing_joints"] == d["n_extra_joints"] == 0


def test_asset_against_itself_is_zero():
    result = compute_metrics(box_cabinet(), box_cabinet(), n_samples=N)
    assert_zero(result)
    assert [(m.gt_joint, m.pred_joint) for m in result.matches] == [("door_joint", "door_joint"),
                                                                    ("drawer_joint", "drawer_joint")]


def test_against_itself_in_another_frame_is_zero():
    # moved and scaled copies land in the same benchmark frame: normalization is per asset
    result = compute_metrics(rotated(box_cabinet(), 0.0, scale=3.0, shift=(1.0, 2.0, -4.0)), box_cabinet(),
                             n_samples=N)
    d = result.to_dict()
    assert d["cd"] < 1e-9 and d["cd_open"] < 1e-9 and d["axis_err"] < 1e-9 and d["pivot_err"] < 1e-9


def test_helper_chain_is_matched_to_itself():
    # a screw cap: prismatic into a helper link without geometry, continuous below it; both joints
    # move the same geometry, so only the tie-break keeps each joint with its own kind
    def bottle():
        links = {"base": Link("base", [Visual(box_mesh((1.0, 1.0, 2.0)))]), "helper": Link("helper"),
                 "cap": Link("cap", [Visual(box_mesh((0.5, 0.5, 0.3), (0.0, 0.0, 1.15)))])}
        joints = {"slide": Joint("slide", "prismatic", "base", "helper", np.eye(4), np.array([0, 0, 1.0]), 0, 0.1),
                  "spin": Joint("spin", "continuous", "helper", "cap", np.eye(4), np.array([0, 0, 1.0]), 0, 2 * np.pi)}
        return ArticulatedAsset("bottle", links, joints, source="bottle")

    result = compute_metrics(bottle(), bottle(), n_samples=5000)
    assert_zero(result)
    assert {(m.gt_joint, m.pred_joint) for m in result.matches} == {("slide", "slide"), ("spin", "spin")}
    assert result.matches[0].gt_links == ["helper", "cap"]


def test_rerun_is_identical_and_seed_matters():
    pred, gt = box_cabinet(door_pivot=(-0.9, -0.4, 0.0)), box_cabinet()
    a = compute_metrics(pred, gt, n_samples=5000, seed=7).to_dict()
    b = compute_metrics(pred, gt, n_samples=5000, seed=7).to_dict()
    c = compute_metrics(pred, gt, n_samples=5000, seed=8).to_dict()
    assert a == b
    assert a["cd"] != c["cd"]


# ----- hand-worked values ----------------------------------------------------------------------
@pytest.mark.parametrize("gap, f01, f05", [(0.04, 1.0, 1.0), (0.2, 0.0, 1.0)])
def test_plates_a_known_distance_apart(gap, f01, f05):
    # gt: one 2x2 plate at z = 0; pred: plates at +-gap (same box after normalization: scale 1,
    # center 0). Every point is `gap` from the other surface: CD = 2 gap.
    result = compute_metrics(plates([-gap, gap]), plates([0.0]), n_samples=N)
    assert result.rest.cd == pytest.approx(2 * gap, abs=2e-3)
    assert result.rest.fscore[0.1] == f01 and result.rest.fscore[0.5] == f05
    assert result.type_err is None and result.axis_err is None and result.matches == []


def test_hinge_moved_by_a_known_offset():
    # pred door plate and hinge 0.2 further in (+x): parallel axes 0.2 apart; part CD = 2 x 0.2
    result = compute_metrics(box_cabinet(door_pivot=(-0.7, -0.5, 0.0)), box_cabinet(), n_samples=N)
    door = result.matches[0]
    assert door.gt_joint == "door_joint" and door.pred_joint == "door_joint"
    assert door.pivot_err == pytest.approx(0.2, abs=1e-9)
    assert door.axis_err == pytest.approx(0.0, abs=1e-12)
    assert door.part.cd == pytest.approx(0.4, abs=2e-3)
    assert door.part.fscore[0.1] == 0.0 and door.part.fscore[0.5] == 1.0
    assert result.pivot_err == pytest.approx(0.2, abs=1e-9)  # the drawer has no pivot
    assert result.type_err == 0.0


def test_hinge_moved_along_its_own_axis_has_no_pivot_error():
    result = compute_metrics(box_cabinet(door_pivot=(-0.9, -0.5, 0.1)), box_cabinet(), n_samples=5000)
    assert result.matches[0].pivot_err == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("angle", [0.25, 0.6])
def test_axis_rotated_by_a_known_angle(angle):
    # door axis tilted by `angle` in the y-z plane through the same pivot: AxisErr = angle, the
    # two axes meet at the pivot so PivotErr = 0
    tilted = (0.0, math.sin(angle), math.cos(angle))
    result = compute_metrics(box_cabinet(door_axis=tilted), box_cabinet(), n_samples=5000)
    assert result.matches[0].axis_err == pytest.approx(angle, abs=1e-12)
    assert result.matches[0].pivot_err == pytest.approx(0.0, abs=1e-12)
    assert result.axis_err == pytest.approx(angle / 2, abs=1e-12)  # mean with the exact drawer
    assert result.rest.cd == 0.0  # same rest shape
    assert result.open.cd > 0.01  # but it opens elsewhere


def test_flipped_axis_is_sign_free_but_seen_when_open():
    result = compute_metrics(box_cabinet(drawer_axis=(1.0, 0.0, 0.0)), box_cabinet(), n_samples=N)
    assert result.matches[1].axis_err == 0.0 and result.rest.cd == 0.0
    assert result.open.cd > 0.01  # the drawer goes into the box instead of out of it


def test_type_errors_and_continuous_as_revolute():
    result = compute_metrics(box_cabinet(door_type="continuous", drawer_type="revolute"), box_cabinet(),
                             n_samples=5000)
    assert [m.type_match for m in result.matches] == [True, False]
    assert result.type_err == 0.5
    assert result.matches[1].pivot_err is None  # a prismatic ground truth has no pivot
    assert result.pivot_err == pytest.approx(0.0, abs=1e-12)


# ----- degenerate inputs -----------------------------------------------------------------------
def test_prediction_without_movable_joints():
    fused = ArticulatedAsset("fused", {"base": Link("base", [Visual(box_cabinet().mesh())])}, {},
                             source="fused")
    result = compute_metrics(fused, box_cabinet(), n_samples=5000)
    d = result.to_dict()
    assert d["type_err"] == 1.0
    assert d["axis_err"] is None and d["pivot_err"] is None
    assert d["n_missing_joints"] == 2 and d["n_extra_joints"] == 0 and d["matching"] == []
    assert d["cd"] < 1e-9  # same surface, all in one link
    assert d["cd_open"] > 0.01  # the ground truth opens, the prediction cannot


def test_ground_truth_without_movable_joints():
    fused = ArticulatedAsset("fused", {"base": Link("base", [Visual(box_cabinet().mesh())])}, {},
                             source="fused")
    result = compute_metrics(box_cabinet(), fused, n_samples=2000)
    assert result.type_err is None and result.axis_err is None  # nothing to get wrong
    assert sorted(result.extra_joints) == ["door_joint", "drawer_joint"] and result.missing_joints == []


def test_prediction_with_more_parts_than_ground_truth():
    pred = box_cabinet()
    pred.links["lid"] = Link("lid", [Visual(box_mesh((0.4, 0.4, 0.0), (0.2, 0.0, 0.0)))])
    pred.joints["lid_joint"] = Joint("lid_joint", "revolute", "base", "lid", make_transform(translation=(0, 0, 0.95)),
                                     np.array([0, 1.0, 0]), 0.0, 1.0)
    result = compute_metrics(pred, box_cabinet(), n_samples=5000)
    assert result.extra_joints == ["lid_joint"] and result.missing_joints == []
    assert {m.pred_joint for m in result.matches} == {"door_joint", "drawer_joint"}
    assert result.type_err == 0.0 and result.to_dict()["n_extra_joints"] == 1


def test_empty_mesh_is_a_clear_error():
    empty = ArticulatedAsset("empty", {"base": Link("base")}, {}, source="empty/mobility.urdf")
    with pytest.raises(InputError, match="empty/mobility.urdf: empty mesh"):
        compute_metrics(empty, box_cabinet(), n_samples=100)


@pytest.mark.parametrize("where", ["vertex", "axis", "origin", "limit"])
def test_nan_is_a_clear_error(where):
    pred = box_cabinet()
    if where == "vertex":
        pred.links["door"].visuals[0].mesh.vertices[0, 1] = np.nan
    elif where == "axis":
        pred.joints["door_joint"].axis = np.array([np.nan, 0.0, 1.0])
    elif where == "origin":
        pred.joints["drawer_joint"].origin = np.full((4, 4), np.nan)
    else:
        pred.joints["drawer_joint"].upper = np.nan
    with pytest.raises(InputError, match="^cabinet: .*(NaN|not finite)"):
        compute_metrics(pred, box_cabinet(), n_samples=100)


def test_unknown_alignment_is_an_error():
    with pytest.raises(InputError, match="alignment"):
        compute_metrics(box_cabinet(), box_cabinet(), align="magic")


# ----- alignment -------------------------------------------------------------------------------
def test_icp_alignment_undoes_a_quarter_turn():
    pred = rotated(box_cabinet(), math.pi / 2)
    plain = compute_metrics(pred, box_cabinet(), n_samples=5000)
    aligned = compute_metrics(pred, box_cabinet(), n_samples=5000, align="icp")
    assert plain.rest.cd > 0.1 and plain.axis_err > 0.5  # the drawer axis turned 90 degrees
    assert aligned.rest.cd < 1e-6 and aligned.open.cd < 1e-6
    assert aligned.axis_err < 1e-6 and aligned.pivot_err < 1e-6 and aligned.type_err == 0.0
    np.testing.assert_allclose(np.asarray(aligned.alignment)[:3, :3], rotation_z(-math.pi / 2), atol=1e-6)


# ----- reporting and CLI ----------------------------------------------------------------------
def test_json_dict_and_table():
    d = compute_metrics(box_cabinet(door_pivot=(-0.7, -0.5, 0.0)), box_cabinet(), n_samples=2000).to_dict()
    for key in ("cd", "fscore@0.1", "fscore@0.5", "cd_open", "axis_err", "pivot_err", "type_err",
                "n_missing_joints", "n_extra_joints", "matching", "convention", "units"):
        assert key in d
    assert d["convention"] == CONVENTION_VERSION
    assert d["matching"][0]["gt_joint"] == "door_joint" and "part_cd" in d["matching"][0]
    json.dumps(d, allow_nan=False)


def write_folder(asset: ArticulatedAsset, folder: Path) -> Path:
    from spark_bench.asset.urdf import write_object_folder

    write_object_folder(asset, folder)
    return folder


def test_cli_json_and_table(tmp_path, capsys):
    from spark_bench.cli import main

    pred = write_folder(box_cabinet(door_pivot=(-0.7, -0.5, 0.0)), tmp_path / "pred")
    gt = write_folder(box_cabinet(), tmp_path / "gt")
    assert main(["metrics", "--pred", str(pred), "--gt", str(gt / "mobility.urdf"), "--json",
                 "--samples", "3000", "--match-samples", "1000"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["pivot_err"] == pytest.approx(0.2, abs=1e-6) and d["type_err"] == 0.0
    assert d["n_samples"] == 3000 and d["convention"] == CONVENTION_VERSION
    assert main(["metrics", "--pred", str(pred), "--gt", str(gt), "--samples", "2000"]) == 0
    table = capsys.readouterr().out
    assert "PivotErr" in table and "door_joint" in table


def test_cli_bad_input_exits_2(tmp_path, capsys):
    from spark_bench.cli import main

    gt = write_folder(box_cabinet(), tmp_path / "gt")
    assert main(["metrics", "--pred", str(tmp_path / "missing"), "--gt", str(gt)]) == 2
    assert "error" in capsys.readouterr().err


@pytest.mark.real
def test_real_object_against_itself(real_object):
    folder = real_object("40147")
    from spark_bench.data import load_object

    asset = load_object(folder)
    result = compute_metrics(asset, load_object(folder), n_samples=3000, n_match_samples=1000)
    assert_zero(result)
    assert {(m.gt_joint, m.pred_joint) for m in result.matches} == {("joint_0", "joint_0"), ("joint_1", "joint_1")}
    assert format_table(result).count("joint_") >= 2
