"""The SPARK driver against a fake SPARK checkout whose scripts take SPARK's real flags."""

from __future__ import annotations

import json
import sys
import time

import pytest
from helpers_fake_spark import write_fake_checkout, write_fake_run

from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.spark import layout
from spark_bench.formats.spark.importer import import_runs
from spark_bench.methods.ours.run_spark import DriverConfig, SparkDriver

PY = sys.executable


@pytest.fixture
def spark(tmp_path, bench):
    """A fake SPARK checkout with a canned run per case (cab1's PartCrafter loses part_01)."""
    spark_dir = write_fake_checkout(tmp_path / "SPARK")
    benchmark = Benchmark(bench)
    for case_id in benchmark.case_ids():
        case = benchmark.case(case_id)
        delete = ("inference/FT5_G1_0/part_01.glb",) if case_id == "cab1" else ()
        write_fake_run(None, case_id, case.load_gt(), case=case, folder=spark_dir / "canned" / case_id,
                       delete=delete, optimized=False)
    return spark_dir


def _stages(run) -> dict[str, str]:
    return {s.name: s.status for s in run.stages}


def test_every_stage_runs_with_sparks_flags_from_sparks_folder(spark, bench, tmp_path):
    driver = SparkDriver(spark, DriverConfig(python=PY))
    run = driver.run_case("cab0", Benchmark(bench).case("cab0").input_image, stamp="20250301_101010")
    assert run.run_dir == spark / "output" / "cab0_20250301_101010"
    assert _stages(run) == {name: "ok" for name in layout.RUN_PY_STAGES}
    argv = {s.name: s.commands[0].argv for s in run.stages}
    r = str(run.run_dir)
    assert argv["structure"] == [PY, "VLMguidance/generate_json.py", "--input", f"{r}/input.png", "--output",
                                 f"{r}/metadata.json", "--csv", "./VLMguidance/partnet-mobility-data-analysis.csv",
                                 "--seed", "42"]
    assert argv["axes"] == [PY, "VLMguidance/repredict_axis.py", "--input", r, "--image", "input.png", "--single"]
    assert argv["urdf"] == [PY, "VLMguidance/generate_urdf.py", "--input-dir", r, "--single"]
    assert argv["inference"] == [PY, "scripts/inference/part_images.py", "--image_folder", r, "--output_dir",
                                 f"{r}/inference", "--tag", "FT5_G1_0", "--seed", "0", "--num_inference_steps",
                                 "1000", "--guidance_scale", "1", "--render"]
    assert argv["clean"] == [PY, "src/utils/clean_mesh.py", "--in_mesh", f"{r}/inference/FT5_G1_0/part_00.glb",
                             "--out_mesh", f"{r}/inference/FT5_G1_0/part_00_cleaned.glb", "--keep_largest",
                             "--merge_tol", "1e-5", "--target_faces", "200000"]
    assert [len(s.commands) for s in run.stages if s.name in ("part_images", "clean", "align_texture")] == [3, 3, 3]
    assert all(c.returncode == 0 for s in run.stages for c in s.commands)
    record = json.loads((run.run_dir / layout.DRIVER_RECORD).read_text())
    assert record["label"] == "spark" and record["failed_stage"] is None
    report = import_runs(spark / "output", bench, tmp_path / "pred", cases=["cab0"])
    assert [c.case_id for c in report.imported] == ["cab0"]
    imported = read_import_record(tmp_path / "pred" / "cab0")
    assert imported["urdf_kind"] == "vlm" and imported["driver"]["label"] == "spark"
    assert report.label == "spark"


def test_a_missing_glb_fails_its_stage_and_blocks_what_needs_it(spark, bench):
    driver = SparkDriver(spark, DriverConfig(python=PY))
    run = driver.run_case("cab1", Benchmark(bench).case("cab1").input_image)
    stages = _stages(run)
    assert run.failed_stage == "inference"
    assert all(c.returncode == 0 for c in run.stages[5].commands)  # exit 0, as SPARK's scripts do
    assert run.stages[5].missing == ["inference/FT5_G1_0/part_01.glb"]
    assert stages["clean"] == "not_run" and stages["retexture"] == "not_run"
    assert stages["open_image"] == "ok"  # does not need the meshes


