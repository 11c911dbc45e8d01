"""The sim table made from the declaration of its rates (``spark_bench.metrics.names.RATES``, issue #45): the eval
records each rate's case value where the declaration reads it, and every declared rate is summarized, shown on
the leaderboard with its coverage and written to the CSV, from the declaration alone."""

from __future__ import annotations

import csv
import io

import pytest

from spark_bench import CONVENTION_VERSION
from spark_bench.evaluation.aggregate import run_rate, summarize
from spark_bench.evaluation.board import HEADERS, coverage_text
from spark_bench.evaluation.case_eval import (
    OPEN_CHECK,
    PHYSX_CHECK,
    RL_CHECK,
    SIM_CHECK,
    failed_stage_result,
    rate_columns,
)
from spark_bench.evaluation.leaderboard import build_leaderboard, to_csv, to_markdown
from spark_bench.evaluation.store import ROW_FIELDS, ResultsStore
from spark_bench.metrics.names import RATE_COLUMNS, RATES


def test_the_eval_records_each_rate_where_the_declaration_reads_it():
    assert {h.rate.check for h in RATES} == {SIM_CHECK, PHYSX_CHECK, OPEN_CHECK, RL_CHECK}
    assert set(RATE_COLUMNS) <= set(ROW_FIELDS)
    checks = {SIM_CHECK: {"passed": True}, OPEN_CHECK: {"success_rate": 0.5, "success_rate_maniskill": 0.25}}
    assert rate_columns(checks) == {"sim_pass": True, "open_success": 0.5}  # no RL stage: no rl_success
    assert rate_columns({RL_CHECK: {"success_rate": None, "error": "boom"}}) == {"rl_success": None}
    # a check of the prediction that raised is a fail; an opening score that raised (on the truth) gives none
    assert failed_stage_result(SIM_CHECK, "boom") == {"passed": False, "error": "boom"}
    assert failed_stage_result(PHYSX_CHECK, "boom") == {"passed": False, "error": "boom"}
    assert failed_stage_result(OPEN_CHECK, "boom") == {"success_rate": None, "error": "boom"}
    assert failed_stage_result(RL_CHECK, "boom") == {"success_rate": None, "error": "boom"}


def _row(case_id: str, status: str = "ok", **values) -> dict:
    out = {"bench": "b", "case_id": case_id, "category": "Cab", "method": "A", "label": "A", "variant": "",
           "regime": "image", "config_hash": "h", "status": status, "finished_at": 1.0,
           "convention": CONVENTION_VERSION, "checks": {}}
    out.update(values)
    return out


def _with_value(h, case_id: str, value) -> dict:
    """A row whose only rate value is ``h``'s, where the declaration reads it (and its joints, for a coverage)."""
    row = _row(case_id)
    if h.rate.column:
        row[h.rate.column] = value
    result = {h.rate.result: value, "joints": {"joint_0": {"success": bool(value), "end_effector": "suction"}}}
    row["checks"] = {h.rate.check: result}
    return row


@pytest.mark.parametrize("key", [h.key for h in RATES])
def test_every_declared_rate_is_summarized_shown_and_written(tmp_path, key):
    (h,) = [h for h in RATES if h.key == key]
    value = True if h.rate.kind == "pass" else 0.5
    rows = [_with_value(h, "c1", value), _with_value(h, "c2", value), _row("c3", status="failed")]
    expected = pytest.approx(2 * float(value) / 3)  # a failed case counts as not passed
    assert run_rate(rows, h.rate) == expected
    summary = summarize(rows, sim=True, rl=True, physx=True)
    assert summary[key] == expected
    coverage = h.rate.coverage
    if coverage is not None:
        assert summary[coverage.key] is not None
        assert coverage_text(coverage.key, summary[coverage.key]).startswith("2/")
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put(rows)
        board = build_leaderboard(store, bench="b")
    sim = board.tables()[2]
    assert key in sim.metrics and HEADERS[key] in to_markdown(board)
    if coverage is not None:
        assert coverage.header in sim.count_headers()
        cell = sim.count_cells(board.entries[0])[sim.count_headers().index(coverage.header)]
        assert cell == ("2/3" if coverage.unit == "case" else "2/2 (2 by cup)")
    (line,) = csv.DictReader(io.StringIO(to_csv(board)))
    assert float(line[key]) == expected


def test_the_physx_coverage_reads_in_words():
    assert coverage_text("physx_coverage", {"with_verdict": 48, "cases": 50}) == "48/50 cases with a PhysX verdict"
    assert coverage_text("physx_coverage", None) == "n/a"
    assert coverage_text("open_coverage", None) == "n/a"
