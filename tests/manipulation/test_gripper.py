"""The parallel gripper (:mod:`spark_bench.manipulation.gripper`): the grip command and the finger target
invert each other, and the fingers settle at the opening commanded."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS


def test_grip_command_spans_the_gripper_travel():
    from spark_bench.manipulation.gripper import GripperConfig, finger_target, grip_command

    cfg = GripperConfig()
    assert grip_command(cfg, cfg.max_opening) == pytest.approx(-1.0)
    assert grip_command(cfg, -cfg.squeeze) == pytest.approx(1.0)
    for opening in (-cfg.squeeze, 0.0, 0.013, cfg.max_opening):  # the env's mapping inverts it
        assert finger_target(cfg, grip_command(cfg, opening)) == pytest.approx(opening)
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    env.reset(seed=0)
    for _ in range(15):  # held at a partial opening, the fingers settle there
        obs, *_ = env.step(np.array([0, 0, 0, grip_command(cfg, 0.01)], dtype=np.float32))
    assert obs[OBS.FINGERS] * cfg.max_opening == pytest.approx(0.01, abs=0.001)
