"""The opening environments: registration, Gymnasium conformity, determinism, the start state, the sim
conversion's object, errors (the grasp points: tests/manipulation/test_grasp_points.py; the unusual grips carried
out by the scripted opener: tests/opening/test_opener.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.data.case import BenchmarkCase
from spark_bench.envs import observation as OBS
from spark_bench.envs.assets import asset_folder
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.errors import InputError

ENV_IDS = ("SparkDrawer-v0", "SparkDoor-v0")


def test_import_registers_both_environments():
    for env_id in ENV_IDS:
        assert env_id in gym.registry
        assert gym.registry[env_id].max_episode_steps == 100


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_on_procedural_cabinet(env_id):
    env = gym.make(env_id, asset="procedural:0")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (OBS.OBS_SIZE,)
    assert env.action_space.shape == (4,)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_and_step_are_deterministic(env_id):
    env_a, env_b = gym.make(env_id, asset="procedural:1"), gym.make(env_id, asset="procedural:1")
    obs_a, _ = env_a.reset(seed=7)
    obs_b, _ = env_b.reset(seed=7)
    # exact: one code path run twice in one process (MuJoCo steps on one thread); determinism is the claim
    np.testing.assert_array_equal(obs_a, obs_b)
    actions = np.random.default_rng(0).uniform(-1, 1, size=(30, 4)).astype(np.float32)
    for action in actions:
        obs_a, reward_a, *_ = env_a.step(action)
        obs_b, reward_b, *_ = env_b.step(action)
    np.testing.assert_array_equal(obs_a, obs_b)
    assert reward_a == reward_b
    other, _ = env_a.reset(seed=8)
    assert not np.allclose(other[:3], env_b.reset(seed=7)[0][:3])


def test_an_environment_that_never_renders_leaves_the_visuals_out_and_moves_the_same():
    """Visual geoms have no contacts and no mass: without them (no ``render_mode``) the scene compiles
    faster and the same actions give the same motion (to 1e-6: two compiled models, one code path)."""
    plain = gym.make("SparkDrawer-v0", asset="procedural:0")
    rendered = gym.make("SparkDrawer-v0", asset="procedural:0", render_mode="rgb_array")
    names = [plain.unwrapped.model.geom(i).name for i in range(plain.unwrapped.model.ngeom)]
    assert "link_0_collision_0" in names and not any(n.endswith("_visual") for n in names)
    obs_a, _ = plain.reset(seed=3)
    obs_b, _ = rendered.reset(seed=3)
    for action in np.random.default_rng(1).uniform(-1, 1, size=(40, 4)).astype(np.float32):
        obs_a, *_ = plain.step(action)
        obs_b, *_ = rendered.step(action)
    np.testing.assert_allclose(obs_a, obs_b, atol=1e-6)
    assert not np.allclose(obs_a[:3], plain.reset(seed=3)[0][:3])  # the actions moved the gripper


def test_object_comes_from_the_sim_conversion():
    """The object's geoms are spark_bench.sim's (named collision hulls in class ``collision``), and the
    gripper's pads collide with them (contype 2 & conaffinity 1) but not with each other."""
    env = gym.make("SparkDrawer-v0", asset="procedural:0", render_mode="rgb_array")
    model = env.unwrapped.model
    names = [model.geom(i).name for i in range(model.ngeom)]
    assert "link_0_collision_0" in names and "link_0_visual" in names
    hull, pad = model.geom("link_0_collision_0"), model.geom("spark_gripper_pad_left")
    assert (hull.contype & pad.conaffinity) or (pad.contype & hull.conaffinity)
    other = model.geom("spark_gripper_pad_right")
    assert not (pad.contype & other.conaffinity) and not (other.contype & pad.conaffinity)
    assert model.geom("link_0_visual").contype == 0


def test_start_state_is_in_front_of_the_handle():
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    obs, info = env.reset(seed=0)
    tcp, grasp = obs[OBS.TCP], obs[OBS.GRASP]
    # the cabinet's front faces -X: the gripper starts ~0.1 m in front of (smaller x than) the handle
    assert 0.06 < grasp[0] - tcp[0] < 0.14
    assert obs[OBS.JOINT_FRACTION] == pytest.approx(0.0, abs=1e-9)
    assert obs[OBS.FINGERS] == pytest.approx(1.0, abs=1e-6)
    assert not info["is_success"] and 0.0 < info["reach"] < 1.0


