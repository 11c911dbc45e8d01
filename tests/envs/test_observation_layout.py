"""The observation layout is defined once (:mod:`spark_bench.envs.observation`): it covers every entry once,
the environments write there what it names, and the environments' docstring tables say the same."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS
from spark_bench.envs.door import SparkDoorEnv
from spark_bench.envs.drawer import SparkDrawerEnv


def test_the_layout_covers_every_entry_once():
    covered = [k for _, where, _ in OBS.LAYOUT for k in OBS.entries(where)]
    assert sorted(covered) == list(range(OBS.FRAME_OBS_SIZE)) and len(covered) == len(set(covered))
    basic = [k for _, where, _ in OBS.LAYOUT for k in OBS.entries(where) if k < OBS.OBS_SIZE]
    assert sorted(basic) == list(range(OBS.OBS_SIZE))
    assert all(min(OBS.entries(w)) >= OBS.OBS_SIZE for _, w, meaning in OBS.LAYOUT if meaning.startswith("frame"))


@pytest.mark.parametrize("env", [SparkDrawerEnv, SparkDoorEnv])
def test_the_docstring_tables_index_the_layout(env):
    """Each row of the environments' tables starts with an entry's index range, and the ranges are the
    layout's, in order."""
    rows = re.findall(r"^\s{4}(\d+)(?:-(\d+))?\s{2,}\S", env.__doc__, flags=re.M)
    ranges = [range(int(a), int(b or a) + 1) for a, b in rows]
    assert ranges == [OBS.entries(where) for _, where, _ in OBS.LAYOUT]


@pytest.mark.parametrize("env_id", ["SparkDrawer-v0", "SparkDoor-v0"])
def test_the_environment_writes_what_the_layout_names(env_id):
    env = gym.make(env_id, asset="procedural:0", observation="frame")
    inner = env.unwrapped
    obs, _ = env.reset(seed=1)
    for step in range(12):
        obs, *_ = env.step(np.array([-0.4, 0.1, 0.0, 1.0 if step > 6 else -1.0], dtype=np.float32))
        np.testing.assert_allclose(obs[OBS.TCP], inner.tcp, atol=1e-6)
        np.testing.assert_allclose(obs[OBS.GRASP], inner.grasp_point, atol=1e-6)
        np.testing.assert_allclose(obs[OBS.TO_GRASP], obs[OBS.GRASP] - obs[OBS.TCP], atol=1e-6)
        assert obs[OBS.GRASP_DISTANCE] == pytest.approx(np.linalg.norm(obs[OBS.TO_GRASP]), abs=1e-6)
        assert obs[OBS.JOINT_FRACTION] == pytest.approx(inner.joint_fraction, abs=1e-6)
        assert np.all((obs[OBS.TOUCH] >= 0.0) & (obs[OBS.TOUCH] <= 1.0))
        assert obs[OBS.FINGERS] <= 1.0 + 1e-6  # open at most fully (closing on nothing can pass 0)
    assert obs[OBS.REVOLUTE] == (1.0 if env_id == "SparkDoor-v0" else 0.0)
    assert np.linalg.norm(obs[OBS.AXIS]) == pytest.approx(1.0, abs=1e-6)
    assert np.linalg.norm(obs[OBS.OUTWARD]) == pytest.approx(1.0, abs=1e-5)
    env.close()
