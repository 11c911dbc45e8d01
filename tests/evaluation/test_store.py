"""The SQLite results store: keys, replacement, JSON columns, concurrent writers, crashes, export."""

from __future__ import annotations

import csv
import math
import multiprocessing
import os
import signal
import sqlite3
import time

import pytest

from spark_bench import CONVENTION_VERSION
from spark_bench.errors import InputError
from spark_bench.evaluation.store import ResultsStore, config_hash, export_rows


def row(case_id: str, label: str = "m", status: str = "ok", **extra) -> dict:
    base = {"bench": "b", "case_id": case_id, "method": "m", "label": label, "config_hash": "h1",
            "status": status, "metrics": {"cd": 0.5, "matching": [{"gt_joint": "j"}]}, "cd": 0.5, "type_err": 0.25,
            "convention": CONVENTION_VERSION}
    base.update(extra)
    return base


def test_put_replaces_same_key_and_decodes(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put(row("c1"))
        store.put(row("c1", cd=0.1, reason="line one\nline two"))  # same key: replaced, not added
        store.put(row("c1", variant="w/o joint opt.", cd=0.3))
        rows = store.rows()
    assert len(rows) == 2
    main = next(r for r in rows if r["variant"] == "")
    assert main["cd"] == 0.1 and main["reason"] == "line one line two"
    assert main["metrics"]["matching"] == [{"gt_joint": "j"}] and main["shape_metrics_valid"] is True


def test_wal_mode_and_non_finite_values(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put(row("c1", cd=math.nan, metrics={"cd": math.inf}, sim_pass=True, shape_metrics_valid=False))
        r = store.rows()[0]
    assert r["cd"] is None and r["metrics"]["cd"] is None  # strict JSON, never NaN
    assert r["sim_pass"] is True and r["shape_metrics_valid"] is False
    mode = sqlite3.connect(tmp_path / "r.sqlite").execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"


def test_done_cases_are_per_run(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([row("c1"), row("c2", status="failed", reason="boom"), row("c3", config_hash="other"),
                   row("c4", variant="v")])
        assert store.done_cases("b", "m", "h1") == {"c1", "c2"}
        assert store.done_cases("b", "m", "other") == {"c3"}
        assert store.delete_run("b", "m", "h1") == 3
        assert store.count() == 1


def test_rows_of_another_convention_are_not_done(tmp_path):
    """A case scored under an older metric convention is scored again, and its new row replaces the old."""
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([row("c1", convention="spark-bench-conv-1", cd=0.9), row("c2"), row("c3", convention="")])
        assert store.done_cases("b", "m", "h1") == {"c2"}
        assert store.done_cases("b", "m", "h1", convention=None) == {"c1", "c2", "c3"}
        store.put(row("c1", cd=0.2))  # the re-scored case: same key, current convention
        rows = {r["case_id"]: r for r in store.rows()}
        assert len(rows) == 3 and rows["c1"]["convention"] == CONVENTION_VERSION and rows["c1"]["cd"] == 0.2
        assert store.done_cases("b", "m", "h1") == {"c1", "c2"}


def test_bad_rows_and_bad_files(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        with pytest.raises(ValueError, match="unknown result fields"):
            store.put({**row("c1"), "colour": "red"})
        with pytest.raises(ValueError, match="status"):
            store.put(row("c1", status="maybe"))
        with pytest.raises(ValueError, match="needs 'case_id'"):
            store.put(row(""))
        assert store.count() == 0
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    with pytest.raises(InputError, match="junk.sqlite"):
        ResultsStore(junk)


def test_config_hash_ignores_key_order():
    assert config_hash({"a": 1, "b": [1, 2]}) == config_hash({"b": [1, 2], "a": 1})
    assert config_hash({"a": 1}) != config_hash({"a": 2})


def _writer(path, worker: int, n: int) -> None:
    with ResultsStore(path) as store:
        for k in range(n):
            store.put([row(f"w{worker}-{k}"), row(f"w{worker}-{k}", variant="v")])


def test_concurrent_writers_lose_nothing(tmp_path):
    path = tmp_path / "r.sqlite"
    ResultsStore(path).close()
    ctx = multiprocessing.get_context("spawn")
    procs = [ctx.Process(target=_writer, args=(path, w, 25)) for w in range(4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0
    with ResultsStore(path) as store:
        assert store.count() == 4 * 25 * 2


def _slow_writer(path) -> None:
    store = ResultsStore(path)
    store._conn.execute("BEGIN IMMEDIATE")
    store._conn.execute("INSERT INTO results (bench, case_id, method, label, config_hash, status) "
                        "VALUES ('b', 'half', 'm', 'm', 'h1', 'ok')")
    time.sleep(60)  # killed here, mid-transaction


def test_a_writer_killed_mid_transaction_leaves_no_row(tmp_path):
    path = tmp_path / "r.sqlite"
    with ResultsStore(path) as store:
        store.put(row("before"))
    ctx = multiprocessing.get_context("spawn")
    proc = ctx.Process(target=_slow_writer, args=(path,))
    proc.start()
    time.sleep(3.0)
    os.kill(proc.pid, signal.SIGKILL)
    proc.join()
    with ResultsStore(path, timeout=10) as store:
        assert [r["case_id"] for r in store.rows()] == ["before"]
        store.put(row("after"))  # the lock died with the writer
        assert store.count() == 2


def test_export_csv(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([row("c1"), row("c2", cd=0.25)])
        out = export_rows(store.rows(), tmp_path / "out" / "results.csv", "csv")
    lines = list(csv.DictReader(out.open()))
    assert [r["case_id"] for r in lines] == ["c1", "c2"]
    assert float(lines[1]["cd"]) == 0.25 and '"matching"' in lines[0]["metrics"]


def test_export_parquet(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow is not installed (optional: Parquet export)")
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([row("c1"), row("c2", cd=0.25)])
        out = export_rows(store.rows(), tmp_path / "results.parquet", "parquet")
    table = pq.read_table(out)
    assert table.num_rows == 2 and table.column("cd").to_pylist() == [0.5, 0.25]


def test_export_command(tmp_path, capsys, isolated_home):
    from spark_bench.cli import main

    with ResultsStore(isolated_home / "results.sqlite") as store:
        store.put([row("c1"), row("c2", label="other")])
    out = tmp_path / "x.csv"
    assert main(["results", "export", "--format", "csv", "--out", str(out), "--method", "other"]) == 0
    assert [r["label"] for r in csv.DictReader(out.open())] == ["other"]
