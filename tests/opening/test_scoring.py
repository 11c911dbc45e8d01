"""Opening each ground-truth joint with a policy (``spark_bench.opening.judge``): the scripted opening score
(the scripted opener, planned from the predicted joints, acting on the ground-truth object at its real size;
a case's ground truth is stored normalized to [-1, 1]^3), and the one rule, shared with the RL transfer
score, for a joint nobody can open."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from helpers_bench import write_case
from helpers_open import identity_matching

from spark_bench.asset import write_object_folder
from spark_bench.asset.model import Collision, Visual
from spark_bench.asset.ops import similarity_asset
from spark_bench.data import load_object
from spark_bench.data.case import BenchmarkCase, ground_truth_in_metres
from spark_bench.envs.assets import load_asset
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.errors import InputError
from spark_bench.opening.judge import open_every_joint, open_with_predicted_joints
from spark_bench.opening.pairing import Pairing, opening_joints


def jammed_cabinet():
    """The procedural cabinet with a stop 15 mm before its drawer's front (as in the envs' test): its
    collision shapes jam the drawer (``joint_0``); the door (``joint_1``) opens."""
    from spark_bench.asset.model import Collision, Joint, Link

    asset = procedural_cabinet(0)
    pose = asset.link_poses()["link_0"]
    front = pose[:3, :3] @ np.array([0.0, -0.25, -0.1]) + pose[:3, 3]
    stop = np.eye(4)
    stop[:3, 3] = np.linalg.inv(asset.link_poses()["base"])[:3] @ np.append(front + (-0.015, 0.0, 0.0), 1.0)
    asset.links["stop"] = Link(name="stop", visuals=[], label="stop",
                               collisions=[Collision(kind="box", origin=np.eye(4), size=np.array([0.01, 0.04, 0.02]))])
    asset.joints["stop_joint"] = Joint("stop_joint", "fixed", "base", "stop", origin=stop)
    return asset


def flat_cabinet(travel: float | None = None):
    """The procedural cabinet with its drawer's bar handle removed: nothing for the gripper to pinch (the
    suction cup's task); with ``travel`` (m) the drawer is a 3 cm push button on its front moving only so far,
    which no end-effector pulls open."""
    flat = procedural_cabinet(seed=0)
    drawer = flat.links["link_0"]
    drawer.visuals, drawer.collisions = drawer.visuals[:5], drawer.collisions[:5]
    if travel is not None:
        front = flat.mesh(links=["link_0"])
        lo, hi = front.bounds
        center = np.array([lo[0], 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]), 1.0])
        in_link = (np.linalg.inv(flat.link_poses()["link_0"]) @ center)[:3]
        button = trimesh.creation.box(extents=(0.03, 0.03, 0.03),
                                      transform=trimesh.transformations.translation_matrix(in_link))
        drawer.visuals = [Visual(mesh=button)]
        drawer.collisions = [Collision("mesh", mesh=button)]
        flat.joints["joint_0"].upper = travel
    return flat


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory):
    return write_case(tmp_path_factory.mktemp("bench"), "cab0", procedural_cabinet(seed=0))


@pytest.fixture(scope="module")
def jammed_dir(tmp_path_factory):
    return BenchmarkCase(write_case(tmp_path_factory.mktemp("bench"), "jam0", jammed_cabinet())).gt_dir


@pytest.fixture(scope="module")
def flat_dir(tmp_path_factory):
    return BenchmarkCase(write_case(tmp_path_factory.mktemp("bench"), "flat0", flat_cabinet())).gt_dir


@pytest.fixture(scope="module")
def button_dir(tmp_path_factory):
    return BenchmarkCase(write_case(tmp_path_factory.mktemp("bench"), "button0", flat_cabinet(travel=0.005))).gt_dir


@pytest.fixture(scope="module")
def case_gt_dir(case_dir):
    return BenchmarkCase(case_dir).gt_dir


def test_case_ground_truth_comes_back_at_source_size(case_dir, case_gt_dir, tmp_path):
    source = procedural_cabinet(seed=0)
    gt_bench, gt_metres, bench_to_metres = ground_truth_in_metres(case_gt_dir)
    assert gt_bench.bounds().max() == pytest.approx(1.0)  # the files: benchmark frame
    # the meshes went through files and back to metres: equal to well within 1e-6 m
    np.testing.assert_allclose(gt_metres.bounds(), source.bounds(), atol=1e-6)
    corners = np.c_[gt_bench.bounds(), np.ones(2)] @ bench_to_metres.T  # the matrix maps the stored box onto it
    np.testing.assert_allclose(corners[:, :3], source.bounds(), atol=1e-6)
    # the environments see the same object when given the case
    env_asset, _ = load_asset(case_dir)
    np.testing.assert_allclose(env_asset.bounds(), source.bounds(), atol=1e-6)
    # any other object folder (here: a copy of the stored ground truth outside its case) is used as it is
    write_object_folder(gt_bench, tmp_path / "object")
    files, same, identity = ground_truth_in_metres(tmp_path / "object")
    assert same is files and np.array_equal(identity, np.eye(4))
    assert same.bounds().max() == pytest.approx(1.0)


def test_ground_truth_joints_open_the_case_and_a_wrong_axis_does_not(case_gt_dir, tmp_path):
    gt = load_object(case_gt_dir)
    result = open_with_predicted_joints(case_gt_dir, case_gt_dir, identity_matching(gt))
    assert result["success_rate"] == 1.0
    assert {name for name, j in result["joints"].items() if j["success"]} == {j.name for j in gt.movable_joints()}
    # a prediction at another scale and place (methods answer in any frame): the same joints, still opened
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = 0.37 * np.eye(3), [2.0, -1.0, 0.5]
    write_object_folder(similarity_asset(gt, matrix), tmp_path / "moved")
    moved = open_with_predicted_joints(tmp_path / "moved", case_gt_dir, identity_matching(gt))
    assert moved["success_rate"] == 1.0
    # the drawer's axis turned sideways: the pull drags the handle across the front, the drawer stays shut
    wrong = gt.copy()
    drawer = next(j for j in wrong.movable_joints() if j.type == "prismatic")
    drawer.axis = np.array([0.0, 1.0, 0.0])
    write_object_folder(wrong, tmp_path / "wrong")
    joints = open_with_predicted_joints(tmp_path / "wrong", case_gt_dir, identity_matching(gt))["joints"]
    assert joints[drawer.name]["success"] is False
    assert all(j["success"] for name, j in joints.items() if name != drawer.name)


def test_unmatched_joint_counts_as_not_opened(case_gt_dir):
    gt = load_object(case_gt_dir)
    door = next(j for j in gt.movable_joints() if j.type == "revolute")
    metrics = {"matching": [m for m in identity_matching(gt)["matching"] if m["gt_joint"] != door.name]}
    result = open_with_predicted_joints(case_gt_dir, case_gt_dir, metrics)
    assert result["joints"][door.name] == {"success": False, "why": "no matched predicted joint", "end_effector": "gripper"}
    assert result["success_rate"] == pytest.approx(1 - 1 / len(result["joints"]))


def test_a_jammed_part_is_left_out_whether_or_not_the_prediction_matched_it(jammed_dir):
    """A drawer its collision shapes jam opens for no one: left out with the scene's reason, for a
    prediction that matched it and for one that did not; an unmatched joint that can be opened still counts
    as not opened."""
    gt = load_object(jammed_dir)
    matched = open_with_predicted_joints(jammed_dir, jammed_dir, identity_matching(gt))
    unmatched = open_with_predicted_joints(jammed_dir, jammed_dir, {"matching": []})
    for result in (matched, unmatched):
        joint = result["joints"]["joint_0"]
        assert joint["success"] is None and "jammed" in joint["reason"]
        assert result["joints_total"] == 2 and result["joints_scored"] == 1
        assert result["left_out"] == {"joint_0": joint["reason"]}
    assert matched["joints"]["joint_1"]["success"] is True and matched["success_rate"] == 1.0
    assert unmatched["joints"]["joint_1"] == {"success": False, "why": "no matched predicted joint",
                                              "end_effector": "gripper"}
    assert unmatched["success_rate"] == 0.0


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


def test_a_part_the_planner_declines_is_left_out_with_its_reason(button_dir):
    """A part no end-effector pulls open (a push button) is no test of the prediction: left out (``success``
    None) with the planner's one-line reason, before any episode; the door is still scored."""
    gt = load_object(button_dir)
    result = open_with_predicted_joints(button_dir, button_dir, identity_matching(gt))
    entry = result["joints"]["joint_0"]
    assert entry == {"success": None, "reason": entry["reason"], "left_out_kind": "planner", "end_effector": "gripper"}
    assert "push button" in entry["reason"] and "\n" not in entry["reason"]
    assert result["joints"]["joint_1"]["success"] is True
    assert result["success_rate"] == 1.0  # the door alone is judged
    assert (result["joints_total"], result["joints_scored"], result["left_out"]) == (2, 1, {"joint_0": entry["reason"]})
    assert result["left_out_kinds"] == {"planner": 1}


