"""The generalist opening policies: grasp-frame features and actions, the task mixture, the shipped
weights and their record, and that the shipped policies are trained."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS
from spark_bench.envs.observation import FRAME_OBS_SIZE
from spark_bench.rl.generalist import (
    N_FEATURES,
    GeneralistPolicy,
    GraspFrameWrapper,
    Memory,
    TaskMixture,
    features,
    make_task_env,
    to_frame,
    to_world,
)

#: The observation's world-frame vectors (turned with the object; the TCP position is only shifted).
VECTORS = [OBS.TCP_VELOCITY, OBS.GRASP, OBS.TO_GRASP, OBS.OUTWARD, OBS.CLOSING, OBS.AXIS, OBS.TO_AXIS, OBS.PRESS]


def random_frame_obs(rng: np.random.Generator) -> np.ndarray:
    """A plausible ``frame`` observation: unit outward / closing / axis, a hinge off the grasp point."""
    obs = np.zeros(FRAME_OBS_SIZE)
    obs[OBS.TCP] = rng.normal(size=3)
    obs[OBS.GRASP] = obs[OBS.TCP] + 0.05 * rng.normal(size=3)
    obs[OBS.TO_GRASP] = obs[OBS.GRASP] - obs[OBS.TCP]
    obs[OBS.GRASP_DISTANCE] = np.linalg.norm(obs[OBS.TO_GRASP])
    obs[OBS.TCP_VELOCITY] = 0.2 * rng.normal(size=3)
    obs[OBS.WRIST], obs[OBS.FINGERS], obs[OBS.JOINT_FRACTION], obs[OBS.JOINT_VELOCITY] = 0.1, 0.7, 0.3, 0.05
    obs[OBS.TOUCH] = 0.4, 0.0
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    obs[OBS.OUTWARD], obs[OBS.CLOSING] = q[:, 0], q[:, 1]
    axis = q[:, 2]
    obs[OBS.AXIS] = axis
    v = 0.4 * rng.normal(size=3)
    obs[OBS.TO_AXIS] = v - (v @ axis) * axis
    obs[OBS.REVOLUTE], obs[OBS.INSIDE_GRIP], obs[OBS.APPROACH_GRIP] = 1.0, 0.0, -1.0
    return obs


def transformed(obs: np.ndarray, rotation: np.ndarray, shift: np.ndarray) -> np.ndarray:
    out = obs.copy()
    for vector in VECTORS:
        out[vector] = rotation @ obs[vector]
    out[OBS.TCP] += shift
    out[OBS.GRASP] += shift
    return out


def test_features_do_not_depend_on_where_or_how_the_object_stands():
    rng = np.random.default_rng(0)
    for _ in range(5):
        obs = random_frame_obs(rng)
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        rotation *= np.sign(np.linalg.det(rotation))  # a proper rotation
        memory = rng.uniform(0, 1, size=8)
        moved = transformed(obs, rotation, rng.normal(size=3))
        np.testing.assert_allclose(features(moved, memory), features(obs, memory), atol=1e-5)
        # the grasp-frame action means the same motion relative to the object
        action = np.array([0.3, -0.5, 0.2, 1.0])
        np.testing.assert_allclose(to_world(moved, action)[:3], rotation @ to_world(obs, action)[:3], atol=1e-6)
    f = features(random_frame_obs(rng))
    assert f.shape == (N_FEATURES,) and f.dtype == np.float32
    # batched observations give the rows of the single ones
    batch = np.stack([random_frame_obs(rng) for _ in range(3)])
    np.testing.assert_allclose(features(batch)[1], features(batch[1]), atol=1e-6)


def test_the_policy_frame_points_where_the_told_joint_opens():
    """x is the drawer's axis, or the door's swing direction at the grasp point; the outward direction is
    a feature, not the frame."""
    from spark_bench.rl.generalist import policy_frames

    rng = np.random.default_rng(1)
    obs = random_frame_obs(rng)
    axis, to_axis = obs[OBS.AXIS], obs[OBS.TO_AXIS]
    swing = np.cross(axis, -to_axis) / np.linalg.norm(to_axis)
    frame = policy_frames(obs)
    np.testing.assert_allclose(frame[:, 0], swing, atol=1e-6)
    np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-9)
    np.testing.assert_allclose(features(obs)[15:18], frame.T @ obs[OBS.OUTWARD], atol=1e-5)
    # pulling along x is pulling along the swing, whatever way the handle faces
    np.testing.assert_allclose(to_world(obs, [1.0, 0.0, 0.0, 1.0])[:3], np.clip(swing, -1, 1), atol=1e-6)
    obs[OBS.REVOLUTE] = 0.0  # told prismatic: x is the axis
    np.testing.assert_allclose(policy_frames(obs)[:, 0], axis, atol=1e-6)
    # a closing direction along x (a lid's tab pinched across its thickness) leaves y to the outward one
    obs[OBS.CLOSING] = axis
    frame = policy_frames(obs)
    np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-9)
    outward = obs[OBS.OUTWARD]
    assert abs(frame[:, 1] @ outward) > 0.9 * np.linalg.norm(outward - (outward @ axis) * axis)


def test_frame_actions_round_trip_and_clip():
    obs = random_frame_obs(np.random.default_rng(2))
    action = np.array([0.2, -0.3, 0.1, -0.4])
    np.testing.assert_allclose(to_frame(obs, to_world(obs, action)), action, atol=1e-6)
    big = to_world(obs, np.array([5.0, 5.0, 5.0, 3.0]))
    assert np.all(np.abs(big) <= 1.0) and big[3] == 1.0


def test_features_refuse_the_basic_observation():
    with pytest.raises(ValueError, match="observation='frame'"):
        features(np.zeros(19))
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    with pytest.raises(ValueError, match="observation='frame'"):
        GraspFrameWrapper(env)


def test_memory_counts_steps_at_the_handle_holding_and_stalled():
    obs = np.zeros(FRAME_OBS_SIZE)
    obs[OBS.GRASP_DISTANCE] = 0.005
    memory = Memory()
    memory.reset(obs)
    assert memory.near == 1 and memory.grip == 0 and memory.stall == 1
    obs[OBS.TOUCH] = 0.5
    memory.step(np.array([0.0, 0.0, 0.0, 1.0]), obs)
    memory.step(np.array([0.0, 0.0, 0.0, 1.0]), obs)
    assert memory.near == 3 and memory.grip == 2 and memory.t == 2
    obs[OBS.GRASP_DISTANCE], obs[OBS.TCP_VELOCITY] = 0.2, (0.3, 0.0, 0.0)  # moved away, fast
    memory.step(np.array([1.0, 0.0, 0.0, 1.0]), obs)
    assert memory.near == 0 and memory.stall == 0 and memory.grip == 3
    np.testing.assert_allclose(memory.vector()[-4:], [1.0, 0.0, 0.0, 1.0])


def test_task_mixture_picks_tasks_by_its_seed():
    envs = [GraspFrameWrapper(make_task_env("drawer", f"procedural:{k}", max_episode_steps=5)) for k in range(3)]
    mixture = TaskMixture(envs)

    def picks(seed: int) -> list[int]:
        mixture.reset(seed=seed)
        out = [mixture.current]
        for _ in range(20):
            mixture.reset()
            out.append(mixture.current)
        return out

    assert picks(0) == picks(0) != picks(1)  # the same seed, the same tasks
    assert set(picks(0)) == {0, 1, 2}  # every task comes up
    obs, reward, terminated, truncated, info = mixture.step(np.zeros(4, dtype=np.float32))
    assert obs.shape == (N_FEATURES,) and "is_success" in info


# ----- the shipped weights -------------------------------------------------------------------------------
def test_shipped_record_names_the_run_and_matches_the_weights():
    import hashlib

    from spark_bench.rl.generalist import FEATURE_VERSION, KINDS, weights_path, weights_record

    record = weights_record()
    assert record["feature_version"] == FEATURE_VERSION and record["version"]
    assert set(record["policies"]) == set(KINDS)
    for kind, policy in record["policies"].items():
        path = weights_path(kind)
        assert hashlib.sha256(path.read_bytes()).hexdigest() == policy["sha256"], f"{kind}: stale record"
        assert path.stat().st_size < 1_000_000  # small: it ships in the package
        assert policy["env_steps"]["total"] > 0 and policy["wall_s"] > 0
        assert policy["test"]["tasks"] > 0 and 0.0 <= policy["test"]["success_rate"] <= 1.0
        assert set(record["seeds"]["train"]).isdisjoint(record["seeds"]["test"])
        assert set(record["seeds"]["val"]).isdisjoint(record["seeds"]["test"])


def test_a_record_for_other_features_is_refused(tmp_path):
    from spark_bench.errors import InputError
    from spark_bench.rl.generalist import load_generalist

    with pytest.raises(InputError, match="no generalist policy record"):
        load_generalist("drawer", tmp_path)
    (tmp_path / "generalist.json").write_text('{"feature_version": 0}')
    with pytest.raises(InputError, match="feature version 0"):
        load_generalist("drawer", tmp_path)


def opened(policy, env_id: str, episodes: int = 5) -> int:
    from spark_bench.rl.tasks import run_episode

    env = gym.make(env_id, observation="frame", max_episode_steps=150)
    try:
        return sum(run_episode(env, policy, seed)["success"] for seed in range(episodes))
    finally:
        env.close()


@pytest.mark.parametrize("kind,env_id", [("drawer", "SparkDrawer-v0"), ("door", "SparkDoor-v0")])
def test_the_shipped_policy_is_trained(kind, env_id):
    """The shipped policy opens the default cabinet's drawer / door in at least 4 of 5 seeded episodes;
    the same network with fresh random weights opens it in none."""
    from stable_baselines3 import PPO

    from spark_bench.rl.generalist import load_generalist

    shipped = load_generalist(kind)
    assert opened(GeneralistPolicy(shipped), env_id) >= 4
    untrained = PPO(shipped.policy_class, shipped.env or _env(kind), policy_kwargs=shipped.policy_kwargs,
                    seed=0, device="cpu")
    assert opened(GeneralistPolicy(untrained), env_id) == 0


def _env(kind: str):
    return GraspFrameWrapper(make_task_env(kind, None, max_episode_steps=150))


def test_frame_noise_turns_only_the_grasp_frame_and_stays_consistent():
    from spark_bench.rl.generalist import perturb_frame, random_rotation

    rng = np.random.default_rng(4)
    angles = []
    for _ in range(50):
        rotation = random_rotation(rng, 0.35)
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(rotation) == pytest.approx(1.0)
        angles.append(np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1)))
    assert max(angles) <= 0.35 + 1e-9 and min(angles) < 0.1 < 0.25 < max(angles)
    obs = random_frame_obs(rng).astype(np.float32)
    seen = perturb_frame(obs, rotation)
    grasp_frame = np.r_[OBS.OUTWARD, OBS.CLOSING]  # the entries the noise turns
    np.testing.assert_array_equal(np.delete(seen, grasp_frame), np.delete(obs, grasp_frame))
    np.testing.assert_allclose(seen[OBS.OUTWARD], rotation @ obs[OBS.OUTWARD], atol=1e-6)
    # an action in the turned frame is the same world motion as its counterpart in the true frame
    action = np.array([0.4, 0.1, -0.2, 0.0])
    world = to_world(seen, action)
    np.testing.assert_allclose(to_world(obs, to_frame(obs, world)), world, atol=1e-6)
    # the wrapper draws one turn per episode, from the environment's seed
    env = GraspFrameWrapper(make_task_env("drawer", "procedural:0", max_episode_steps=5), frame_noise=0.35)
    first, _ = env.reset(seed=1)
    turn = env.rotation.copy()
    again, _ = env.reset(seed=1)
    np.testing.assert_array_equal(turn, env.rotation)
    np.testing.assert_array_equal(first, again)
    env.reset(seed=2)
    assert not np.allclose(turn, env.rotation)
