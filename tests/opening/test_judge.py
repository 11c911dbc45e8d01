"""The opening score's rule for one ground-truth joint (:func:`spark_bench.opening.judge.judge_joint`): the
grasp is planned once per joint and handed to the environment, and a safe door the gripper fails with its own
joint is scored with the suction cup."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_open import opens_with_its_hinge_only
from helpers_real import PARTNET_DEV

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.opening.judge import judge_joint


def test_the_judge_plans_each_joints_grasp_once_and_the_environment_compiles_its_scene_for_that_plan(monkeypatch):
    """One plan per joint: the judge's own (:func:`~spark_bench.manipulation.scene.plan_grasp`) reaches the
    environment, whose scene plans no other (``build_scene`` is handed it), and the reference episode runs on
    it."""
    import spark_bench.manipulation.scene as scene_module
    import spark_bench.manipulation.task as task_module

    plans: list[str] = []
    real = scene_module.plan_grasp

    def counted(asset, joint, gripper=None):
        plans.append(joint)
        return real(asset, joint, gripper)

    monkeypatch.setattr(scene_module, "plan_grasp", counted)
    monkeypatch.setattr(task_module, "plan_grasp", counted)
    asset = procedural_cabinet(0)
    judged = judge_joint(asset, asset.joints["joint_0"], seed=0, max_steps=200)
    try:
        assert plans == ["joint_0"]
        planned = real(asset, "joint_0")  # the memo's entry: the very plan the judge made
        assert judged.reason is None and judged.end_effector == "gripper" and judged.grasp == planned.source
        assert judged.env.unwrapped.scene.grasp is planned
        np.testing.assert_array_equal(judged.env.unwrapped.scene.grasp.point, planned.point)
    finally:
        judged.close()


@pytest.mark.slow
def test_a_safe_door_the_gripper_fails_with_its_own_joint_is_scored_with_the_cup():
    """PartNet-Mobility safe 102387 (a door behind its dial): the only pinch is a low ring beside a 200 mm dial,
    the pads land on the dial, and the scripted opener fails with the door's own joint. The opening score's
    rule (``judge_joint``, ``auto``) then tries the cup on the door's front: it opens the door with the true
    hinge, and not with the hinge turned in the door's plane, so the door is scored (with the cup), not left
    out."""
    from spark_bench.data import load_object
    from spark_bench.envs import make_env
    from spark_bench.manipulation.scene import plan_grasp
    from spark_bench.opening.judge import judge_joint

    folder = PARTNET_DEV / "102387"
    if not folder.is_dir():
        pytest.skip(f"partnet_dev objects not available ({folder} is absent)")
    asset = load_object(folder)  # at its real size, as the opening score acts on it
    grasp = plan_grasp(asset, "joint_0")  # with the simulated collision shapes, as the environments plan
    assert grasp.reason is None and grasp.landing
    env = make_env("SparkDoor-v0", asset=asset, joint="joint_0", end_effector="auto", max_episode_steps=200)
    assert env.unwrapped.end_effector == "gripper"  # something to pinch: the environment keeps the gripper
    assert opens_with_its_hinge_only(env, 200)[0] is False
    env.close()
    judged = judge_joint(asset, asset.joints["joint_0"], seed=0, max_steps=200)
    try:
        assert judged.reason is None and judged.end_effector == "suction" and judged.cup_radius is not None
        assert opens_with_its_hinge_only(judged.env, 200) == (True, False)
    finally:
        judged.close()
