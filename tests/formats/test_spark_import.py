"""``spark-bench import spark`` and ``spark-bench data export-images``: mapping, reports, exit codes."""

from __future__ import annotations

import json

import pytest
from helpers_bench import write_case
from helpers_fake_spark import write_fake_run

from spark_bench.data.case import Benchmark
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.errors import InputError
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.spark.importer import SUMMARY, find_runs, import_runs, match_runs

TAG_DIR = "inference/FT5_G1_0"


@pytest.fixture(scope="module")
def underscored_bench(tmp_path_factory):
    """A benchmark whose case ids contain underscores and prefixes of one another."""
    folder = tmp_path_factory.mktemp("ubench") / "ubench"
    ids = ["cab_1", "cab_1_b"]
    for k, case_id in enumerate(ids):
        write_case(folder, case_id, procedural_cabinet(seed=k))
    Benchmark(folder).write_manifest({"name": "ubench", "cases": ids, "failed": {}})
    return folder


def test_case_ids_with_underscores_and_the_newest_run_wins(tmp_path, underscored_bench):
    bench = Benchmark(underscored_bench)
    gt_a, gt_b = bench.case("cab_1").load_gt(), bench.case("cab_1_b").load_gt()
    runs = tmp_path / "output"
    write_fake_run(runs, "cab_1", gt_a, stamp="20250101_120000")
    newest = write_fake_run(runs, "cab_1", gt_a, stamp="20250102_080000")
    write_fake_run(runs, "cab_1_b", gt_b, stamp="20241231_235959")
    write_fake_run(runs, "cab_2", gt_b, stamp="20250101_120000")  # no such case
    (runs / "notes").mkdir()
    (runs / "log.txt").write_text("x")
    found, other = find_runs(runs)
    assert other == ["log.txt", "notes"]
    chosen, superseded, unknown = match_runs(found, bench.case_ids())
    assert {k: v.path.name for k, v in chosen.items()} == {"cab_1": "cab_1_20250102_080000",
                                                           "cab_1_b": "cab_1_b_20241231_235959"}
    assert [r.path.name for r in superseded] == ["cab_1_20250101_120000"]
    assert [r.path.name for r in unknown] == ["cab_2_20250101_120000"]

    report = import_runs(runs, underscored_bench, tmp_path / "pred")
    assert report.exit_code == 0 and [c.case_id for c in report.imported] == ["cab_1", "cab_1_b"]
    assert read_import_record(tmp_path / "pred" / "cab_1")["run"] == str(newest.resolve())
    summary = json.loads((tmp_path / "pred" / SUMMARY).read_text())
    assert summary["superseded"] == ["cab_1_20250101_120000"] and summary["unknown"] == ["cab_2_20250101_120000"]
    assert summary["not_runs"] == ["log.txt", "notes"] and summary["label"] == "spark+optimized"


def test_failed_stages_are_named_and_skipped_runs_listed(tmp_path, bench):
    benchmark = Benchmark(bench)
    runs = tmp_path / "output"
    # cab0: texturing failed (run.py still exited 0): imported with the cleaned meshes
    write_fake_run(runs, "cab0", benchmark.case("cab0").load_gt(),
                   stages=("structure", "urdf", "part_prompts", "part_images", "inference", "clean", "open_prompt",
                           "open_image"))
    # cab1: PartCrafter left out one GLB and cleaning never ran: skipped
    write_fake_run(runs, "cab1", benchmark.case("cab1").load_gt(),
                   stages=("structure", "urdf", "part_prompts", "part_images", "inference"),
                   delete=(f"{TAG_DIR}/part_01.glb",))
    report = import_runs(runs, bench, tmp_path / "pred")
    assert report.exit_code == 0
    cab0, cab1 = report.cases
    assert (cab0.imported, cab0.failed_stage) == (True, "retexture")
    assert {m["variant"] for m in read_import_record(tmp_path / "pred" / "cab0")["meshes"]} == {"cleaned"}
    assert (cab1.imported, cab1.failed_stage) == (False, "inference")
    assert "no usable mesh for 'part_01.glb'" in cab1.reason and not (tmp_path / "pred" / "cab1").exists()
    lines = "\n".join(report.lines())
    assert "skipped  cab1" in lines and "[failed stage: inference]" in lines


