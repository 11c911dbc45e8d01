"""Stored records name an asset by its path and content hash (``train.json``, transfer scores)."""

from __future__ import annotations

import json

from spark_bench.rl.records import asset_content_hash, asset_record


def test_content_hash_follows_the_content_not_the_object(tmp_path):
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data import load_object
    from spark_bench.envs.cabinet import procedural_cabinet

    cabinet = procedural_cabinet(0)
    folder = tmp_path / "cabinet"
    write_object_folder(cabinet, folder)
    a, b = load_object(folder), load_object(folder)
    assert asset_content_hash(a) == asset_content_hash(b)  # two loads of the same files
    record = asset_record(folder)
    assert record == {"path": str(folder.resolve()), "sha256": asset_content_hash(a)}
    b.joints["joint_0"].upper += 0.01  # a longer drawer travel is another asset
    assert asset_content_hash(b) != asset_content_hash(a)
    c = load_object(folder)
    c.links["link_0"].visuals[0].mesh.vertices[0, 0] += 1e-4  # so is a moved vertex
    assert asset_content_hash(c) != asset_content_hash(a)
    # an in-memory asset is named by the file it was read from
    assert asset_record(a)["path"] == str(a.source) and asset_record(a)["sha256"] == record["sha256"]
    assert asset_record("procedural:1")["path"] == "procedural:1"
    assert asset_record("procedural:1")["sha256"] != asset_record("procedural:2")["sha256"]


def test_train_json_names_the_asset_by_path_and_hash(tmp_path):
    from spark_bench.rl.train import train

    out = tmp_path / "ppo"
    train("SparkDrawer-v0", algo="ppo", steps=64, out=out, asset="procedural:0", n_envs=1, eval_every=64,
          eval_episodes=1, eval_asset="procedural:1", progress_bar=False,
          hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1, "policy_kwargs": {"net_arch": [8]}})
    meta = json.loads((out / "train.json").read_text())
    assert meta["asset"] == asset_record("procedural:0")
    assert meta["transfer"]["asset"] == asset_record("procedural:1")
    text = (out / "train.json").read_text()
    assert "ArticulatedAsset(" not in text and len(text) < 5000



def test_generalist_task_rows_name_the_asset_by_path_and_hash(tmp_path):
    """The generalist's record (scores per task) names each object as :func:`asset_record` does."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.envs.cabinet import procedural_cabinet
    from spark_bench.rl.tasks import build_tasks, evaluate_teacher, object_tasks

    folder = tmp_path / "cabinet"
    write_object_folder(procedural_cabinet(3), folder)
    tasks = object_tasks(folder)
    assert tasks
    built, _ = build_tasks(tasks[:2])
    try:
        rows = evaluate_teacher(built[:1])
    finally:
        for b in built:
            b.env.close()
    expected = asset_record(folder)
    assert all(b.asset == expected for b in built)
    assert rows[0]["asset"] == expected and rows[0]["task"] == f"cabinet/{tasks[0].joint}"
    assert rows[0]["part"] == built[0].part == "drawer"  # the procedural cabinet's moving parts are drawers
