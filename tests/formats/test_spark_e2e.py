"""End to end: a fake SPARK run of a benchmark case, imported, then scored by the metrics."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from helpers_fake_spark import write_fake_run

from spark_bench.data.case import Benchmark
from spark_bench.data.readers import load_object
from spark_bench.formats.spark.importer import import_runs
from spark_bench.metrics.evaluate import compute_metrics

N = 20_000  # samples per shape: enough for a stable Chamfer floor, fast on two cores


def _score(pred, gt, align):
    # one worker: the numbers do not depend on the machine's thread count
    return compute_metrics(pred, gt, n_samples=N, n_match_samples=5_000, align=align, workers=1)


@pytest.fixture(scope="module")
def floor(gt):
    return sampling_floor(gt)


def sampling_floor(gt):
    """The scores of the very same surface sampled independently: the ground truth against a copy whose
    every mesh lists its faces in another order (so other points are drawn). A perfect prediction
    sampled independently of the ground truth cannot do better; the size is set by N, not by any error."""
    shuffled = gt.copy()
    rng = np.random.default_rng(0)
    for link in shuffled.links.values():
        for visual in link.visuals:
            visual.mesh = trimesh.Trimesh(visual.mesh.vertices, rng.permutation(visual.mesh.faces), process=False)
    result = _score(shuffled, gt, "none")
    assert result.rest.cd > 0.0 and min(m.part.cd for m in result.matches) > 0.0
    return result


def _assert_near_zero(result, floor, axis_tol, pivot_tol):
    # 1.5x the sampling floor: the prediction's samples differ from the ground truth's as the floor's
    # do, plus the alignment's residual (ICP on 3,000 independent samples) and float32 GLB vertices
    assert result.rest.cd <= 1.5 * floor.rest.cd
    assert result.open.cd <= 1.5 * floor.open.cd
    assert result.rest.fscore[0.1] == 1.0 and result.open.fscore[0.1] == 1.0
    assert not result.missing_joints and not result.extra_joints and len(result.matches) == 2
    for match in result.matches:
        assert match.type_match
        assert match.axis_err < axis_tol
        assert match.pivot_err is None or match.pivot_err < pivot_tol
        floor_part = next(m.part.cd for m in floor.matches if m.gt_joint == match.gt_joint)
        assert match.part.cd <= 1.5 * floor_part


def test_spark_parts_turned_scaled_and_reordered_score_near_zero_with_icp(tmp_path, bench, gt, floor):
    runs, pred = tmp_path / "output", tmp_path / "pred"
    # SPARK's frame (Y up, front +Z), a quarter turn about the up axis, 0.8 x, shifted, parts in another
    # order than the ground truth's (body, door, drawer), SPARK's names (link0.., link0_to_link1)
    write_fake_run(runs, "cab0", gt, yaw_deg=90.0, scale=0.8, offset=(0.3, -0.2, 0.1))
    assert import_runs(runs, bench, pred, cases=["cab0"]).exit_code == 0
    predicted = load_object(pred / "cab0")
    assert set(predicted.joints) == {"base_to_link0", "link0_to_link1", "link0_to_link2"}
    assert {m.pred_joint: m.gt_joint for m in _score(predicted, gt, "icp").matches} == {
        "link0_to_link1": "joint_1", "link0_to_link2": "joint_0"}  # matched by geometry, not by name
    # ICP on 3,000 samples per side leaves a residual turn of ~1e-3 rad and shift of ~1e-3
    _assert_near_zero(_score(predicted, gt, "icp"), floor, axis_tol=0.01, pivot_tol=0.01)
    unaligned = _score(predicted, gt, "none")
    # the quarter turn is real and left to the alignment: the drawer slides sideways without it
    assert unaligned.rest.cd > 3 * floor.rest.cd
    assert max(m.axis_err for m in unaligned.matches) == pytest.approx(math.pi / 2, abs=1e-6)


def test_camera_alignment_needs_no_metrics_alignment(tmp_path, bench, case0, gt, floor):
    camera = case0.read_camera()
    yaw = math.degrees(math.atan2(camera["position"][1], camera["position"][0])) - 180.0
    assert abs(yaw % 30.0) > 1.0  # off the alignment grid: only the camera can undo it exactly
    runs, pred = tmp_path / "output", tmp_path / "pred"
    write_fake_run(runs, "cab0", gt, case=case0, yaw_deg=yaw, scale=1.3)
    assert import_runs(runs, bench, pred, alignment="camera", cases=["cab0"]).exit_code == 0
    # exact up to float32 GLB vertices (~1e-7) and the optimizer's 8 printed decimals
    _assert_near_zero(_score(load_object(pred / "cab0"), gt, "none"), floor, axis_tol=1e-5, pivot_tol=1e-5)


def test_without_the_optimized_urdf_the_pivot_is_sparks_guess(tmp_path, bench, gt):
    runs, pred = tmp_path / "output", tmp_path / "pred"
    run = write_fake_run(runs, "cab0", gt, yaw_deg=90.0)
    (run / "mobility_optimized.urdf").unlink()
    import_runs(runs, bench, pred, cases=["cab0"])
    result = _score(load_object(pred / "cab0"), gt, "icp")
    door = next(m for m in result.matches if m.gt_type == "revolute")
    assert door.pivot_err > 0.1  # generate_urdf.py puts every joint at the origin
    assert Benchmark(bench).case_ids() == ["cab0", "cab1"]


def test_from_the_shell_export_run_import_eval(tmp_path, bench, spark_cli, capsys, isolated_home):
    """The README's steps on a benchmark: export-images -> (SPARK) -> import spark -> eval --align icp; the
    runs turned by odd angles (off the alignment's grid), scaled, parts reordered, SPARK's names."""
    import json

    from spark_bench.evaluation.store import ResultsStore

    image_dir, runs, pred = tmp_path / "SPARK" / "image", tmp_path / "SPARK" / "output", tmp_path / "pred"
    assert spark_cli(["data", "export-images", str(bench), "--out", str(image_dir)]) == 0
    benchmark = Benchmark(bench)
    for image, yaw in zip(sorted(image_dir.glob("*.png")), (-35.0, 137.0)):  # what run.py makes of image/
        case = benchmark.case(image.stem)
        write_fake_run(runs, image.stem, case.load_gt(), case=case, yaw_deg=yaw, scale=0.7)
    assert spark_cli(["import", "spark", "--runs", str(runs), "--bench", str(bench), "--out", str(pred)]) == 0
    capsys.readouterr()
    common = ["--bench", str(bench), "--align", "icp", "--json", "--no-sim", "--n-samples", str(N), "--workers", "0",
              "--no-progress"]
    floor_cd = np.mean([sampling_floor(benchmark.case(c).load_gt()).rest.cd for c in benchmark.case_ids()])
    assert spark_cli(["eval", "--method", "predictions", "--predictions", str(pred), "--label", "spark+optimized",
                      *common]) == 0
    doc = json.loads(capsys.readouterr().out)
    metrics = doc["metrics"]
    assert doc["method"] == "spark+optimized" and doc["n_failed"] == 0 and doc["n_cases"] == 2
    assert metrics["cd"] <= 1.5 * floor_cd and metrics["fscore@0.1"] == 1.0  # (eval --json's cd: at rest)
    assert metrics["type_err"] == 0.0 and metrics["axis_err"] < 0.01 and metrics["pivot_err"] < 0.01
    with ResultsStore(isolated_home / "results.sqlite") as store:
        rows = [r for r in store.rows() if r["info"].get("spark_urdf")]
    assert sorted(r["case_id"] for r in rows) == ["cab0", "cab1"]
    for row in rows:  # each row says which SPARK run, which URDF and which alignment it came from
        assert row["info"]["spark_urdf"] == "mobility_optimized.urdf" and row["info"]["spark_alignment"] == "icp"
        assert row["info"]["spark_run"] == str((runs / f"{row['case_id']}_20250101_120000").resolve())