def test_a_case_without_a_run_is_reported_and_a_stale_import_removed(tmp_path, bench):
    benchmark = Benchmark(bench)
    runs = tmp_path / "output"
    write_fake_run(runs, "cab0", benchmark.case("cab0").load_gt(), stamp="20250101_120000")
    write_fake_run(runs, "cab1", benchmark.case("cab1").load_gt(), stamp="20250101_120000")
    assert len(import_runs(runs, bench, tmp_path / "pred").imported) == 2
    # a newer cab1 run whose URDF stage failed, and cab0's runs gone
    write_fake_run(runs, "cab1", benchmark.case("cab1").load_gt(), stamp="20250105_120000", stages=("structure",))
    for old in runs.glob("cab0_*"):
        import shutil
        shutil.rmtree(old)
    report = import_runs(runs, bench, tmp_path / "pred")
    assert report.exit_code == 1
    cab0, cab1 = report.cases
    assert (cab0.reason, cab0.removed_stale) == ("no SPARK run for this case", True)
    assert cab1.failed_stage == "urdf" and cab1.removed_stale and "no SPARK URDF" in cab1.reason
    assert not (tmp_path / "pred" / "cab0").exists() and not (tmp_path / "pred" / "cab1").exists()


def test_bad_arguments_are_input_errors(tmp_path, bench):
    with pytest.raises(InputError, match="SPARK runs folder not found"):
        import_runs(tmp_path / "nowhere", bench, tmp_path / "pred")
    (tmp_path / "output").mkdir()
    with pytest.raises(InputError, match="not a benchmark folder"):
        import_runs(tmp_path / "output", tmp_path, tmp_path / "pred")
    with pytest.raises(InputError, match="no case 'cab9'"):
        import_runs(tmp_path / "output", bench, tmp_path / "pred", cases=["cab9"])


def test_command_exit_codes(tmp_path, bench, spark_cli, capsys):
    runs, pred = tmp_path / "output", tmp_path / "pred"
    runs.mkdir()
    argv = ["import", "spark", "--runs", str(runs), "--bench", str(bench), "--out", str(pred)]
    assert spark_cli(argv) == 1  # nothing to import
    assert "no SPARK run could be imported" in capsys.readouterr().err
    write_fake_run(runs, "cab0", Benchmark(bench).case("cab0").load_gt())
    assert spark_cli(argv) == 0
    out = capsys.readouterr().out
    assert "imported cab0" in out and "skipped  cab1: no SPARK run for this case" in out
    assert f"--method-args predictions={pred},label=spark+optimized --bench {bench} --align icp" in out
    assert spark_cli(argv + ["--json"]) == 0
    assert json.loads(capsys.readouterr().out)["imported"] == 1
    assert spark_cli(["import", "spark", "--runs", str(tmp_path / "nowhere"), "--bench", str(bench),
                      "--out", str(pred)]) == 2
    with pytest.raises(SystemExit) as exit_info:  # argparse: a required flag missing
        spark_cli(["import", "spark", "--runs", str(runs)])
    assert exit_info.value.code == 2


def test_export_images_writes_one_png_per_case(tmp_path, bench, spark_cli, capsys):
    out = tmp_path / "image"
    assert spark_cli(["data", "export-images", str(bench), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["cab0.png", "cab1.png"]
    for case in Benchmark(bench).cases():
        assert (out / f"{case.id}.png").read_bytes() == case.input_image.read_bytes()
    assert spark_cli(["data", "export-images", str(bench), "--out", str(tmp_path / "one"), "--cases", "cab1"]) == 0
    assert [p.name for p in (tmp_path / "one").iterdir()] == ["cab1.png"]
    assert spark_cli(["data", "export-images", str(tmp_path), "--out", str(out)]) == 2


def test_export_images_is_a_data_command():
    from spark_bench import cli
    from spark_bench.data import commands

    args = cli.build_parser().parse_args(["data", "export-images", "B", "--out", "D"])
    assert args.func is commands.run_export_images and args.data_command == "export-images"
