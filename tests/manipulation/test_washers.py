"""Washers' doors and lids (synth objects): where the grasp planner takes a front-loader's door whose rim tab
the body blocks, and a top-loader's lid lifted by its lip, pinched beside the deck or, too heavy for that
pinch (the drive check), taken by the suction cup."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from helpers_open import opens_with_its_hinge_only

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.opening.episodes import open_with_ground_truth


def test_a_washers_door_whose_rim_tab_the_body_blocks_is_opened_from_its_front(tmp_path):
    """A front-loading washer's handle is a tab on the door's rim, flush with its depth: pinched from beyond
    the rim, the pads would run into the body's front just behind it. The tab gives way to the front's own
    grasps (nothing to pinch there: ``no_handle``, not ``blocked``), and ``auto`` opens the door with the cup
    on its front, with the true hinge, and not with the hinge turned in the door's plane."""
    from spark_bench.data.synth import generate_object
    from spark_bench.manipulation.grasp import find_grasp, find_grasp_unchecked
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.rest_meshes import RestMeshes

    folder = str(generate_object("WashingMachine", 5001, tmp_path, "WashingMachine_5001"))
    env = gym.make("SparkDoor-v0", asset=folder, joint="joint_3", end_effector="auto", max_episode_steps=200)
    asset = env.unwrapped.scene.asset
    assert find_grasp_unchecked(RestMeshes(asset), "joint_3", 0, GripperConfig()).source == "tab"  # what it looks at first
    grasp = find_grasp(asset, "joint_3")
    assert grasp.source == "face" and grasp.declined == "no_handle"
    scene = env.unwrapped.scene
    assert scene.end_effector == "suction" and scene.grasp.reason is None
    assert scene.grasp.outward @ np.array([-1.0, 0.0, 0.0]) > 0.99  # on the door's front, not from its side
    assert opens_with_its_hinge_only(env, 200) == (True, False)
    env.close()


def test_a_top_loading_washers_lid_lifted_by_its_lip_is_pinched_beside_the_deck_or_taken_by_the_cup(tmp_path):
    """A top-loading washer's lid has a lip along its front edge, a few cm over the deck. The pads come in
    pre-closed beside the lip (open, the lower one lands on the deck). Lifting the lid moves the lip along the
    fingers' closing, where one finger's servo alone holds it: a 5.9 kg lid is too heavy for that pinch
    (``weak_pinch``, the drive check at that force), so ``auto`` takes the cup on the lid's top, which opens it
    with the true hinge and not with the hinge turned in the lid's plane; a 4.7 kg lid stays with the pinch."""
    from spark_bench.data.synth import generate_object
    from spark_bench.manipulation.drive_check import hand_pull
    from spark_bench.manipulation.gripper import largest_pull, pinch_hold
    from spark_bench.manipulation.scene import plan_grasp

    heavy = str(generate_object("TopLoadingWasher", 5003, tmp_path, "heavy"))
    light = str(generate_object("TopLoadingWasher", 5005, tmp_path, "light"))
    pinched = gym.make("SparkDoor-v0", asset=heavy, joint="joint_1", end_effector="gripper", max_episode_steps=200)
    scene = pinched.unwrapped.scene
    grasp = plan_grasp(scene.asset, "joint_1")
    assert grasp.source == "tab" and grasp.opening is not None and grasp.opening < 0.02  # pre-closed beside the lip
    config = scene.gripper.config
    assert hand_pull(scene) == pytest.approx(pinch_hold(config), rel=0.05) and pinch_hold(config) < largest_pull(config)
    assert scene.grasp.declined == "weak_pinch" and "too heavy for the pinch" in scene.grasp.reason
    pinched.close()

    env = gym.make("SparkDoor-v0", asset=heavy, joint="joint_1", end_effector="auto", max_episode_steps=200)
    scene = env.unwrapped.scene
    assert scene.end_effector == "suction" and scene.grasp.reason is None
    assert scene.grasp.outward @ np.array([0.0, 0.0, 1.0]) > 0.9  # on the lid's top
    assert opens_with_its_hinge_only(env, 200) == (True, False)
    env.close()

    env = gym.make("SparkDoor-v0", asset=light, joint="joint_2", end_effector="auto", max_episode_steps=200)
    scene = env.unwrapped.scene
    assert scene.end_effector == "gripper" and scene.grasp.source == "tab" and scene.grasp.reason is None
    assert open_with_ground_truth(env, seed=0, max_steps=200).success
    env.close()