def test_a_part_with_nothing_to_pinch_is_opened_with_the_suction_cup(flat_dir, tmp_path):
    """The handle-less drawer: the scripted score opens it with the suction cup planned from the predicted
    joint (the row says so) and fails it planned from a wrong axis; the RL transfer score scores it too, its
    policy driving the cup (the same end-effector rule), and told the wrong axis it fails."""
    from spark_bench.rl.transfer import rl_transfer_score

    gt = load_object(flat_dir)
    result = open_with_predicted_joints(flat_dir, flat_dir, identity_matching(gt))
    drawer = result["joints"]["joint_0"]
    assert drawer["success"] is True and drawer["end_effector"] == "suction"
    assert result["joints"]["joint_1"]["end_effector"] == "gripper"
    assert (result["joints_scored"], result["scored_by"]) == (2, {"gripper": 1, "suction": 1})
    wrong = gt.copy()
    wrong.joints["joint_0"].axis = np.array([0.0, 1.0, 0.0])  # sideways: the cup slides off or drags nothing
    write_object_folder(wrong, tmp_path / "wrong")
    turned = open_with_predicted_joints(tmp_path / "wrong", flat_dir, identity_matching(gt))["joints"]["joint_0"]
    assert turned["success"] is False and turned["end_effector"] == "suction"
    rl = rl_transfer_score(tmp_path / "wrong", flat_dir,
                           {"matching": [{"gt_joint": "joint_0", "pred_joint": "joint_0"}]}, finetune_steps=0)
    row = rl["joints"]["joint_0"]
    assert row["end_effector"] == "suction" and row["grasp"] == "suction" and "reason" not in row
    assert row["zero_shot"] == 0.0 and row["zero_shot_max_fraction"] < 0.5  # the wrong axis misleads the policy
    assert rl["scored_by"] == {"gripper": 1, "suction": 1} and rl["joints"]["joint_1"]["end_effector"] == "gripper"


