"""The environments' ``frame`` observation: the grasp frame and the joint, what a policy needs to act on
any asset (``observation="frame"``), and the joint it reports (``joint_estimate``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS
from spark_bench.envs.observation import FRAME_OBS_SIZE, OBS_SIZE
from spark_bench.opening.episodes import ground_truth_joint
from spark_bench.opening.opener import rotate_about


def frame_env(env_id: str, **kwargs):
    return gym.make(env_id, asset="procedural:0", observation="frame", **kwargs)


@pytest.mark.parametrize("env_id", ["SparkDrawer-v0", "SparkDoor-v0"])
def test_frame_observation_extends_the_basic_one(env_id):
    basic = gym.make(env_id, asset="procedural:0")
    frame = frame_env(env_id)
    assert basic.observation_space.shape == (OBS_SIZE,) and frame.observation_space.shape == (FRAME_OBS_SIZE,)
    check_env(frame.unwrapped, skip_render_check=True)
    a, _ = basic.reset(seed=3)
    b, _ = frame.reset(seed=3)
    np.testing.assert_array_equal(a, b[:OBS_SIZE])  # the same physics, the first 19 entries unchanged
    action = np.array([0.3, -0.2, 0.1, 0.5], dtype=np.float32)
    for _ in range(5):
        a, *_ = basic.step(action)
        b, *_ = frame.step(action)
    np.testing.assert_array_equal(a, b[:OBS_SIZE])
    assert frame.observation_space.contains(b)


def test_drawer_frame_is_the_grasp_and_the_ground_truth_axis():
    env = frame_env("SparkDrawer-v0")
    obs, _ = env.reset(seed=0)
    grasp = env.unwrapped.scene.grasp
    outward, closing = obs[OBS.OUTWARD], obs[OBS.CLOSING]
    np.testing.assert_allclose(outward, grasp.outward, atol=1e-6)
    np.testing.assert_allclose(closing, grasp.closing, atol=1e-6)
    assert abs(float(outward @ closing)) < 1e-6
    axis, _, joint_type = ground_truth_joint(env)
    np.testing.assert_allclose(obs[OBS.AXIS], axis, atol=1e-6)
    assert joint_type == "prismatic" and obs[OBS.REVOLUTE] == 0.0 and np.all(obs[OBS.TO_AXIS] == 0.0)
    # a bar handle: pinched with the fingers approaching fully open, nothing to press on
    assert obs[OBS.INSIDE_GRIP] == 0.0 and obs[OBS.APPROACH_GRIP] == -1.0 and np.all(obs[OBS.PRESS] == 0.0)


def test_door_frame_turns_with_the_door_and_reports_its_hinge():
    env = frame_env("SparkDoor-v0")
    obs, _ = env.reset(seed=0)
    axis, pivot, _ = ground_truth_joint(env)
    grasp = obs[OBS.GRASP].astype(float)
    to_axis = obs[OBS.TO_AXIS].astype(float)
    # the vector from the grasp point to its nearest point on the hinge line
    foot = pivot + ((grasp - pivot) @ axis) * axis
    np.testing.assert_allclose(to_axis, foot - grasp, atol=1e-5)
    assert obs[OBS.REVOLUTE] == 1.0 and abs(float(to_axis @ axis)) < 1e-5
    # swing the door by 0.6 rad: the grasp frame turns with it about the hinge, the hinge stays
    u = env.unwrapped
    u.data.qpos[u._joint_q] += 0.6
    from spark_bench.mujoco_gl import mujoco_module

    mujoco_module().mj_forward(u.model, u.data)
    turned = u._obs()
    for direction in (OBS.OUTWARD, OBS.CLOSING):
        swung = rotate_about(obs[direction].astype(float), np.zeros(3), axis, 0.6)
        np.testing.assert_allclose(turned[direction], swung, atol=1e-5)
    np.testing.assert_allclose(turned[OBS.AXIS], obs[OBS.AXIS], atol=1e-7)
    # the grasp point kept its distance to the hinge
    assert np.linalg.norm(turned[OBS.TO_AXIS]) == pytest.approx(np.linalg.norm(to_axis), abs=1e-5)


def test_joint_estimate_is_what_the_observation_reports():
    env = frame_env("SparkDoor-v0")
    axis, pivot, _ = ground_truth_joint(env)
    wrong_axis = np.cross(axis, [1.0, 0.0, 0.0])
    wrong_pivot = pivot + np.array([0.0, 0.2, 0.0])
    told = frame_env("SparkDoor-v0", joint_estimate=(2.0 * wrong_axis, wrong_pivot, "prismatic"))
    own, _ = env.reset(seed=1)
    obs, _ = told.reset(seed=1)
    joint = OBS.AXIS.start  # the same scene: only the joint entries differ
    np.testing.assert_array_equal(obs[:joint], own[:joint])
    np.testing.assert_allclose(obs[OBS.AXIS], wrong_axis / np.linalg.norm(wrong_axis), atol=1e-6)  # normalized
    assert obs[OBS.REVOLUTE] == 0.0 and np.all(obs[OBS.TO_AXIS] == 0.0)  # told prismatic: no hinge
    told = frame_env("SparkDoor-v0", joint_estimate=(axis, wrong_pivot, "revolute"))
    obs, _ = told.reset(seed=1)
    grasp = obs[OBS.GRASP].astype(float)
    foot = wrong_pivot + ((grasp - wrong_pivot) @ axis) * axis
    np.testing.assert_allclose(obs[OBS.TO_AXIS], foot - grasp, atol=1e-5)
    assert not np.allclose(obs[OBS.TO_AXIS], own[OBS.TO_AXIS], atol=1e-3)


@pytest.mark.parametrize("estimate,match", [
    (((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), "revolute"), "non-zero finite 3-vector axis"),
    (((1.0, 0.0, 0.0), (np.nan, 0.0, 0.0), "revolute"), "finite 3-vector pivot"),
    (((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), "fixed"), "type must be one of"),
])
def test_a_bad_joint_estimate_or_observation_is_refused(estimate, match):
    with pytest.raises(ValueError, match=match):
        frame_env("SparkDrawer-v0", joint_estimate=estimate)
    with pytest.raises(ValueError, match="observation must be one of"):
        gym.make("SparkDrawer-v0", asset="procedural:0", observation="pixels")


def test_inside_grip_reports_the_notch(tmp_path):
    """A synth printer's paper tray has a finger-pull notch: the fingers approach closed (+1) and press
    towards the notch's inner wall, a direction in the front plane."""
    from spark_bench.data.synth import generate_object

    folder = generate_object("Printer", 1, tmp_path, "printer")
    env = gym.make("SparkDrawer-v0", asset=folder, joint="joint_0", observation="frame")
    obs, _ = env.reset(seed=0)
    grasp = env.unwrapped.scene.grasp
    assert grasp.inside_grip and obs[OBS.INSIDE_GRIP] == 1.0 and obs[OBS.APPROACH_GRIP] == 1.0
    press = obs[OBS.PRESS].astype(float)
    np.testing.assert_allclose(press, grasp.press, atol=1e-6)
    assert np.linalg.norm(press) == pytest.approx(1.0, abs=1e-6) and abs(press @ obs[OBS.OUTWARD]) < 1e-6
