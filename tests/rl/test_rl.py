"""The scripted opener, rollouts, the CLI and the training pipeline."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from helpers_open import opener_observation, opens_with_its_hinge_only

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.cli import main
from spark_bench.envs import observation as OBS
from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint
from spark_bench.opening.opener import rotate_about


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


def test_rollout_cli_prints_json(capsys):
    code = main(["rollout", "--env", "SparkDrawer-v0", "--asset", "procedural:0", "--episodes", "2", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["episodes"] == 2 and out["success_rate"] == 1.0 and out["mean_return"] > 0


def test_rollout_reports_why_the_planner_declines_a_flat_front(tmp_path, capsys):
    """A drawer front with nothing to hold (no handle, knob, notch, tab; too tall to pinch by its edges):
    no episode runs, the JSON is still one object with ``success_rate`` (0) and the one-line ``reason``."""
    from spark_bench.asset import write_object_folder
    from spark_bench.envs.cabinet import procedural_cabinet

    asset = procedural_cabinet(0)
    drawer = asset.links["link_0"]
    drawer.visuals, drawer.collisions = drawer.visuals[:5], drawer.collisions[:5]  # the bar handle removed
    write_object_folder(asset, tmp_path / "flat")
    code = main(["rollout", "--env", "SparkDrawer-v0", "--asset", str(tmp_path / "flat"), "--episodes", "2", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["success_rate"] == 0.0 and out["episodes"] == 0
    assert "no handle" in out["reason"] and "\n" not in out["reason"]
    # the door of the same cabinet keeps its bar: attempted, opened, no reason
    code = main(["rollout", "--env", "SparkDoor-v0", "--asset", str(tmp_path / "flat"), "--episodes", "1", "--json"])
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 0 and out["success_rate"] == 1.0 and "reason" not in out


def test_rollout_cli_rejects_a_missing_joint(capsys):
    code = main(["rollout", "--env", "SparkDoor-v0", "--asset", "procedural:0", "--joint", "joint_9"])
    assert code == 2
    assert "no joint named 'joint_9'" in capsys.readouterr().err


def test_rollout_writes_a_gif_of_the_episode_it_scores(tmp_path):
    """One frame per step at the environment's render size, showing the gripper move; and recording
    the video does not change the episode (rendering reads the physics state, never writes it)."""
    import imageio.v3 as iio

    from spark_bench.rl.rollout import rollout

    path = tmp_path / "drawer.gif"
    stats = rollout("SparkDrawer-v0", asset="procedural:0", episodes=1, video=path, max_episode_steps=20)
    frames = iio.imread(path, index=None)
    assert frames.shape[0] == 20 and frames.shape[1:3] == (360, 480)  # 20 steps, the default 480 x 360
    first, last = frames[0, ..., :3].astype(int), frames[-1, ..., :3].astype(int)
    assert np.mean(np.any(first != last, axis=-1)) > 0.001  # the gripper moved between the first and last frame
    plain = rollout("SparkDrawer-v0", asset="procedural:0", episodes=1, max_episode_steps=20)
    assert stats.successes == plain.successes
    # the same steps with and without a renderer: equal but for float summation, which is the same
    # here; an episode that rendering changed would differ by far more than this
    assert stats.returns == pytest.approx(plain.returns, rel=1e-12)
    assert 0.0 < stats.returns[0] < 20.0  # 20 steps of a reward in [0, 1]


@pytest.mark.slow
def test_train_pipeline_writes_model_curve_and_transfer(tmp_path):
    from spark_bench.rl.rollout import rollout
    from spark_bench.rl.train import train

    out = tmp_path / "ppo"
    # a pipeline check, not a learning check: tiny networks, two PPO updates, short evaluations
    result = train("SparkDrawer-v0", algo="ppo", steps=512, out=out, asset="procedural:0", n_envs=2,
                   eval_every=256, eval_episodes=2, eval_asset="procedural:1", progress_bar=False,
                   hyperparams={"n_steps": 128, "batch_size": 128, "n_epochs": 1,
                                "policy_kwargs": {"net_arch": [16, 16]}})
    assert (out / "model.zip").is_file() and (out / "curve.png").stat().st_size > 1000
    meta = json.loads((out / "train.json").read_text())
    assert meta["algo"] == "ppo" and meta["steps"] >= 512
    assert [row.steps for row in result.curve] == [256, 512]
    assert (out / "curve.csv").read_text().count("\n") == 3  # header and two evaluations
    assert result.transfer["episodes"] == 2 and 0.0 <= result.transfer["success_rate"] <= 1.0
    # the saved model reloads and acts as the trained one did: it replays the transfer evaluation (same
    # object, seeds from 20000, deterministic actions) step for step
    replay = rollout("SparkDrawer-v0", asset="procedural:1", policy=str(out), episodes=2, seed=20_000)
    assert replay.successes == result.transfer["successes"]
    # the same weights (saved as they are) through the same computation in this process: equal but for
    # float summation; a policy acting differently changes a 100-step return by far more than this
    assert replay.returns == pytest.approx(result.transfer["returns"], rel=1e-9)


def test_load_model_names_a_broken_train_json(tmp_path):
    from spark_bench.errors import InputError
    from spark_bench.rl import load_model

    (tmp_path / "model.zip").write_bytes(b"PK")
    (tmp_path / "train.json").write_text('{"algo": ')
    with pytest.raises(InputError, match="malformed JSON") as err:
        load_model(tmp_path)
    assert "train.json" in str(err.value)
    (tmp_path / "train.json").write_text('{"algo": "td3"}')
    with pytest.raises(InputError, match="unknown algorithm 'td3'"):
        load_model(tmp_path / "model.zip")


@pytest.mark.slow
def test_sac_trains_a_few_steps(tmp_path):
    from spark_bench.rl.train import train

    result = train("SparkDoor-v0", algo="sac", steps=150, out=tmp_path / "sac", asset="procedural:0", n_envs=1,
                   eval_every=150, eval_episodes=1, progress_bar=False,
                   hyperparams={"learning_starts": 100, "batch_size": 32, "buffer_size": 1000,
                                "policy_kwargs": {"net_arch": [16, 16]}})
    assert (tmp_path / "sac" / "model.zip").is_file() and result.curve[-1].steps >= 150
    assert (tmp_path / "sac" / "curve.png").stat().st_size > 1000


@pytest.mark.slow
def test_scripted_opener_opens_every_drawer_and_door_of_a_real_object(real_object):
    from spark_bench.opening.judge import open_every_joint

    rows = open_every_joint(str(real_object("41083")))
    assert sorted(r["type"] for r in rows) == ["prismatic", "prismatic", "revolute", "revolute"]
    assert all(r["success_rate"] == 1.0 and "reason" not in r for r in rows), rows  # none the scores leave out


def test_grip_command_spans_the_gripper_travel():
    from spark_bench.opening.planning.gripper import GripperConfig, finger_target, grip_command

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


def test_a_washers_door_whose_rim_tab_the_body_blocks_is_opened_from_its_front(tmp_path):
    """A front-loading washer's handle is a tab on the door's rim, flush with its depth: pinched from beyond
    the rim, the pads would run into the body's front just behind it. The tab gives way to the front's own
    grasps (nothing to pinch there: ``no_handle``, not ``blocked``), and ``auto`` opens the door with the cup
    on its front, with the true hinge, and not with the hinge turned in the door's plane."""
    from spark_bench.data.synth import generate_object
    from spark_bench.opening.planning.grasp import find_grasp, find_grasp_unchecked
    from spark_bench.opening.planning.gripper import GripperConfig
    from spark_bench.opening.planning.rest_meshes import RestMeshes

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
    from spark_bench.opening.planning.drive_check import hand_pull
    from spark_bench.opening.planning.gripper import largest_pull, pinch_hold
    from spark_bench.opening.planning.scene import plan_grasp

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
