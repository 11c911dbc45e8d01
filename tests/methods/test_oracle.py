"""The ``oracle`` method: the ground truth itself, copied so that it stands on its own."""

from __future__ import annotations

from helpers_bench import make_tiny_bench

from spark_bench.data import load_object
from spark_bench.data.case import Benchmark
from spark_bench.methods.base import CaseInput
from spark_bench.methods.oracle import Oracle
from spark_bench.metrics import compute_metrics


def test_oracle_copy_stands_on_its_own(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    out = tmp_path / "out"
    out.mkdir()
    case = Benchmark(bench).case("cab0")
    generation = Oracle().generate(CaseInput(case, frozenset(Oracle.inputs)), out)
    assert generation.folder == out
    gt = load_object(case.gt_dir)
    case.gt_dir.rename(tmp_path / "moved")  # the copy must not read the original
    copy = load_object(out)
    assert sorted(j.name for j in copy.movable_joints()) == ["joint_0", "joint_1"]
    metrics = compute_metrics(copy, gt, n_samples=5000)
    # the same files through the same code path with the same seed: exactly zero, not nearly
    assert metrics.rest.cd == 0.0 and metrics.axis_err == 0.0
