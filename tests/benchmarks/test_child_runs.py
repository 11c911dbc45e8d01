"""The many-object benchmarks' runner: a child that fails costs only its own row, which says why, and a stored row
is reused, not measured again."""

from __future__ import annotations

import json

from benchmarks.child_runs import run_in_children, stored_path


def test_a_failing_child_stores_its_error_and_a_stored_row_is_reused(tmp_path):
    store, missing = tmp_path / "store", tmp_path / "no_such_object"
    kept = {"object": "kept", "intact": None, "twins": []}
    store.mkdir()
    stored_path(store, "a set", "kept").write_text(json.dumps(kept))
    lines = []
    rows = run_in_children([("a set", "gone", missing), ("a set", "kept", tmp_path / "never_read")], store,
                           "benchmarks.measure_check_validity", [], home=tmp_path / "home", jobs=2, timeout=600,
                           fresh=False, describe=lambda row: lines.append(row) or "")
    gone = rows["a_set__gone"]
    assert "no_such_object" in gone["error"]  # the child's last line names what it could not read
    assert json.loads(stored_path(store, "a set", "gone").read_text())["error"] == gone["error"]
    assert rows["a_set__kept"]["set"] == "a set" and rows["a_set__kept"]["intact"] is None
    assert len(lines) == 1  # only the child that ran is reported


def test_a_child_past_its_time_is_killed_and_says_so(tmp_path):
    rows = run_in_children([("s", "slow", tmp_path)], tmp_path / "store", "benchmarks.measure_check_validity", [],
                           home=tmp_path / "home", jobs=1, timeout=0.05, fresh=False, describe=lambda row: "")
    assert "timed out" in rows["s__slow"]["error"]
