"""The RL transfer score (``eval --rl``): the shipped generalist, fine-tuned on the prediction, judged on the
ground truth's drawers and doors (those nobody can open left out, as the scripted score leaves them out:
``tests/opening/test_scoring.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from spark_bench.data.case import prediction_to_gt_metres
from spark_bench.rl.transfer import rl_transfer_score


@pytest.fixture(scope="module")
def default_cabinet():
    """The default cabinet: joint_0 a door, joint_2 a drawer (the shipped policies open both)."""
    from spark_bench.envs.assets import default_asset_path

    folder = default_asset_path()
    if folder is None:
        pytest.skip("the synth generator is not installed")
    return folder


def matching(*pairs) -> dict:
    return {"matching": [{"gt_joint": g, "pred_joint": p} for g, p in pairs], "alignment": None}


def test_prediction_frame_undoes_a_moved_and_scaled_copy():
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.envs.cabinet import procedural_cabinet

    gt = procedural_cabinet(0)
    moved = np.diag([1.7, 1.7, 1.7, 1.0])
    moved[:3, 3] = [0.4, -1.0, 2.0]
    pred = similarity_asset(gt, moved)  # a prediction twice as large as the object, elsewhere
    frame = prediction_to_gt_metres(pred, gt)
    np.testing.assert_allclose(frame, np.linalg.inv(moved), atol=1e-9)
    back = similarity_asset(pred, frame)
    for name, (point, axis) in gt.joint_frames().items():
        p, a = back.joint_frames()[name]
        np.testing.assert_allclose(a, axis, atol=1e-6)
        np.testing.assert_allclose(np.cross(p - point, axis), 0.0, atol=1e-6)  # the same axis line
    # the metrics' alignment acts in the benchmark frame, between the two
    turn = np.eye(4)
    turn[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    from spark_bench.data.case import benchmark_frame

    expected = np.linalg.inv(benchmark_frame(gt)) @ turn @ benchmark_frame(pred)
    np.testing.assert_allclose(prediction_to_gt_metres(pred, gt, turn), expected, atol=1e-9)
    twice = np.diag([2.0, 2.0, 2.0, 1.0])  # a case's ground truth in metres: applied last
    np.testing.assert_allclose(prediction_to_gt_metres(pred, gt, turn, twice), twice @ expected, atol=1e-9)


def test_the_oracle_opens_every_drawer_and_door_zero_shot(default_cabinet, tmp_path):
    video = tmp_path / "episode.gif"
    result = rl_transfer_score(default_cabinet, default_cabinet,
                               matching(("joint_0", "joint_0"), ("joint_2", "joint_2")),
                               finetune_steps=0, episodes=1, video=video)
    joints = result["joints"]
    assert set(joints) == {"joint_0", "joint_2"}
    assert joints["joint_0"]["kind"] == "door" and joints["joint_2"]["kind"] == "drawer"
    assert result["zero_shot_success_rate"] == 1.0 and result["success_rate"] == 1.0
    assert video.stat().st_size > 1000 and sum("video" in j for j in joints.values()) == 1
    assert result["policy"]["weights"] == "shipped" and result["policy"]["version"]
    # the cabinet's handles are holdable, by the gripper (auto); both assets are named by path and content hash
    assert all(j["grasp"] != "face" and "reason" not in j and j["end_effector"] == "gripper" for j in joints.values())
    assert result["scored_by"] == {"gripper": 2}
    assert result["holdable_joints"] == 2 and result["holdable_zero_shot_success_rate"] == 1.0
    assert (result["joints_total"], result["joints_scored"], result["left_out"]) == (2, 2, {})
    from spark_bench.data import load_object
    from spark_bench.rl.records import asset_content_hash

    digest = asset_content_hash(load_object(default_cabinet))
    assert result["assets"]["ground_truth"] == {"path": str(default_cabinet), "sha256": digest}
    assert result["assets"]["prediction"]["sha256"] == digest


def test_a_wrong_predicted_axis_fails_and_an_unmatched_joint_counts(default_cabinet, tmp_path):
    """The prediction's drawer slides sideways: told that axis, the policy drags the real drawer's handle
    sideways. The door has no matched predicted joint: not opened, and still counted."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data import load_object

    pred = load_object(default_cabinet)
    axis = pred.joints["joint_2"].axis
    sideways = np.cross(axis, [0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.cross(axis, [1.0, 0.0, 0.0])
    pred.joints["joint_2"].axis = sideways / np.linalg.norm(sideways)
    write_object_folder(pred, tmp_path / "pred")
    result = rl_transfer_score(tmp_path / "pred", default_cabinet, matching(("joint_2", "joint_2")),
                               finetune_steps=0, episodes=1)
    joints = result["joints"]
    assert joints["joint_2"]["zero_shot"] == 0.0 and joints["joint_2"]["zero_shot_max_fraction"] < 0.5
    assert joints["joint_0"] == {"type": "revolute", "pred_joint": None, "zero_shot": 0.0, "success": 0.0,
                                 "end_effector": "gripper", "why": "no matched predicted joint"}
    assert result["zero_shot_success_rate"] == 0.0 and result["success_rate"] == 0.0
    assert result["joints_scored"] == result["joints_total"] == 2  # both counted: neither is left out


@pytest.mark.slow
def test_finetuning_trains_a_copy_on_the_prediction(default_cabinet, tmp_path):
    from spark_bench.rl.generalist import load_generalist

    result = rl_transfer_score(default_cabinet, default_cabinet,
                               matching(("joint_2", "joint_2"), ("joint_0", "joint_2")),
                               out_dir=tmp_path, finetune_steps=256, episodes=1)
    # one fine-tuning for the drawer policy (both ground-truth joints were matched with the drawer)
    assert list(result["finetune"]) == ["drawer"] and result["finetune"]["drawer"]["steps"] >= 256
    assert result["joints"]["joint_0"]["kind"] == "drawer"  # a door told it is a drawer: the drawer policy
    tuned = load_generalist("drawer", env=None).policy.state_dict()
    from stable_baselines3 import PPO

    saved = PPO.load(tmp_path / "drawer_finetuned.zip", device="cpu").policy.state_dict()
    changed = [k for k in saved if not np.allclose(saved[k].numpy(), tuned[k].numpy())]
    assert changed  # the copy was trained; the shipped weights were not touched
    assert load_generalist("drawer").policy.state_dict()["action_net.weight"].equal(tuned["action_net.weight"])
    assert 0.0 <= result["success_rate"] <= 1.0 and result["joints"]["joint_2"]["max_fraction"] >= 0.0


def test_a_prediction_without_a_task_to_finetune_on_fails_the_finetuned_column(default_cabinet, tmp_path):
    """The predicted drawer has no geometry: nothing to grasp in the prediction's simulation, so no
    fine-tuning; the zero-shot column still acts on the ground truth with the predicted joint."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data import load_object

    pred = load_object(default_cabinet)
    for link in pred.part_of_joint("joint_2"):
        pred.links[link].visuals, pred.links[link].collisions = [], []
    write_object_folder(pred, tmp_path / "pred")
    result = rl_transfer_score(tmp_path / "pred", default_cabinet, matching(("joint_2", "joint_2")),
                               finetune_steps=64, episodes=1)
    row = result["joints"]["joint_2"]
    assert row["success"] == 0.0 and row["why"] == "the prediction gives no opening task to fine-tune on"
    assert "joint_2" in result["finetune"]["drawer"]["skipped"] and result["finetune"]["drawer"]["steps"] == 0
    assert "zero_shot_max_fraction" in row


def test_the_oracle_ground_truth_is_loaded_once(default_cabinet, tmp_path, object_loads):
    """The oracle's prediction folder is the ground-truth folder: one load, not two (0.6 s CPU on a
    52k-vertex PartNet object); a prediction in another folder is still loaded from its own files.
    Nothing matched: no policy runs (the rule's scripted reference episodes act on the ground truth in
    memory, loading nothing)."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data.readers import load_object

    copy = tmp_path / "copy"
    write_object_folder(load_object(default_cabinet), copy)
    loaded = object_loads
    loaded.clear()
    same = rl_transfer_score(default_cabinet, default_cabinet, matching(), finetune_steps=0)
    assert len(loaded) == 1
    loaded.clear()
    other = rl_transfer_score(copy, default_cabinet, matching(), finetune_steps=0)
    assert len(loaded) == 2 and loaded[1] == str(copy)
    assert same["success_rate"] == other["success_rate"] == 0.0
    assert same["assets"]["prediction"] == same["assets"]["ground_truth"]
    assert other["assets"]["prediction"]["path"] == str(copy)


def test_a_ground_truth_the_caller_loaded_is_not_loaded_again(default_cabinet, tmp_path, object_loads):
    """``eval`` loads a case's ground truth once (its metrics stage) and hands it to the opening and RL
    stages: with ``gt_bench`` neither reads the ground-truth folder again (a real case's R=200 remesh is
    ~0.6 s CPU a load); the prediction in its own folder is still read."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data.readers import load_object
    from spark_bench.opening.judge import open_with_predicted_joints

    copy = tmp_path / "copy"
    write_object_folder(load_object(default_cabinet), copy)
    gt_bench = load_object(default_cabinet)
    loaded = object_loads
    loaded.clear()
    rl_transfer_score(copy, default_cabinet, matching(), finetune_steps=0, gt_bench=gt_bench)
    assert loaded == [str(copy)]
    loaded.clear()
    open_with_predicted_joints(copy, default_cabinet, matching(), gt_bench=gt_bench)
    assert loaded == [str(copy)]
    loaded.clear()
    open_with_predicted_joints(copy, default_cabinet, matching())  # without it: both folders
    assert sorted(loaded) == sorted([str(default_cabinet), str(copy)])


def test_fine_tuning_takes_the_fused_adam_step_and_repeats_to_the_bit(default_cabinet):
    """The fused step's square root is correctly rounded (torch's unfused one is MKL's, whose last bit differs
    between CPUs): the loaded optimizer is switched to it, and the same fine-tuning gives the same weights."""
    import torch

    from spark_bench.rl.transfer import finetune

    weights = []
    for _ in range(2):
        model, info = finetune("drawer", default_cabinet, ["joint_2"], steps=32, seed=5)
        assert info["steps"] >= 32
        assert all(group["fused"] for group in model.policy.optimizer.param_groups)
        weights.append(torch.cat([p.detach().flatten() for p in model.policy.parameters()]).numpy())
    assert np.array_equal(weights[0], weights[1])