@pytest.mark.parametrize("asset", ["procedural:0", "in memory"])
def test_an_environment_given_a_grasp_plan_compiles_its_scene_for_it(asset):
    """``grasp=`` (the opening score's judge plans each joint's grasp once and hands it on): the scene takes
    that plan rather than planning its own, for an asset in memory and for one given by name (whose scenes
    are otherwise cached and shared: this one is not)."""
    from spark_bench.manipulation.scene import plan_grasp

    loaded = procedural_cabinet(0)
    planned = plan_grasp(loaded, "joint_0")
    given = gym.make("SparkDrawer-v0", asset=loaded if asset == "in memory" else asset, grasp=planned)
    own = gym.make("SparkDrawer-v0", asset=asset if asset != "in memory" else procedural_cabinet(0))
    assert given.unwrapped.scene.grasp is planned and own.unwrapped.scene.grasp is not planned
    np.testing.assert_array_equal(given.unwrapped.scene.grasp.point, own.unwrapped.scene.grasp.point)
    np.testing.assert_array_equal(given.reset(seed=0)[0], own.reset(seed=0)[0])
    given.close()
    own.close()


def test_unknown_joint_and_wrong_kind_fail_at_make():
    with pytest.raises(InputError, match="no joint named 'nope'"):
        gym.make("SparkDrawer-v0", asset="procedural:0", joint="nope")
    with pytest.raises(InputError, match="is revolute, this task needs a prismatic joint"):
        gym.make("SparkDrawer-v0", asset="procedural:0", joint="joint_1")
    doorless = procedural_cabinet(0)
    del doorless.joints["joint_1"], doorless.links["link_1"]
    with pytest.raises(InputError, match="no revolute joint"):
        gym.make("SparkDoor-v0", asset=doorless)


def test_case_folder_maps_to_its_ground_truth(tmp_path):
    case = BenchmarkCase(tmp_path)
    case.write_record({"id": "c0"})
    with pytest.raises(InputError, match=f"no {case.gt_dir.name}/"):
        asset_folder(tmp_path)
    case.gt_dir.mkdir()
    assert asset_folder(tmp_path) == case.gt_dir
    assert asset_folder(case.gt_dir) == case.gt_dir  # the ground truth's own folder is an object folder
    with pytest.raises(InputError, match="no such"):
        asset_folder(tmp_path / "absent")


def test_default_cabinet_is_generated_once_per_generator_version(tmp_path, monkeypatch):
    from spark_bench.data import load_object
    from spark_bench.data.synth import GENERATOR_VERSION
    from spark_bench.envs import assets

    monkeypatch.setenv("SPARK_BENCH_HOME", str(tmp_path))
    folder = assets.default_asset_path()
    assert folder.parent == tmp_path / "envs" and assets.has_kinds(load_object(folder, load_meshes=False))
    marker = tmp_path / "envs" / f"default_cabinet_v{GENERATOR_VERSION}.txt"
    assert marker.read_text() == folder.name
    (folder / "mobility.urdf").write_text("<robot/>")  # a cache hit does not regenerate
    assert assets.default_asset_path() == folder and (folder / "mobility.urdf").read_text() == "<robot/>"
    monkeypatch.setattr(assets, "_synth_generator", lambda: (lambda *a: pytest.fail("regenerated"), "0.0-other"))
    with pytest.raises(pytest.fail.Exception, match="regenerated"):  # another generator version: generated anew
        assets.default_asset_path()


def test_sparse_reward_and_rgb_render():
    env = gym.make("SparkDoor-v0", asset="procedural:0", reward_type="sparse", render_mode="rgb_array",
                   width=160, height=120)
    env.reset(seed=0)
    _, reward, *_ = env.step(env.action_space.sample())
    assert reward == 0.0
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8 and frame.std() > 5
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("object_id,env_ids", [("41083", ENV_IDS), ("45780", ("SparkDoor-v0",))])
def test_check_env_on_real_objects(real_object, object_id, env_ids):
    """Gymnasium-conformant on real objects, and a sound start: the gripper in front of the grasp point
    (:data:`START_OFFSET` along the part's outward direction, give or take the start noise), the joint
    shut, and an idle gripper leaves the object at rest (nothing pushed, nothing falling open)."""
    from spark_bench.envs.base import START_NOISE, START_OFFSET

    folder = real_object(object_id)
    for env_id in env_ids:
        env = gym.make(env_id, asset=str(folder))
        check_env(env.unwrapped, skip_render_check=True)
        obs, info = env.reset(seed=0)
        tcp, grasp = obs[OBS.TCP].astype(float), obs[OBS.GRASP].astype(float)
        outward = env.unwrapped.scene.grasp.outward
        noise = np.sqrt(3.0) * START_NOISE  # the start's uniform noise, at most this far from its centre
        assert START_OFFSET - noise < (tcp - grasp) @ outward < START_OFFSET + noise, env_id
        assert obs[OBS.JOINT_FRACTION] == pytest.approx(0.0, abs=1e-9) and not info["is_success"]
        for _ in range(20):  # hold still (an action of zero keeps the TCP's target where the TCP is)
            obs, _, terminated, _, info = env.step(np.zeros(4, dtype=np.float32))
        assert not terminated and np.all(np.isfinite(obs))
        assert abs(env.unwrapped.joint_fraction) < 1e-3, (env_id, env.unwrapped.joint_fraction)
        assert np.linalg.norm(obs[OBS.GRASP] - grasp) < 1e-3  # the grasp point (on the part) has not moved
        env.close()