def test_the_oracle_ground_truth_is_loaded_once(case_gt_dir, tmp_path, object_loads):
    """The oracle's prediction folder is the ground-truth folder: one load, not two (seconds on a real
    object); a prediction in another folder is still loaded from its own files."""
    loaded = object_loads
    no_matching = {"matching": []}  # every joint unmatched: only the ground truth's own episodes run
    same = open_with_predicted_joints(case_gt_dir, case_gt_dir, no_matching)
    assert len(loaded) == 1
    loaded.clear()
    # the same folder spelled another way (a relative path with ".."): still one load
    spelled = case_gt_dir.parent / ".." / case_gt_dir.parent.name / case_gt_dir.name
    open_with_predicted_joints(spelled, case_gt_dir, no_matching)
    assert len(loaded) == 1
    loaded.clear()
    write_object_folder(load_object(case_gt_dir), tmp_path / "copy")
    loaded.clear()
    other = open_with_predicted_joints(tmp_path / "copy", case_gt_dir, no_matching)
    assert len(loaded) == 2 and loaded[1] == str(tmp_path / "copy")
    assert other == same and all(j["success"] is False for j in same["joints"].values())


def test_the_opening_tasks_are_the_drawers_and_doors():
    """Continuous joints (knobs, caps) have no opening task: neither score reports them; the training
    tasks' joint types are the same."""
    from spark_bench.rl.tasks import TASK_KIND

    asset = procedural_cabinet(0)
    assert [j.name for j in opening_joints(asset)] == ["joint_0", "joint_1"]
    asset.joints["joint_1"].type = "continuous"
    assert [j.name for j in opening_joints(asset)] == ["joint_0"]
    assert set(TASK_KIND) == {"prismatic", "revolute"}


def test_the_pairing_says_why_a_matched_joint_cannot_be_attempted():
    """A ground-truth joint is attempted with the predicted joint the metrics matched with it, if an
    environment opens that joint's type; otherwise it counts as not opened, with why."""
    from spark_bench.asset.model import Joint

    pred = procedural_cabinet(0)
    pred.joints["fixed_one"] = Joint("fixed_one", "fixed", "base", "link_1")
    pairing = Pairing(gt_bench=pred, gt_metres=pred, pred=pred, pred_to_gt_metres=np.eye(4),
                      matched={"a": "joint_0", "b": "gone", "c": "fixed_one"})
    assert pairing.predicted_joint("a") == ("joint_0", None)
    assert pairing.predicted_joint("b") == ("gone", "no matched predicted joint")
    assert pairing.predicted_joint("c") == ("fixed_one", "the matched predicted joint is fixed")
    assert pairing.predicted_joint("d") == (None, "no matched predicted joint")
    axis, pivot, kind = pairing.estimates["joint_0"]
    point, direction = pred.joint_frames()["joint_0"]
    assert kind == "prismatic" and np.allclose(axis, direction) and np.allclose(pivot, point)


