"""The one reader of a predictions folder, used by ``--method predictions`` and by the SPARK pipeline's
``predictions`` geometry backend: both refuse a case id that would leave the folder."""

from __future__ import annotations

import shutil

import pytest
from helpers_bench import make_tiny_bench

from spark_bench.data.case import Benchmark, BenchmarkCase
from spark_bench.errors import InputError
from spark_bench.methods.base import CaseInput
from spark_bench.methods.predictions import PredictionsFolder, prediction_folder

UNSAFE = ("..", "a/b", ".", "", "a\\b")


def _with_id(case: BenchmarkCase, case_id: str, folder) -> BenchmarkCase:
    """A copy of ``case`` whose case.json says ``case_id``."""
    shutil.copytree(case.folder, folder)
    copy = BenchmarkCase(folder)
    copy.write_record({**case.record, "id": case_id})
    return copy


def test_prediction_folder(tmp_path):
    (tmp_path / "preds" / "cab0").mkdir(parents=True)
    assert prediction_folder(tmp_path / "preds", "cab0") == tmp_path / "preds" / "cab0"
    with pytest.raises(InputError, match="no prediction folder for this case"):
        prediction_folder(tmp_path / "preds", "cab1")
    (tmp_path / "preds" / "a" / "b").mkdir(parents=True)  # exists, and is still refused
    for case_id in UNSAFE:
        with pytest.raises(InputError, match="unsafe case id"):
            prediction_folder(tmp_path / "preds", case_id)


def test_predictions_method_refuses_unsafe_case_ids(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case = Benchmark(bench).case("cab0")
    preds = tmp_path / "preds"
    shutil.copytree(case.gt_dir, preds / "cab0")
    (tmp_path / "secret").mkdir()  # what "../secret" would reach
    method = PredictionsFolder(preds)
    assert method.generate(CaseInput(case, frozenset()), tmp_path / "out").folder == preds / "cab0"
    for k, case_id in enumerate(("..", "a/b", "../secret")):
        unsafe = _with_id(case, case_id, tmp_path / f"copy{k}")
        with pytest.raises(InputError, match="unsafe case id"):
            method.generate(CaseInput(unsafe, frozenset()), tmp_path / "out")


def test_spark_predictions_backend_refuses_unsafe_case_ids(tmp_path):
    pytest.importorskip("torch", reason="the SPARK pipeline is not installed")
    from helpers_toy import write_toy_case

    from spark_bench.methods.ours import SparkConfig, run_ours
    from spark_bench.methods.ours.geometry import predictions_geometry
    from spark_bench.methods.ours.method import ours_case

    preds = tmp_path / "preds"
    (preds / "a" / "b").mkdir(parents=True)
    for case_id in ("..", "a/b"):
        with pytest.raises(InputError, match="unsafe case id"):
            predictions_geometry(preds, case_id)
    # and through the pipeline, from the case's own record
    config = SparkConfig().with_overrides(["geometry.backend=predictions",
                                           f'geometry.predictions_dir="{preds}"', "optimize.enabled=false"])
    for k, case_id in enumerate(("..", "a/b")):
        folder = tmp_path / f"case{k}"
        write_toy_case(folder, case_id=case_id)
        with pytest.raises(InputError, match="unsafe case id"):
            run_ours(ours_case(folder, config), tmp_path / f"out{k}", config)


def test_an_imported_spark_run_says_what_was_read(tmp_path):
    """A case folder written by ``spark-bench import spark`` carries its import record into the row's info."""
    from spark_bench.jsonio import to_json_text

    bench = make_tiny_bench(tmp_path, n=2)
    benchmark = Benchmark(bench)
    preds = tmp_path / "preds"
    for case_id in ("cab0", "cab1"):
        shutil.copytree(benchmark.case(case_id).gt_dir, preds / case_id)
    record = {"format": "spark-bench spark import 1", "run": "/spark/output/cab0_20250101_120000",
              "urdf": "mobility_optimized.urdf", "urdf_kind": "optimized", "alignment": "icp"}
    (preds / "cab0" / "import.json").write_text(to_json_text(record))
    method = PredictionsFolder(preds)
    info = method.generate(CaseInput(benchmark.case("cab0"), frozenset()), tmp_path / "out").info
    assert info == {"source": str(preds / "cab0"), "spark_run": "/spark/output/cab0_20250101_120000",
                    "spark_urdf": "mobility_optimized.urdf", "spark_urdf_kind": "optimized",
                    "spark_alignment": "icp"}
    # a folder from anywhere else says only where it is
    assert method.generate(CaseInput(benchmark.case("cab1"), frozenset()), tmp_path / "out").info == {
        "source": str(preds / "cab1")}
    (preds / "cab1" / "import.json").write_text("{not json")
    with pytest.raises(InputError, match="cab1/import.json: malformed JSON"):
        method.generate(CaseInput(benchmark.case("cab1"), frozenset()), tmp_path / "out")
