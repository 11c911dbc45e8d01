"""The opening score of a prediction: the scripted opener, planned from the predicted joints, acting on
the ground-truth object at its real size (a case's ground truth is stored normalized to [-1, 1]^3)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers_bench import write_case

from spark_bench.asset import write_object_folder
from spark_bench.asset.ops import similarity_asset
from spark_bench.data import load_object
from spark_bench.data.case import BenchmarkCase
from spark_bench.envs.assets import load_asset
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.errors import InputError
from spark_bench.evaluation.opening import ground_truth_in_metres, open_with_predicted_joints


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory):
    return write_case(tmp_path_factory.mktemp("bench"), "cab0", procedural_cabinet(seed=0))


@pytest.fixture(scope="module")
def gt_dir(case_dir):
    return BenchmarkCase(case_dir).gt_dir


def identity_matching(asset) -> dict:
    return {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in asset.movable_joints()]}


def test_case_ground_truth_comes_back_at_source_size(case_dir, gt_dir, tmp_path):
    source = procedural_cabinet(seed=0)
    stored, gt, to_metres = ground_truth_in_metres(gt_dir)
    assert stored.bounds().max() == pytest.approx(1.0)  # the files: benchmark frame
    # the meshes went through files and back to metres: equal to well within 1e-6 m
    np.testing.assert_allclose(gt.bounds(), source.bounds(), atol=1e-6)
    corners = np.c_[stored.bounds(), np.ones(2)] @ to_metres.T  # the matrix maps the stored box onto it
    np.testing.assert_allclose(corners[:, :3], source.bounds(), atol=1e-6)
    # the environments see the same object when given the case
    env_asset, _ = load_asset(case_dir)
    np.testing.assert_allclose(env_asset.bounds(), source.bounds(), atol=1e-6)
    # any other object folder (here: a copy of the stored ground truth outside its case) is used as it is
    write_object_folder(stored, tmp_path / "object")
    files, same, identity = ground_truth_in_metres(tmp_path / "object")
    assert same is files and np.array_equal(identity, np.eye(4))
    assert same.bounds().max() == pytest.approx(1.0)


def test_ground_truth_joints_open_the_case_and_a_wrong_axis_does_not(gt_dir, tmp_path):
    gt = load_object(gt_dir)
    result = open_with_predicted_joints(gt_dir, gt_dir, identity_matching(gt))
    assert result["success_rate"] == 1.0
    assert {name for name, j in result["joints"].items() if j["success"]} == {j.name for j in gt.movable_joints()}
    # a prediction at another scale and place (methods answer in any frame): the same joints, still opened
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = 0.37 * np.eye(3), [2.0, -1.0, 0.5]
    write_object_folder(similarity_asset(gt, matrix), tmp_path / "moved")
    assert open_with_predicted_joints(tmp_path / "moved", gt_dir, identity_matching(gt))["success_rate"] == 1.0
    # the drawer's axis turned sideways: the pull drags the handle across the front, the drawer stays shut
    wrong = gt.copy()
    drawer = next(j for j in wrong.movable_joints() if j.type == "prismatic")
    drawer.axis = np.array([0.0, 1.0, 0.0])
    write_object_folder(wrong, tmp_path / "wrong")
    joints = open_with_predicted_joints(tmp_path / "wrong", gt_dir, identity_matching(gt))["joints"]
    assert joints[drawer.name]["success"] is False
    assert all(j["success"] for name, j in joints.items() if name != drawer.name)


def test_unmatched_joint_counts_as_not_opened(gt_dir):
    gt = load_object(gt_dir)
    door = next(j for j in gt.movable_joints() if j.type == "revolute")
    metrics = {"matching": [m for m in identity_matching(gt)["matching"] if m["gt_joint"] != door.name]}
    result = open_with_predicted_joints(gt_dir, gt_dir, metrics)
    assert result["joints"][door.name] == {"success": False, "why": "no matched predicted joint"}
    assert result["success_rate"] == pytest.approx(1 - 1 / len(result["joints"]))


def test_a_jammed_part_is_left_out_whether_or_not_the_prediction_matched_it(tmp_path):
    """A drawer its collision shapes jam (a stop 15 mm before its front, as in the envs' test) opens for no
    one: left out with the scene's reason, for a prediction that matched it and for one that did not; an
    unmatched joint that can be opened still counts as not opened."""
    from spark_bench.asset.model import Collision, Joint, Link

    asset = procedural_cabinet(0)
    pose = asset.link_poses()["link_0"]
    front = pose[:3, :3] @ np.array([0.0, -0.25, -0.1]) + pose[:3, 3]
    stop = np.eye(4)
    stop[:3, 3] = np.linalg.inv(asset.link_poses()["base"])[:3] @ np.append(front + (-0.015, 0.0, 0.0), 1.0)
    asset.links["stop"] = Link(name="stop", visuals=[], label="stop",
                               collisions=[Collision(kind="box", origin=np.eye(4), size=np.array([0.01, 0.04, 0.02]))])
    asset.joints["stop_joint"] = Joint("stop_joint", "fixed", "base", "stop", origin=stop)
    gt_dir = BenchmarkCase(write_case(tmp_path / "bench", "jam0", asset)).gt_dir
    gt = load_object(gt_dir)
    matched = open_with_predicted_joints(gt_dir, gt_dir, identity_matching(gt))["joints"]
    unmatched = open_with_predicted_joints(gt_dir, gt_dir, {"matching": []})["joints"]
    for joints in (matched, unmatched):
        assert joints["joint_0"]["success"] is None and "jammed" in joints["joint_0"]["reason"]
    assert matched["joint_1"]["success"] is True
    assert unmatched["joint_1"] == {"success": False, "why": "no matched predicted joint"}


def test_bad_normalization_is_a_clear_error(case_dir, tmp_path):
    import shutil

    broken = BenchmarkCase(tmp_path / "broken")
    shutil.copytree(case_dir, broken.folder)
    record = json.loads(broken.record_path.read_text())
    record["normalization"]["scale"] = -2.0
    broken.write_record(record)
    with pytest.raises(InputError, match="bad normalization") as info:
        ground_truth_in_metres(broken.gt_dir)
    assert str(broken.record_path) in str(info.value)


def test_a_part_the_planner_declines_is_left_out_with_its_reason(tmp_path):
    """A drawer with nothing to hold is no test of the prediction: left out (``success`` None) with the
    planner's one-line reason, before any episode; the door is still scored."""
    flat = procedural_cabinet(seed=0)
    drawer = flat.links["link_0"]
    drawer.visuals, drawer.collisions = drawer.visuals[:5], drawer.collisions[:5]  # the bar handle removed
    gt_dir = BenchmarkCase(write_case(tmp_path / "bench", "flat0", flat)).gt_dir
    gt = load_object(gt_dir)
    result = open_with_predicted_joints(gt_dir, gt_dir, identity_matching(gt))
    entry = result["joints"]["joint_0"]
    assert entry["success"] is None and "no handle" in entry["reason"] and "\n" not in entry["reason"]
    assert result["joints"]["joint_1"]["success"] is True
    assert result["success_rate"] == 1.0  # the door alone is judged


def test_the_oracle_ground_truth_is_loaded_once(gt_dir, tmp_path, object_loads):
    """The oracle's prediction folder is the ground-truth folder: one load, not two (seconds on a real
    object); a prediction in another folder is still loaded from its own files."""
    loaded = object_loads
    no_matching = {"matching": []}  # every joint unmatched: only the ground truth's own episodes run
    same = open_with_predicted_joints(gt_dir, gt_dir, no_matching)
    assert len(loaded) == 1
    loaded.clear()
    # the same folder spelled another way (a relative path with ".."): still one load
    spelled = gt_dir.parent / ".." / gt_dir.parent.name / gt_dir.name
    open_with_predicted_joints(spelled, gt_dir, no_matching)
    assert len(loaded) == 1
    loaded.clear()
    write_object_folder(load_object(gt_dir), tmp_path / "copy")
    loaded.clear()
    other = open_with_predicted_joints(tmp_path / "copy", gt_dir, no_matching)
    assert len(loaded) == 2 and loaded[1] == str(tmp_path / "copy")
    assert other == same and all(j["success"] is False for j in same["joints"].values())
