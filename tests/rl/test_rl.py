"""Rollouts, the CLI and the training pipeline (the scripted opener: tests/opening/test_opener.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.cli import main


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
