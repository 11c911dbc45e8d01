"""``spark-bench import FORMAT``: the contract every foreign format shares (``DIR/<case id>/`` -> ``PRED/<case
id>/`` in the benchmark frame, with ``import.json``; skips listed with their reasons; exit 0/1/2), and a
shape-only format's articulation metrics shown as n/a.

The format here is a toy made for the test: a case's ground-truth object written at 3x its size, turned
31 degrees about the up axis (as a view-dependent method leaves it) and with its URDF's lengths in
centimetres declared in ``units.json``; ``shape_only`` drops its joints.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers_bench import FAST, make_tiny_bench

from spark_bench.asset.ops import similarity_asset
from spark_bench.asset.urdf import write_object_folder
from spark_bench.cli import main
from spark_bench.data.case import Benchmark
from spark_bench.data.readers import load_object
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject, read_import_record
from spark_bench.formats.runs import import_runs

TURN_DEG = 31.0


def read_toy_run(run_dir: Path) -> ForeignObject:
    """The toy format's reader: ``object/`` (PartNet-Mobility layout) in the units ``units.json`` names."""
    units_file = run_dir / "units.json"
    try:
        units = json.loads(units_file.read_text())["length"]
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(units_file, f"no length unit: {exc}") from None
    if units not in ("m", "cm"):
        raise InputError(units_file, f"unknown length unit {units!r}")
    asset = load_object(run_dir / "object")
    scale = np.eye(4) * (0.01 if units == "cm" else 1.0)
    scale[3, 3] = 1.0
    asset = similarity_asset(asset, scale)
    if (run_dir / "shape_only").exists():  # parts and no joints: each part hangs fixed from the root
        for joint in asset.joints.values():
            joint.type = "fixed"
    return ForeignObject(asset, {"files": ["units.json", "object/mobility.urdf"],
                                 "facts": [f"lengths in {units}"]},
                         articulated=not (run_dir / "shape_only").exists())


def write_toy_run(runs: Path, case, units: str = "cm", shape_only: bool = False) -> Path:
    """A toy run of ``case``: its ground truth turned by TURN_DEG about Z, 3x larger, lengths in ``units``."""
    gt = case.load_gt()
    turn = np.eye(4)
    c, s = math.cos(math.radians(TURN_DEG)), math.sin(math.radians(TURN_DEG))
    turn[:2, :2] = [[c, -s], [s, c]]
    turn[:3, :3] *= 3.0 * (100.0 if units == "cm" else 1.0)
    run = runs / case.id
    write_object_folder(similarity_asset(gt, turn), run / "object")
    (run / "units.json").write_text(json.dumps({"length": units}))
    if shape_only:
        (run / "shape_only").write_text("")
    return run


@pytest.fixture
def bench_of_three(tmp_path):
    """A benchmark of three procedural cabinets (``cab0`` .. ``cab2``), made again for each test."""
    return make_tiny_bench(tmp_path, n=3)


def test_a_run_per_case_is_read_into_the_benchmark_frame_and_skips_are_listed(bench_of_three, tmp_path):
    benchmark = Benchmark(bench_of_three)
    cases = {case.id: case for case in benchmark.cases()}
    runs, out = tmp_path / "runs", tmp_path / "pred"
    write_toy_run(runs, cases["cab0"])
    write_toy_run(runs, cases["cab1"], units="furlong")  # the reader refuses it
    (runs / "stranger").mkdir(parents=True)  # names no case
    (out / "cab1").mkdir(parents=True)
    (out / "cab1" / "import.json").write_text("{}")  # a stale import of a case now skipped
    report = import_runs("toy", runs, bench_of_three, out, reader=read_toy_run)

    assert [c.case_id for c in report.imported] == ["cab0"] and report.exit_code == 0
    skipped = {c.case_id: c for c in report.skipped}
    assert "units.json" in skipped["cab1"].reason and "unknown length unit 'furlong'" in skipped["cab1"].reason
    assert skipped["cab1"].removed_stale and not (out / "cab1").exists()
    assert "no toy run for this case" in skipped["cab2"].reason
    assert report.unknown == ["stranger"]
    summary = json.loads((out / "toy_import.json").read_text())
    assert summary["imported"] == 1 and summary["skipped"] == 2

    # the turn left open is squared away (a quarter turn may remain), the size normalized: the imported
    # object's box is the ground truth's, up to a quarter turn about Z
    imported, gt = load_object(out / "cab0"), cases["cab0"].load_gt()
    extent = np.ptp(imported.bounds(), axis=0)
    gt_extent = np.ptp(gt.bounds(), axis=0)
    assert np.allclose(sorted(extent[:2]), sorted(gt_extent[:2]), atol=2e-3) and abs(extent[2] - gt_extent[2]) < 2e-3
    record = read_import_record(out / "cab0")
    assert record["format"] == "toy" and record["case_id"] == "cab0" and record["articulated"] is True
    assert record["facts"] == ["lengths in cm"] and set(record["frame"]["open"]) == {"yaw", "scale"}
    turned = (record["frame"]["yaw_deg"] + TURN_DEG) % 90.0
    assert min(turned, 90.0 - turned) < 0.5  # the footprint squared: the toy's 31 degrees undone
    assert len(imported.movable_joints()) == len(gt.movable_joints())


def test_the_command_exits_0_1_2(bench_of_three, tmp_path, monkeypatch, capsys):
    from spark_bench import formats

    monkeypatch.setitem(formats.FORMATS, "toy", "test_foreign_import:read_toy_run")
    case = Benchmark(bench_of_three).case("cab0")
    write_toy_run(tmp_path / "runs", case)
    args = ["import", "toy", "--runs", str(tmp_path / "runs"), "--bench", str(bench_of_three),
            "--out", str(tmp_path / "pred")]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "imported cab0" in printed and "spark-bench eval --method predictions" in printed
    assert main([*args[:3], str(tmp_path / "empty"), *args[4:]]) == 2  # no runs folder
    (tmp_path / "none").mkdir()
    assert main([*args[:3], str(tmp_path / "none"), *args[4:]]) == 1  # nothing to import
    assert main([*args, "--cases", "nope"]) == 2


def test_a_shape_only_prediction_has_no_articulation_numbers(bench_of_three, tmp_path, isolated_home):
    """A shape-only format (part meshes, no joints) is scored for shape; its articulation columns are n/a,
    not the errors of a prediction that got every joint wrong."""
    from spark_bench.evaluation.runner import run_eval
    from spark_bench.evaluation.store import ResultsStore
    from spark_bench.methods.base import MethodSpec

    runs, out = tmp_path / "runs", tmp_path / "pred"
    for case in Benchmark(bench_of_three).cases():
        write_toy_run(runs, case, shape_only=True)
    assert len(import_runs("toy", runs, bench_of_three, out, reader=read_toy_run).imported) == 3
    summary = run_eval(MethodSpec.create("predictions", predictions=str(out), label="toy-parts"),
                       str(bench_of_three), FAST, db=tmp_path / "r.sqlite", workers=0,
                       runs_root=tmp_path / "runs_root", progress=False)
    assert summary.n_failed == 0
    assert summary.metrics["axis_err"] is None and summary.metrics["type_err"] is None
    assert summary.metrics["cd"] is not None and summary.metrics["cd"] < 0.05  # the right shape, scaled back
    with ResultsStore(tmp_path / "r.sqlite") as store:
        rows = store.rows(status="ok")
    assert all(r["axis_err"] is None and r["metrics"]["articulation_metrics_valid"] is False for r in rows)
    assert all(r["info"]["articulated"] is False and r["info"]["import_format"] == "toy" for r in rows)
