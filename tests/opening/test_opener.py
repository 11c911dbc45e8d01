"""The scripted opener (:mod:`spark_bench.opening.opener`, run for one episode by :mod:`spark_bench.opening.episodes`):
it opens the procedural cabinet, synth and real objects, notched fronts and each leaf of a double door with the
true joint, fails planned from a wrong axis or pivot, and moves on when its approach stalls or the handle slips."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from helpers_open import double_door_cabinet, notched_cabinet, opener_observation

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint
from spark_bench.opening.opener import rotate_about


@pytest.fixture(scope="module")
def double_door(tmp_path_factory):
    return double_door_cabinet(tmp_path_factory.mktemp("synth"))


def test_rotate_about_keeps_the_axis_distance():
    point, pivot, axis = np.array([1.0, 0.5, 0.2]), np.array([0.0, 0.5, 0.0]), np.array([0.0, 0.0, 1.0])
    out = rotate_about(point, pivot, axis, np.pi / 2)
    np.testing.assert_allclose(out, [0.0, 1.5, 0.2], atol=1e-12)


@pytest.mark.parametrize("env_id", ["SparkDrawer-v0", "SparkDoor-v0"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scripted_opener_solves_the_procedural_cabinet(env_id, seed):
    env = gym.make(env_id, asset=f"procedural:{seed}")
    result = open_with_ground_truth(env, seed=seed)
    assert result.success and result.fraction >= 0.75
    assert result.steps < 100


def test_a_wrong_predicted_axis_fails_on_the_ground_truth_drawer():
    """Planning from a joint axis 90 degrees off drags the handle sideways: the drawer barely opens."""
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    axis, pivot, joint_type = ground_truth_joint(env)
    good = open_with_joint(env, axis, pivot, joint_type, seed=0)
    sideways = np.cross(axis, [0.0, 0.0, 1.0])
    bad = open_with_joint(env, sideways, pivot, joint_type, seed=0)
    assert good.success and not bad.success
    assert bad.max_fraction < 0.3


def test_a_wrong_predicted_pivot_fails_on_the_ground_truth_door():
    env = gym.make("SparkDoor-v0", asset="procedural:0")
    axis, pivot, joint_type = ground_truth_joint(env)
    assert open_with_joint(env, axis, pivot, joint_type, seed=0).success
    grasp = env.unwrapped.scene.grasp.point
    wrong_pivot = pivot + 0.8 * (grasp - pivot) * np.array([1.0, 1.0, 0.0])  # hinge moved next to the handle
    assert not open_with_joint(env, axis, wrong_pivot, joint_type, seed=0).success


@pytest.mark.slow
def test_scripted_opener_opens_every_drawer_and_door_of_a_real_object(real_object):
    from spark_bench.opening.judge import open_every_joint

    rows = open_every_joint(str(real_object("41083")))
    assert sorted(r["type"] for r in rows) == ["prismatic", "prismatic", "revolute", "revolute"]
    assert all(r["success_rate"] == 1.0 and "reason" not in r for r in rows), rows  # none the scores leave out


#: synth-v1 objects (``object_seed(0, index)``, as the benchmark generates them) whose doors and lids the
#: opener could not open with their own joints: (category, index, joint, grasp source); why, in comments.
SYNTH_V1_OPENINGS = [
    ("Door", 25, "joint_0", "label"),  # a room door's handle is a lever on a joint of its own
    ("Refrigerator", 6, "joint_0", "notch"),  # a finger-pull 0.37 m long on a 1.5 m door
    ("Bucket", 19, "joint_0", "label"),  # the bail is an arc: its box's center is in the air
    ("Box", 3, "joint_0", "tab"),  # the lid's lifting tab stands out past its front edge, below its top
    ("TrashCan", 16, "joint_0", "tab"),
]


@pytest.mark.parametrize("category,index,joint,source", SYNTH_V1_OPENINGS)
def test_scripted_opener_opens_synth_v1_objects(tmp_path, category, index, joint, source):
    from spark_bench.data.synth import generate_object, object_seed

    folder = str(generate_object(category, object_seed(0, index), tmp_path, f"{category}_{index:05d}"))
    env = gym.make("SparkDoor-v0", asset=folder, joint=joint, max_episode_steps=200)
    assert env.unwrapped.scene.grasp.source == source
    result = open_with_ground_truth(env, seed=0, max_steps=200)
    assert result.success and result.fraction >= 0.75, result


def test_the_opener_moves_on_when_its_approach_stalls_and_grasps_again_when_the_handle_slips():
    """A pad resting on a lip stops the hand short of the handle: after STALL_STEPS steps without progress
    the opener closes there instead of pushing out the phase's step budget. While opening, a handle
    REGRASP_DISTANCE away has slipped out of the fingers: the opener opens them and goes back to the
    pre-grasp in front of where the handle now is, at most MAX_REGRASPS times."""
    from spark_bench.opening.opener import (
        MAX_REGRASPS,
        PREGRASP_OFFSET,
        REGRASP_DISTANCE,
        STALL_STEPS,
        ScriptedOpener,
    )

    outward = np.array([-1.0, 0.0, 0.0])
    opener = ScriptedOpener(axis=outward, pivot=np.zeros(3), joint_type="prismatic", outward=outward)
    grasp = np.array([0.3, 0.0, 0.4])
    pregrasp = grasp + PREGRASP_OFFSET * outward
    opener(opener_observation(pregrasp, grasp))
    assert opener.phase == "approach"
    stuck = grasp + 0.03 * outward  # 3 cm short, and it stays there
    for _ in range(STALL_STEPS + 1):
        opener(opener_observation(stuck, grasp))
    assert opener.phase == "close"
    for _ in range(10):
        action = opener(opener_observation(stuck, grasp))
    assert opener.phase == "open" and action[3] > 0  # pulling, fingers closed
    # held: the grasp point moves with the TCP, no regrasp
    action = opener(opener_observation(grasp + 0.01 * outward, grasp))
    assert opener.phase == "open" and opener.regrasps == 0
    # slipped: the drawer stays, the hand ran on
    slipped = grasp + (REGRASP_DISTANCE + 0.01) * outward
    action = opener(opener_observation(slipped, grasp))
    assert opener.phase == "pregrasp" and opener.regrasps == 1 and action[3] < 0  # fingers open
    for _ in range(MAX_REGRASPS + 2):
        opener.phase = "open"
        opener(opener_observation(slipped, grasp))
    assert opener.regrasps == MAX_REGRASPS and opener.phase == "open"


@pytest.mark.parametrize("env_id,joint", [("SparkDrawer-v0", "joint_0"), ("SparkDoor-v0", "joint_1")])
def test_scripted_opener_opens_notched_fronts_with_an_inside_grip(env_id, joint):
    """No handle, a notch: the closed fingers enter it and open against its sides; a predicted axis 90
    degrees off still fails on the notched drawer."""
    env = gym.make(env_id, asset=notched_cabinet(0), joint=joint, max_episode_steps=150)
    assert env.unwrapped.scene.grasp.inside_grip
    axis, pivot, joint_type = ground_truth_joint(env)
    result = open_with_joint(env, axis, pivot, joint_type, seed=0)
    assert result.success and result.fraction >= 0.75
    if joint_type == "prismatic":
        bad = open_with_joint(env, np.cross(axis, [0.0, 0.0, 1.0]), pivot, joint_type, seed=0)
        assert not bad.success and bad.max_fraction < 0.3


def test_scripted_opener_opens_each_leaf_of_a_double_door_alone(double_door):
    """The edge lips of a double door stand ~6 mm apart: with the default 12 mm pads closing from fully
    open, the fingers pinched both lips and neither door opened past 10 %. Each leaf must open while the
    other stays shut."""
    folder = str(double_door)
    env = gym.make("SparkDoor-v0", asset=folder, max_episode_steps=150)
    doors = [j.name for j in env.unwrapped.scene.asset.movable_joints() if j.type == "revolute"]
    env.close()
    assert len(doors) == 2
    for joint, other in ((doors[0], doors[1]), (doors[1], doors[0])):
        env = gym.make("SparkDoor-v0", asset=folder, joint=joint, max_episode_steps=150)
        unwrapped = env.unwrapped
        assert unwrapped.scene.grasp.opening is not None  # the pads go beside the lip, not around both
        result = open_with_ground_truth(env, seed=0)
        assert result.success and result.fraction >= 0.75, (joint, result)
        other_q = unwrapped.data.qpos[unwrapped.model.jnt_qposadr[unwrapped.model.joint(other).id]]
        assert abs(other_q) < 0.02, (other, other_q)  # rad: the neighbour was not dragged along
        env.close()
