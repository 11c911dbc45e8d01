"""``spark-bench train-generalist``: the recipe of the shipped generalist weights, as a command.

A tiny run (one Box lid per seed set, a few hundred environment steps) writes weights that the generalist
loader reads back, a record naming the command line, and the report with its curve.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from spark_bench.cli import main
from spark_bench.errors import InputError

TINY = ["--kinds", "door", "--categories", "Box", "--train-seeds", "1000", "--val-seeds", "8000",
        "--test-seeds", "9000", "--demo-episodes", "1", "--dagger-rounds", "1", "--ppo-steps", "256",
        "--cup-every", "0", "--no-real"]


def test_help_names_the_recipe_options(capsys):
    with pytest.raises(SystemExit) as done:
        main(["train-generalist", "--help"])
    assert done.value.code == 0
    text = capsys.readouterr().out
    for option in ("--train-seeds", "--val-seeds", "--test-seeds", "--cup-every", "--ppo-steps", "--ppo-minutes",
                   "--real", "--no-real", "--score-only", "--weights", "--results"):
        assert option in text


def test_seed_ranges_and_bad_seeds():
    from spark_bench.rl.generalist_recipe import seed_range

    assert seed_range("1000:1003") == [1000, 1001, 1002]
    assert seed_range("5,7") == [5, 7]
    with pytest.raises(InputError, match="seeds"):
        seed_range("a:b")


def test_recipe_command_names_every_recipe_option():
    import argparse

    from spark_bench.rl.commands import add_commands, recipe_command

    parser = argparse.ArgumentParser()
    add_commands(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["train-generalist", "--ppo-minutes", "3", "--real", "/data/partnet_dev"])
    line = recipe_command(args, args.defaults)
    assert line.startswith("spark-bench train-generalist --kinds drawer door --train-seeds 1000:1012 ")
    assert "--ppo-minutes 3 " in line and "--real /data/partnet_dev" in line
    assert "--weights" not in line and "--score-only" not in line  # defaults and unset flags left out


@pytest.mark.timeout(120)
def test_tiny_run_writes_loadable_weights(tmp_path, isolated_home):
    from stable_baselines3 import PPO

    from spark_bench.rl.generalist import FEATURE_VERSION, N_FEATURES, load_generalist, weights_record

    weights, results = tmp_path / "weights", tmp_path / "results"
    assert main(["train-generalist", *TINY, "--weights", str(weights), "--results", str(results)]) == 0

    record = weights_record(weights)
    assert record["feature_version"] == FEATURE_VERSION
    assert record["produced_by"].startswith("spark-bench train-generalist --kinds door ")
    assert record["seeds"] == {"train": [1000], "val": [8000], "test": [9000]}
    assert record["synth"]["categories"] == ["Box"]
    door = record["policies"]["door"]
    assert set(record["policies"]) == {"door"} and door["real"] is None
    assert door["train_tasks"] >= 1 and door["test"]["tasks"] >= 1
    assert door["env_steps"]["ppo"] >= 256 and door["env_steps"]["dagger"] > 0
    assert [row["stage"] for row in door["curve"]][:2] == ["initial (random weights)", "behaviour cloning"]

    model = load_generalist("door", weights)
    assert isinstance(model, PPO)
    assert model.observation_space.shape == (N_FEATURES,)
    report = (results / "generalist_training.md").read_text()
    assert "spark-bench train-generalist" in report and "| door |" in report
    assert (results / "generalist_curve.png").stat().st_size > 0
    assert json.loads((weights / "generalist.json").read_text())["policies"]["door"]["file"] == "door.zip"
    assert Path(weights / "door.zip").is_file()

    # --score-only: the same weights scored again on their held-out seeds (of the record's categories)
    before = (weights / "door.zip").read_bytes()
    assert main(["train-generalist", "--kinds", "door", "--score-only", "--no-real", "--weights", str(weights),
                 "--results", str(results)]) == 0
    rescored = weights_record(weights)
    assert rescored["scored_by"].startswith("spark-bench train-generalist --kinds door ")
    assert "--score-only" in rescored["scored_by"]
    rows = rescored["policies"]["door"]["test"]["rows"]
    assert rows and all(row["task"].startswith("Box_9000/") for row in rows)
    assert rescored["policies"]["door"]["test"]["tasks"] == door["test"]["tasks"]
    assert (weights / "door.zip").read_bytes() == before  # scoring never rewrites the weights
    assert "measured again with the shipped weights" in (results / "generalist_training.md").read_text()