def _reference_fails_on(joint_name: str, monkeypatch) -> None:
    """Make the scripted opener's ground-truth reference episode fail on ``joint_name`` (a real failure
    needs an object the opener cannot open; the rule under test is what the scores do with one)."""
    import spark_bench.opening.judge as scoring
    from spark_bench.opening.episodes import OpenResult

    real = scoring.open_with_ground_truth

    def reference(env, seed=None, **kwargs):
        if env.unwrapped.scene.joint.name == joint_name:
            return OpenResult(success=False, steps=200, fraction=0.1, max_fraction=0.12, episode_return=0.0)
        return real(env, seed=seed, **kwargs)

    monkeypatch.setattr(scoring, "open_with_ground_truth", reference)


@pytest.mark.parametrize("why", ["planner", "scene", "reference"])
def test_both_scores_leave_out_the_same_joint_with_the_same_reason(why, button_dir, jammed_dir, case_gt_dir,
                                                                   monkeypatch):
    """The one rule, for the scripted opening score and the RL transfer score alike: the planner declines
    the push button, the scene finds the jammed drawer stuck, the opener fails the reference episode (here:
    made to, on the door). The joint is left out of both with the same reason, matched or not, and each
    result says how many joints its rate covers. Only the left-out joint is matched: no policy runs."""
    from spark_bench.rl.transfer import rl_transfer_score

    folder, joint, words = {"planner": (button_dir, "joint_0", "push button"), "scene": (jammed_dir, "joint_0", "jammed"),
                            "reference": (case_gt_dir, "joint_1", "fails with the ground-truth joint too"),
                            }[why]
    if why == "reference":
        _reference_fails_on(joint, monkeypatch)
    metrics = {"matching": [{"gt_joint": joint, "pred_joint": joint}]}
    scripted = open_with_predicted_joints(folder, folder, metrics)
    rl = rl_transfer_score(folder, folder, metrics, finetune_steps=0)
    reason = scripted["joints"][joint]["reason"]
    assert words in reason and "\n" not in reason
    kind = {"planner": "planner", "scene": "stuck", "reference": "reference"}[why]
    assert scripted["joints"][joint] == {"success": None, "reason": reason, "left_out_kind": kind,
                                         "end_effector": "gripper"}
    assert rl["joints"][joint]["reason"] == reason and rl["joints"][joint]["left_out_kind"] == kind
    assert rl["joints"][joint]["success"] is None and rl["joints"][joint]["zero_shot"] is None
    for result in (scripted, rl):
        assert (result["joints_total"], result["joints_scored"], result["left_out"]) == (2, 1, {joint: reason})
        assert result["left_out_kinds"] == {kind: 1}
        assert result["success_rate"] == 0.0  # the other joint, scored, was not matched
    assert rl["zero_shot_success_rate"] == 0.0 and rl["finetune"] == {}
    other = next(name for name in rl["joints"] if name != joint)
    assert rl["joints"][other]["why"] == scripted["joints"][other]["why"] == "no matched predicted joint"


def test_every_joint_left_out_gives_no_rate(button_dir, monkeypatch):
    """A ground truth whose every drawer and door is left out has no rate (None), not 0: the case is no
    test of any prediction."""
    _reference_fails_on("joint_1", monkeypatch)  # the door; the planner declines the push button
    result = open_with_predicted_joints(button_dir, button_dir, {"matching": []})
    assert result["success_rate"] is None
    assert (result["joints_total"], result["joints_scored"]) == (2, 0) and set(result["left_out"]) == {"joint_0", "joint_1"}
    assert result["left_out_kinds"] == {"planner": 1, "reference": 1}


def test_open_every_joint_reports_the_rule_and_what_the_episodes_did(monkeypatch):
    """The opener's diagnostic runs every joint's episodes, also those the scores leave out, and gives the
    scores' reason: the scene's for the jammed drawer, the failed first episode's for the door (made to
    fail); its numbers are the episodes'."""
    _reference_fails_on("joint_1", monkeypatch)
    rows = {row["joint"]: row for row in open_every_joint(jammed_cabinet(), episodes=1)}
    assert set(rows) == {"joint_0", "joint_1"}
    assert "jammed" in rows["joint_0"]["reason"] and rows["joint_0"]["success_rate"] == 0.0
    assert rows["joint_0"]["max_fraction"] < 0.75  # the episode ran, the drawer stayed shut
    assert rows["joint_1"]["reason"].startswith("the scripted opener fails with the ground-truth joint too")
    assert rows["joint_1"]["success_rate"] == 0.0 and rows["joint_1"]["max_fraction"] == 0.12
