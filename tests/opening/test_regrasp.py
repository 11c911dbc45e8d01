"""The scripted opener's re-grasp: a hand going back to a part that slipped out of its fingers part-way open
must not push it shut (a real safe's door, let go at 0.66 of its range, was pushed back from 0.75 to 0.60
by the hand coming in again)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from helpers_open import opener_observation

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS
from spark_bench.opening.episodes import ground_truth_joint, opener_for
from spark_bench.opening.opener import PREGRASP_OFFSET, PUSH_GUARD, REGRASP_DISTANCE, ScriptedOpener


def _slipped_door_opener(grasp_moved=(0.0, 0.0, 0.0)):
    """An opener on a door hinged about z at (0.3, -0.5, z) (at its handle it opens along its outward
    direction, -x) that held the handle and swung it ``grasp_moved`` on (m), then lost it: the hand ran on
    beside the handle, REGRASP_DISTANCE + 1 cm across the pull, its fingers still over the face."""
    outward = np.array([-1.0, 0.0, 0.0])
    opener = ScriptedOpener(axis=[0.0, 0.0, 1.0], pivot=[0.3, -0.5, 0.4], joint_type="revolute", outward=outward)
    rest = np.array([0.3, 0.0, 0.4])
    opener(opener_observation(rest + PREGRASP_OFFSET * outward, rest))  # pre-grasp reached
    for _ in range(12):  # approach reached, close
        opener(opener_observation(rest, rest))
    assert opener.phase == "open"
    grasp = rest + np.asarray(grasp_moved)
    opener(opener_observation(grasp, grasp))
    tcp = grasp + np.array([-0.01, REGRASP_DISTANCE + 0.01, 0.0])
    action = opener(opener_observation(tcp, grasp))
    assert opener.phase == "pregrasp" and opener.regrasps == 1 and action[3] < 0
    return opener, grasp, tcp, outward, action


def test_after_a_slip_the_hand_backs_out_from_a_door_before_it_crosses_over():
    """The hand first moves straight away from the door's face (along the outward direction only), and only
    once it stands the pre-grasp distance out does it cross over to the pre-grasp in front of the handle."""
    opener, grasp, tcp, outward, action = _slipped_door_opener()
    assert action[0] < -0.5 and abs(action[1]) < 1e-6 and abs(action[2]) < 1e-6  # out, not across
    out = grasp + np.array([-PREGRASP_OFFSET, REGRASP_DISTANCE + 0.01, 0.0])  # backed out, still beside it
    action = opener(opener_observation(out, grasp))
    assert action[1] < -0.5  # now across, towards the pre-grasp in front of the handle


def test_the_re_grasp_of_an_open_door_waits_comes_in_slowly_and_stops_where_it_would_push_it_shut():
    """While the door still swings the hand holds at the pre-grasp; coming in, it moves at most REGRASP_STEP a
    step and stops (and closes there) as soon as the door is knocked towards closing or a pad touches it. A
    door at rest against its stop is approached at full speed, as at first."""
    from spark_bench.manipulation.gripper import MAX_STEP
    from spark_bench.opening.opener import REGRASP_STEP

    opener, grasp, tcp, outward, _ = _slipped_door_opener((-0.05, 0.0, 0.0))
    pre = PREGRASP_OFFSET * outward
    moving = grasp.copy()
    for _ in range(5):  # the door swings on, 3 mm a step: no approach yet
        moving = moving + 0.003 * outward
        opener(opener_observation(moving + pre, moving))
        assert opener.phase == "pregrasp"
    opener(opener_observation(moving + pre, moving))  # at rest
    assert opener.phase == "approach"
    action = opener(opener_observation(moving + pre, moving))
    assert 0.5 * REGRASP_STEP <= np.linalg.norm(action[:3]) * MAX_STEP <= REGRASP_STEP + 1e-6  # slowly
    knocked = moving - 3 * PUSH_GUARD * outward  # the door swung back 3 mm in one step: the hand knocked it
    action = opener(opener_observation(moving + 0.04 * outward, knocked))
    assert opener.phase == "close" and np.linalg.norm(action[:3]) < 1e-6
    for _ in range(3):  # closing, the hand stays where it stopped even as the door swings away
        action = opener(opener_observation(moving + 0.04 * outward, knocked - 0.01 * outward))
        assert np.linalg.norm(action[:3]) < 1e-6 and action[3] > 0
    # a pad touching the open door stops the approach too
    opener, grasp, tcp, outward, _ = _slipped_door_opener((-0.05, 0.0, 0.0))
    for _ in range(3):
        opener(opener_observation(grasp + pre, grasp))
    assert opener.phase == "approach"
    opener(opener_observation(grasp + 0.03 * outward, grasp, touch=(0.3, 0.0)))
    assert opener.phase == "close"
    # the same door slipped at rest (against its stop): the full-speed approach, untouched by a touch
    opener, grasp, tcp, outward, _ = _slipped_door_opener()
    for _ in range(3):
        opener(opener_observation(grasp + pre, grasp))
    action = opener(opener_observation(grasp + pre, grasp, touch=(0.3, 0.0)))
    assert opener.phase == "approach" and np.linalg.norm(action[:3]) * MAX_STEP > 1.5 * REGRASP_STEP


def test_a_door_let_go_half_open_is_not_pushed_shut_by_the_hand_coming_back():
    """The procedural cabinet's door, opened past half its range by the scripted opener and let go (the
    fingers open, the hand runs on along the swing for 4 steps, as when a handle slips out): the opener
    grasps again, and the door never closes by more than 0.05 of its range below where it was let go. (Before
    the re-grasp backed out, waited and came in guarded, the hand coming back swung it shut to about 0.2.) The
    same with the push from inside (a door this far open fits the hand behind it) and with the re-grasp."""
    env = gym.make("SparkDoor-v0", asset="procedural:0", max_episode_steps=200)
    unwrapped = env.unwrapped
    axis, pivot, joint_type = ground_truth_joint(env)
    for seed, push in ((0, True), (2, True), (0, False), (2, False)):
        opener = opener_for(env, axis, pivot, joint_type)
        if not push:  # the re-grasp of a door too little open to push from inside
            opener.edge = None
        obs, _ = env.reset(seed=seed)
        for _ in range(150):
            if unwrapped.joint_fraction >= 0.5:
                break
            obs, *_ = env.step(opener(obs))
        assert unwrapped.joint_fraction >= 0.5 and opener.regrasps == 0
        grasp = obs[OBS.GRASP].astype(float)
        swing = np.cross(axis, grasp - pivot)
        swing /= np.linalg.norm(swing)
        for _ in range(4):  # let go: fingers open, the hand runs on ahead of the handle
            obs, *_ = env.step(np.append(swing, -1.0).astype(np.float32))
        released = unwrapped.joint_fraction
        fractions = []
        for _ in range(40):
            obs, *_ = env.step(opener(obs))
            fractions.append(unwrapped.joint_fraction)
        assert opener.regrasps >= 1, "the opener did not notice that it let go"
        assert min(fractions) >= released - 0.05, (seed, released, min(fractions))
    env.close()


def test_the_wait_for_a_swinging_door_ends():
    """A door that never comes to rest (a hand nudging it, a part oscillating on its joint) is waited for at
    most twice the pre-grasp's step budget; then the approach starts."""
    from spark_bench.opening.opener import PREGRASP_STEPS

    opener, grasp, tcp, outward, _ = _slipped_door_opener((-0.05, 0.0, 0.0))
    pre = PREGRASP_OFFSET * outward
    for step in range(4 * PREGRASP_STEPS):
        moving = grasp + (0.003 if step % 2 else -0.003) * outward  # 6 mm back and forth every step
        opener(opener_observation(moving + pre, moving))
        if opener.phase != "pregrasp":
            break
    assert opener.phase == "approach" and PREGRASP_STEPS < step <= 2 * PREGRASP_STEPS + 1
