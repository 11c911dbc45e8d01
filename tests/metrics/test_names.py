"""The declaration of the benchmark's numbers (issue #45): every sim-table rate says once where its case value is
read, which stage makes it, how it shows and what covers it; the derived tables agree with it."""

from __future__ import annotations

from spark_bench.metrics.names import (
    BY_KEY,
    COVERAGES,
    HEADLINE,
    HEADLINE_KEYS,
    RATE_COLUMNS,
    RATE_KEYS,
    RATE_STAGES,
    RATES,
    SUMMARY_KEYS,
    Rate,
)


def test_every_sim_rate_is_declared_with_its_source_stage_and_coverage():
    assert [h.key for h in RATES] == [h.key for h in HEADLINE if h.table == "sim"]  # every one, in CSV order
    assert all(h.rate is None for h in HEADLINE if h.table != "sim") and all(h.column is None for h in RATES)
    for h in RATES:
        assert h.rate.stage in RATE_STAGES and h.rate.kind in ("pass", "fraction")
        assert h.rate.check and h.rate.result
        assert not (h.summary and h.rate.appended)  # a rate of every summary has its place among the rates
        if h.rate.coverage is not None:
            assert h.rate.coverage.unit in ("joint", "case") and h.rate.coverage.header
            assert bool(h.rate.coverage.what) == (h.rate.coverage.unit == "case")
    assert RATE_COLUMNS == {"sim_pass": "sim_pass_rate", "open_success": "open_success_rate",
                            "rl_success": "rl_success_rate"}  # the results store's columns (store.py)
    assert {key: h.key for key, h in COVERAGES.items()} == {
        "physx_coverage": "sim_pass_rate_physx", "open_coverage": "open_success_rate", "rl_coverage": "rl_success_rate"}
    assert RATE_KEYS == ("sim_pass_rate", "open_success_rate") and SUMMARY_KEYS[-2:] == RATE_KEYS
    assert len(set(HEADLINE_KEYS)) == len(HEADLINE_KEYS)


def test_a_rate_reads_its_column_where_it_has_one_else_its_checks():
    mujoco, physx = BY_KEY["sim_pass_rate"].rate, BY_KEY["sim_pass_rate_physx"].rate
    row = {"sim_pass": True, "checks": {"sim": {"passed": False}, "sim_physx": {"passed": False}}}
    assert mujoco.of_row(row) is True and mujoco.from_checks(row["checks"]) is False
    assert physx.of_row(row) is False
    assert physx.of_row({"checks": {"sim_physx": {"skipped": "no sapien"}}}) is None
    assert physx.of_row({"checks": {}}) is None and physx.of_row({}) is None and physx.from_checks(None) is None
    maniskill = BY_KEY["open_success_rate_maniskill"].rate
    assert maniskill == Rate("sim", "open", "success_rate_maniskill", appended=True)
    assert maniskill.of_row({"checks": {"open": {"success_rate": 1.0, "success_rate_maniskill": 0.5}}}) == 0.5