def test_skipping_texture_and_adding_the_optimizer(spark, bench, tmp_path):
    config = DriverConfig.with_stages(skip=["texture"], add=["optimize"], python=PY)
    assert config.label() == "spark-texture+optimize"
    assert "retexture" not in config.stages and config.stages[-1] == "optimize"
    runs = SparkDriver(spark, config).run_benchmark(bench, ["cab0"])
    run = runs[0]
    assert _stages(run) == {**{s: "ok" for s in layout.RUN_PY_STAGES if s not in ("retexture", "align_texture")},
                            "optimize": "ok"}
    optimize = run.stages[-1]
    # generate_urdf.py again, pointed at the cleaned meshes, then the optimizer for the one revolute joint
    assert optimize.commands[0].argv[-4:] == ["--mesh-dir", str(run.run_dir / "inference" / "FT5_G1_0"),
                                              "--mesh-pattern", "part_{index:02d}_cleaned.glb"]
    assert optimize.commands[1].argv[1:4] == ["URDFoptimizer/optimize_urdf_joint_v4.py", "--urdf",
                                              str(run.run_dir / "mobility.urdf")]
    assert len(optimize.commands) == 2
    # the fake optimizer, like the real one, fails unless the URDF points at meshes that exist
    assert 'filename="inference/FT5_G1_0/part_01_cleaned.glb"' in (run.run_dir / "mobility.urdf").read_text()
    report = import_runs(spark / "output", bench, tmp_path / "pred", cases=["cab0"])
    record = read_import_record(tmp_path / "pred" / "cab0")
    assert record["urdf"] == "mobility_optimized.urdf"
    assert {m["variant"] for m in record["meshes"]} == {"cleaned"}
    assert report.label == "spark-texture+optimize"


def test_a_stage_that_hangs_is_killed_and_named(spark, bench):
    (spark / "VLMguidance" / "generate_json.py").write_text("import time\ntime.sleep(60)\n")
    driver = SparkDriver(spark, DriverConfig(python=PY, timeout_s=1.0))
    start = time.monotonic()
    run = driver.run_case("cab0", Benchmark(bench).case("cab0").input_image)
    assert time.monotonic() - start < 30
    assert run.failed_stage == "structure" and "timed out" in run.stages[0].reason
    assert all(s.status == "not_run" for s in run.stages[1:] if s.name != "structure")


def test_bad_configurations(tmp_path, spark):
    with pytest.raises(InputError, match="unknown SPARK stage 'paint'"):
        DriverConfig.with_stages(skip=["paint"])
    with pytest.raises(InputError, match="not a SPARK checkout"):
        SparkDriver(tmp_path)
    assert DriverConfig().label() == "spark"
    assert DriverConfig.with_stages(skip=["open"]).label() == "spark-open"
    assert DriverConfig(inference_seed=3).tag == "FT5_G1_3"
    image = tmp_path / "x.png"
    image.write_bytes(b"png")
    for name in ("../x", "a/b", "", ".hidden"):  # a run name is a folder inside the output folder
        with pytest.raises(InputError, match="unsafe run name"):
            SparkDriver(spark, DriverConfig(python=PY)).run_case(name, image)


def test_run_spark_on_one_image(spark, bench, spark_cli, capsys, tmp_path):
    """``run-spark --image``: the command the ``spark`` geometry backend of ``ours`` runs per case."""
    out = tmp_path / "out"
    image = Benchmark(bench).case("cab0").input_image
    argv = ["run-spark", "--spark", str(spark), "--image", str(image), "--name", "cab0", "--output", str(out),
            "--python", PY, "--skip", "texture"]
    assert spark_cli(argv) == 0
    run = next(out.glob("cab0_*"))
    assert f"run folder {run}" in capsys.readouterr().out
    assert (run / "inference" / "FT5_G1_0" / "part_02_cleaned.glb").is_file()
    with pytest.raises(SystemExit):  # --bench or --image, not both
        spark_cli(argv + ["--bench", str(bench)])


def test_run_spark_command(spark, bench, spark_cli, capsys):
    argv = ["run-spark", "--spark", str(spark), "--bench", str(bench), "--python", PY, "--skip", "texture"]
    assert spark_cli(argv + ["--cases", "cab0"]) == 0
    out = capsys.readouterr().out
    assert "cab0: cab0_" in out and ": every stage done" in out and "label spark-texture;" in out
    assert spark_cli(argv) == 1  # cab1's PartCrafter loses a part
    assert "cab1: cab1_" in capsys.readouterr().out
    assert spark_cli(argv + ["--skip", "paint"]) == 2
