"""``run_ours`` end to end on a toy case: prior and refined objects, report, and the ablation's gain."""

import json

import pytest

from spark_bench.spark import SparkConfig, run_ours
from spark_bench.spark.toy import write_toy_case


@pytest.mark.slow
def test_run_ours_offline_end_to_end(tmp_path):
    from spark_bench.data import load_object

    case = tmp_path / "case"
    write_toy_case(case)
    # a prior with a wrong door axis and both types flipped (p = 1), pivots 0.1 off
    config = SparkConfig().with_overrides(["prior.noise.p_axis=1.0", "prior.noise.p_type=1.0",
                                           "prior.noise.p_sign=0.0", "prior.noise.sigma_origin=0.1"])
    report = run_ours(case, tmp_path / "out", config)
    # a non-default noise model: the label says the settings changed
    assert report["label"] == config.label()
    assert report["label"].startswith("prior=annotation,geometry=annotation,open=dataset,opt=native,settings=")
    saved = json.loads((tmp_path / "out" / "spark_report.json").read_text())
    assert saved["loss_curve"] == report["loss_curve"] and len(saved["loss_curve"]) > 20
    assert saved["geometry_is_ground_truth"] is True
    before, after = report["diagnostics"]["prior"], report["diagnostics"]["refined"]
    assert before["type_err"] == 1.0 and before["axis_err"] > 0.7
    assert after["type_err"] == 0.0 and after["axis_err"] < 0.035 and after["pivot_err"] < 0.02
    refined = load_object(tmp_path / "out")
    prior = load_object(tmp_path / "out" / "prior")
    assert refined.joints["joint_0"].type == "revolute" and prior.joints["joint_0"].type == "prismatic"
    assert refined.joints["joint_1"].type == "prismatic"
    # the rest geometry is untouched by the refinement
    assert abs(refined.bounds() - prior.bounds()).max() < 1e-6
