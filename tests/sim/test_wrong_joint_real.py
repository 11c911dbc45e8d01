"""A real door turned the wrong way fails the sim checks; the door as it ships passes (issue #42, conv-9).

The twin is built as ``benchmarks/measure_check_validity.py`` builds it (``benchmarks/broken_twins.py``). Skips
cleanly where ``../shared/real_objects`` is absent.
"""

import pytest
from helpers_real import real_object_path

from benchmarks.broken_twins import axis_reversed, pivot_far_edge
from spark_bench.data import load_object
from spark_bench.sim import run_checks
from spark_bench.sim.options import ConvertOptions

OPTIONS = ConvertOptions(workers=1)


@pytest.mark.slow
@pytest.mark.real
def test_a_real_cabinet_door_reversed_into_its_body_fails_the_sweep_and_the_intact_one_passes(isolated_home):
    cabinet = load_object(real_object_path("45780"))  # StorageFurniture: two doors (link_0, link_1), body link_2
    intact = run_checks(cabinet, OPTIONS)
    assert intact.passed, intact.failures()
    for twin in (axis_reversed(cabinet, "joint_0"), pivot_far_edge(cabinet, "joint_0")):
        report = run_checks(twin.asset, OPTIONS)
        sweep = report.checks["joint_sweep"]
        door = sweep.details["joints"]["joint_0"]
        assert not sweep.passed and "joint_0" in sweep.details["failed"], twin.kind
        assert door["reached"] < 0.5, twin.kind  # it stops as it starts into the body
        assert door["stopped_by"]["cause"] == "contact", twin.kind
        assert "link_0 runs into link_2" in sweep.details["reason"], (twin.kind, sweep.details["reason"])
        assert report.checks["mjcf_compiles"].details["excluded"] == [], twin.kind
