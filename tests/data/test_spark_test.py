"""The ``spark-test`` benchmark (the SPARK paper's 42 PartNet-Mobility test ids) prepared from a download that
holds some of them, SPARK's camera, and GAPartNet part classes carried from the source through the metrics
into the leaderboard."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers_assets import tiny_cabinet

from spark_bench.asset.urdf import write_object_folder
from spark_bench.cli import main
from spark_bench.data import load_object
from spark_bench.data.benchmarks import (
    BENCHMARKS,
    SPARK_TEST_IDS,
    benchmark_dir,
    ensure_benchmark,
    prepare_listed,
)
from spark_bench.data.camera import CameraView
from spark_bench.data.case import Benchmark
from spark_bench.data.prepare import PrepareOptions, prepare_benchmark
from spark_bench.errors import SparkBenchError

FAST = ["--image-size", "64", "--resolution", "24"]

#: SPARK's ``datasets/create_testset.py`` SELECT list, as issue #16 quotes it.
ISSUE_LIST = ("100162 100202 100448 100473 101362 102834 103048 103105 12092 12540 8867 8897 100021 100051 10090 "
              "10101 7221 7236 101773 101931 103863 103872 10627 10900 100828 101011 101593 102301 35059 44817 "
              "100550 100825 20411 25913 103477 103482 101323 102632 101377 102155 103518 103521").split()


def write_download(src: Path, ids, annotate: str | None = None) -> Path:
    """Small synthetic objects under PartNet-Mobility ids; ``annotate``: the id whose door link gets a
    GAPartNet ``hinge_door`` annotation."""
    for object_id in ids:
        write_object_folder(tiny_cabinet(), src / object_id)
        if object_id == annotate:
            door = next(j.child for j in tiny_cabinet().movable_joints() if j.type == "revolute")
            (src / object_id / "link_annotation_gapartnet.json").write_text(json.dumps(
                [{"link_name": door, "is_gapart": True, "category": "hinge_door", "bbox": []}]))
    return src


def test_the_list_is_spark_s_select_list():
    assert SPARK_TEST_IDS == tuple(ISSUE_LIST) and len(set(SPARK_TEST_IDS)) == 42
    spec = BENCHMARKS["spark-test"]
    assert spec.is_listed and spec.n_objects == 42
    assert (spec.options.distance, spec.options.fov_deg) == (4.0, 40.0)
    assert (spec.options.azimuth_deg, spec.options.elevation_deg) == (180.0, 0.0)


def test_prepare_the_listed_objects_found(tmp_path, capsys):
    src = write_download(tmp_path / "download", ["7221", "100162", "99999"], annotate="100162")
    out = tmp_path / "spark-test"
    assert main(["data", "prepare", "--src", str(src), "--bench", "spark-test", "--out", str(out), *FAST]) == 0
    text = capsys.readouterr().out
    assert "2 of 42 listed objects found" in text and "2 prepared" in text and "missing (40): 100202 " in text
    bench = Benchmark(out)
    manifest = bench.manifest()
    assert manifest["name"] == "spark-test" and sorted(manifest["cases"]) == ["100162", "7221"]  # 99999 skipped
    assert len(manifest["missing"]) == 40 and "7221" not in manifest["missing"] and manifest["listed"][0] == "100162"
    assert manifest["options"]["azimuth_deg"] == 180.0 and manifest["options"]["image_size"] == 64
    view = CameraView.load(bench.case("7221").camera_path)
    assert view.distance == pytest.approx(4.0) and view.fov_deg == 40.0 and view.width == 64
    assert view.position == pytest.approx([-4.0, 0.0, 0.0], abs=1e-9)  # level, straight at the front (-X)
    assert (view.azimuth_deg, view.elevation_deg) == (180.0, 0.0)
    # the annotated object's ground truth keeps its GAPartNet class; the other has none
    gt = load_object(bench.case("100162").gt_dir)
    assert [link.annotations.get("category") for link in gt.links.values() if link.annotations] == ["hinge_door"]
    assert not any(link.annotations for link in load_object(bench.case("7221").gt_dir).links.values())
    # resuming with the same options keeps the cases; a second run finds them done
    assert main(["data", "prepare", "--src", str(src), "--bench", "spark-test", "--out", str(out), *FAST]) == 0


def test_no_listed_object_or_none_prepared_is_an_error(tmp_path, capsys):
    src = write_download(tmp_path / "download", ["99999"])
    assert main(["data", "prepare", "--src", str(src), "--bench", "spark-test", "--out", str(tmp_path / "b")]) == 2
    assert "none of the 42 objects of spark-test is there" in capsys.readouterr().err
    broken = tmp_path / "broken"
    (broken / "8867").mkdir(parents=True)
    (broken / "8867" / "mobility.urdf").write_text("<robot name='x'><link name='base'>")
    assert main(["data", "prepare", "--src", str(broken), "--bench", "spark-test", "--out", str(tmp_path / "c"),
                 *FAST]) == 1
    out, err = capsys.readouterr()
    assert "failed 8867:" in out and "none of the listed objects of spark-test could be prepared" in err
    # one good object beside the broken one: exit 0, the failure reported
    write_download(broken, ["8897"])
    assert main(["data", "prepare", "--src", str(broken), "--bench", "spark-test", "--out", str(tmp_path / "c"),
                 *FAST]) == 0
    assert "failed 8867:" in capsys.readouterr().out
    assert main(["data", "prepare", "--src", str(broken), "--bench", "synth-v1", "--out", str(tmp_path / "d")]) == 2
    assert main(["data", "prepare", "--src", str(broken)]) == 2  # no --out without a listed --bench


def test_named_benchmark_from_the_cache(tmp_path, isolated_home, caplog):
    with pytest.raises(SparkBenchError, match="spark-bench data prepare --src PARTNET_MOBILITY_DIR --bench spark-test"):
        ensure_benchmark("spark-test")
    src = write_download(tmp_path / "download", ["10090"])
    result = prepare_listed(BENCHMARKS["spark-test"], src, options=PrepareOptions(
        image_size=64, resolution=24, azimuth_deg=180.0, elevation_deg=0.0), progress=False)
    assert result.folder == benchmark_dir("spark-test") and result.prepared == ["10090"]
    with caplog.at_level("WARNING", logger="spark_bench.data.benchmarks"):
        assert ensure_benchmark("spark-test") == benchmark_dir("spark-test")
    # prepared with other options than the spec's (64 px, R=24): used, and said
    assert "prepared with other options" in caplog.text and "--overwrite" in caplog.text
    with pytest.raises(SparkBenchError, match="generated, not listed"):
        prepare_listed(BENCHMARKS["synth-v1"], src)
    with pytest.raises(SparkBenchError, match="azimuth_deg and elevation_deg"):
        PrepareOptions(azimuth_deg=180.0)


@pytest.mark.real
def test_gapartnet_part_classes_reach_the_leaderboard(tmp_path, real_object, isolated_home):
    """45780 (two GAPartNet ``hinge_door``s): prepare, evaluate two methods, break the leaderboard down by class."""
    from spark_bench.evaluation.leaderboard import build_leaderboard, to_markdown
    from spark_bench.evaluation.runner import EvalOptions, run_eval
    from spark_bench.evaluation.store import ResultsStore
    from spark_bench.methods.base import MethodSpec

    bench = tmp_path / "bench"
    prepare_benchmark(real_object("45780"), bench, options=PrepareOptions(image_size=64, resolution=24), progress=False)
    db = tmp_path / "r.sqlite"
    options = EvalOptions(sim=False, n_samples=2000)
    for method in ("oracle", "geometry"):
        run_eval(MethodSpec.create(method), str(bench), options, db=db, workers=0, progress=False)
    with ResultsStore(db) as store:
        rows = store.rows(label="oracle")
        board = build_leaderboard(store)
    stored = rows[0]["metrics"]
    assert stored["gt_part_classes"] == {"joint_0": "hinge_door", "joint_1": "hinge_door"}
    assert [m["gt_part_class"] for m in stored["matching"]] == ["hinge_door", "hinge_door"]
    (table,) = board.part_class_tables()
    assert table.key == "part-hinge_door" and [e.metrics["n_joints"] for e in table.entries] == [2, 2]
    oracle = next(e for e in table.entries if e.label == "oracle")
    assert oracle.metrics["axis_err"] == 0.0 and oracle.metrics["pivot_err"] == pytest.approx(0.0, abs=1e-9)
    assert "## URDF parameter estimation: hinge door" in to_markdown(board, per_part_class=True)
