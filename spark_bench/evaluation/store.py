"""The results store: one SQLite file (standard library, WAL), one row per case and method run.

A *run* is identified by ``(bench, label, config_hash)``: the benchmark, the method's display label and
the hash of its configuration. Each run holds one row per ``(case_id, variant)``; ``variant`` is ``""``
for the method's own output and names a side result otherwise (``w/o joint opt.`` for the SPARK prior
before joint optimization). Writing a row replaces any row with the same key, inside one transaction,
so a crashed or repeated write never leaves two results for one case.

Every row carries the ``convention`` (:data:`spark_bench.CONVENTION_VERSION`) its metrics were computed
under; rows of different conventions are never averaged together (:meth:`ResultsStore.done_cases`
re-scores old ones, the leaderboard shows only the current one).

Concurrency: WAL lets readers run beside one writer; writers from several processes wait for each
other (``busy_timeout``) instead of failing. Each :class:`ResultsStore` opens its own connection, so
one may be created per process (never share a connection across a ``fork``).
"""

from __future__ import annotations

import hashlib
import json
import math
import sqlite3
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from spark_bench.convention import CONVENTION_VERSION
from spark_bench.errors import InputError
from spark_bench.jsonio import plain
from spark_bench.metrics.names import METRIC_COLUMNS

SCHEMA_VERSION = 1
STATUSES = ("ok", "failed")

# the headline metrics (METRIC_COLUMNS, spark_bench.metrics.names) are columns of their own; the rest of a
# result lives in the ``metrics`` JSON
_SCHEMA = """
CREATE TABLE IF NOT EXISTS results (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    bench TEXT NOT NULL,
    case_id TEXT NOT NULL,
    category TEXT NOT NULL DEFAULT '',
    method TEXT NOT NULL,
    label TEXT NOT NULL,
    variant TEXT NOT NULL DEFAULT '',
    regime TEXT NOT NULL DEFAULT '',
    config TEXT NOT NULL DEFAULT '{}',
    config_hash TEXT NOT NULL,
    method_version TEXT NOT NULL DEFAULT '',
    package_version TEXT NOT NULL DEFAULT '',
    convention TEXT NOT NULL DEFAULT '',
    status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
    stage TEXT NOT NULL DEFAULT '',
    reason TEXT NOT NULL DEFAULT '',
    shape_metrics_valid INTEGER NOT NULL DEFAULT 1,
    <metric columns>,
    sim_pass INTEGER,
    open_success REAL,
    rl_success REAL,
    metrics TEXT NOT NULL DEFAULT '{}',
    checks TEXT NOT NULL DEFAULT '{}',
    timings TEXT NOT NULL DEFAULT '{}',
    info TEXT NOT NULL DEFAULT '{}',
    prediction_dir TEXT NOT NULL DEFAULT '',
    case_dir TEXT NOT NULL DEFAULT '',
    started_at REAL,
    finished_at REAL,
    UNIQUE (bench, label, config_hash, case_id, variant)
);
CREATE INDEX IF NOT EXISTS results_run ON results (bench, label, config_hash);
CREATE TABLE IF NOT EXISTS store_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
""".replace("<metric columns>", ", ".join(f"{column} REAL" for column in METRIC_COLUMNS.values()))

#: Columns a caller may give to :meth:`ResultsStore.put` (``id`` is assigned by SQLite).
ROW_FIELDS = (
    "bench", "case_id", "category", "method", "label", "variant", "regime", "config", "config_hash",
    "method_version", "package_version", "convention", "status", "stage", "reason", "shape_metrics_valid",
    *METRIC_COLUMNS.values(), "sim_pass", "open_success", "rl_success", "metrics", "checks", "timings",
    "info", "prediction_dir", "case_dir", "started_at", "finished_at",
)
_JSON_FIELDS = ("config", "metrics", "checks", "timings", "info")


def config_hash(config: dict) -> str:
    """A short stable hash of a JSON-serializable configuration (key order does not matter)."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _finite_or_none(value) -> float | None:
    if value is None or isinstance(value, bool):
        return None if value is None else float(value)
    try:
        value = float(value)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _finite(value):
    """Plain JSON data with NaN and infinities replaced by None."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_column(value) -> str:
    """The text of a JSON column: ``value`` made plain (:func:`spark_bench.jsonio.plain`), NaN and
    infinities as None (the stored JSON is strict), keys sorted."""
    return json.dumps(_finite(plain(value)), sort_keys=True)


class ResultsStore:
    """The SQLite results file.

    :param path: the database file (created with its folder when absent)
    :param timeout: seconds a writer waits for another writer's lock before failing
    """

    def __init__(self, path: str | Path, timeout: float = 60.0):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self._conn = sqlite3.connect(str(self.path), timeout=timeout, isolation_level=None)
            self._conn.row_factory = sqlite3.Row
            self._conn.execute(f"PRAGMA busy_timeout = {int(timeout * 1000)}")
            self._conn.execute("PRAGMA journal_mode = WAL")
            self._conn.execute("PRAGMA synchronous = NORMAL")
            with self._transaction():
                for statement in _SCHEMA.split(";"):
                    if statement.strip():
                        self._conn.execute(statement)
                self._conn.execute("INSERT OR IGNORE INTO store_meta VALUES ('schema_version', ?)",
                                   (str(SCHEMA_VERSION),))
        except sqlite3.DatabaseError as exc:
            raise InputError(self.path, f"not a spark-bench results database: {exc}") from None
        version = self._conn.execute("SELECT value FROM store_meta WHERE key='schema_version'").fetchone()
        if version is None or int(version[0]) != SCHEMA_VERSION:
            raise InputError(self.path, f"results schema version {version and version[0]}, "
                                        f"expected {SCHEMA_VERSION}")

    # ----- plumbing ---------------------------------------------------------------------------
    def _transaction(self):
        store = self

        class _Tx:
            def __enter__(self):
                # IMMEDIATE takes the write lock now, so two writers queue instead of deadlocking
                store._conn.execute("BEGIN IMMEDIATE")

            def __exit__(self, exc_type, exc, tb):
                store._conn.execute("COMMIT" if exc_type is None else "ROLLBACK")
                return False

        return _Tx()

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ----- writing ----------------------------------------------------------------------------
    @staticmethod
    def _prepare(row: dict) -> dict:
        unknown = set(row) - set(ROW_FIELDS)
        if unknown:
            raise ValueError(f"unknown result fields {sorted(unknown)}")
        for key in ("bench", "case_id", "method", "label", "config_hash", "status"):
            if not row.get(key) and row.get(key) != 0:
                raise ValueError(f"result row needs {key!r}")
        if row["status"] not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {row['status']!r}")
        out = dict(row)
        out.setdefault("variant", "")
        for key in _JSON_FIELDS:
            out[key] = json_column(out.get(key) or {})
        for column in (*METRIC_COLUMNS.values(), "open_success", "rl_success"):
            out[column] = _finite_or_none(out.get(column))
        if out.get("sim_pass") is not None:
            out["sim_pass"] = int(bool(out["sim_pass"]))
        out["shape_metrics_valid"] = int(bool(out.get("shape_metrics_valid", True)))
        out["reason"] = " ".join(str(out.get("reason") or "").split())[:1000]  # always one line
        return out

    def put(self, rows: dict | Sequence[dict]) -> None:
        """Write result rows in one transaction, each replacing any row with the same key.

        :param rows: one row or several (the rows of one case: its result and its variants), each a
            dict of :data:`ROW_FIELDS`; ``metrics``/``checks``/``timings``/``info``/``config`` as dicts
        """
        rows = [rows] if isinstance(rows, dict) else list(rows)
        prepared = [self._prepare(r) for r in rows]
        with self._transaction():
            for row in prepared:
                columns = ", ".join(row)
                marks = ", ".join("?" for _ in row)
                self._conn.execute(f"INSERT OR REPLACE INTO results ({columns}) VALUES ({marks})",
                                   tuple(row.values()))

    def delete_run(self, bench: str, label: str, config_hash_value: str | None = None) -> int:
        """Delete every row of a run (or of every configuration of ``label``); returns the count."""
        query, args = "DELETE FROM results WHERE bench=? AND label=?", [bench, label]
        if config_hash_value is not None:
            query, args = query + " AND config_hash=?", [*args, config_hash_value]
        with self._transaction():
            return self._conn.execute(query, args).rowcount

    # ----- reading ----------------------------------------------------------------------------
    def done_cases(self, bench: str, label: str, config_hash_value: str,
                   convention: str | None = CONVENTION_VERSION) -> set[str]:
        """Case ids of a run that already have a final result (ok or failed) for the main variant.

        A row scored under another metric convention is not done: a run resumed after the metric
        definitions changed scores those cases again (from the cached generation), and the new rows
        replace the old ones, so a run never averages two conventions.

        :param convention: only rows of this convention count (None: any)
        """
        query = "SELECT case_id FROM results WHERE bench=? AND label=? AND config_hash=? AND variant=''"
        args: list = [bench, label, config_hash_value]
        if convention is not None:
            query, args = query + " AND convention=?", [*args, convention]
        return {r[0] for r in self._conn.execute(query, args)}

    def rows(self, bench: str | None = None, label: str | None = None, status: str | None = None,
             where: Iterable[tuple[str, object]] = ()) -> list[dict]:
        """Result rows as dicts (JSON columns decoded), ordered by bench, label, variant, case.

        :param bench: only this benchmark
        :param label: only this method label
        :param status: only ``ok`` or ``failed`` rows
        :param where: further ``(column, value)`` equality filters
        """
        clauses, args = [], []
        for column, value in [("bench", bench), ("label", label), ("status", status), *where]:
            if value is None:
                continue
            if column not in ROW_FIELDS and column != "id":
                raise ValueError(f"unknown column {column!r}")
            clauses.append(f"{column}=?")
            args.append(value)
        sql = "SELECT * FROM results" + (" WHERE " + " AND ".join(clauses) if clauses else "")
        sql += " ORDER BY bench, label, variant, case_id, config_hash"
        return [self._decode(r) for r in self._conn.execute(sql, args)]

    @staticmethod
    def _decode(row: sqlite3.Row) -> dict:
        out = dict(row)
        for key in _JSON_FIELDS:
            out[key] = json.loads(out[key]) if out[key] else {}
        out["shape_metrics_valid"] = bool(out["shape_metrics_valid"])
        if out["sim_pass"] is not None:
            out["sim_pass"] = bool(out["sim_pass"])
        return out

    def benches(self) -> list[str]:
        """Benchmarks with at least one result."""
        return [r[0] for r in self._conn.execute("SELECT DISTINCT bench FROM results ORDER BY bench")]

    def count(self) -> int:
        return int(self._conn.execute("SELECT COUNT(*) FROM results").fetchone()[0])


def now() -> float:
    """Wall-clock time stamp written into rows (seconds since the epoch)."""
    return time.time()


EXPORT_FORMATS = ("csv", "parquet")


def flat_rows(rows: Sequence[dict]) -> list[dict]:
    """Rows with the JSON columns as JSON text, for flat formats."""
    out = []
    for row in rows:
        flat = {}
        for key, value in row.items():
            flat[key] = json_column(value) if key in _JSON_FIELDS else value
        out.append(flat)
    return out


def export_rows(rows: Sequence[dict], path: str | Path, fmt: str = "csv") -> Path:
    """Write result rows to ``path`` as CSV (standard library) or Parquet (needs ``pyarrow``).

    :param rows: rows from :meth:`ResultsStore.rows`
    :param path: output file
    :param fmt: ``csv`` or ``parquet``
    """
    import csv

    from spark_bench.errors import SparkBenchError

    if fmt not in EXPORT_FORMATS:
        raise SparkBenchError(f"unknown export format {fmt!r}; choose from {', '.join(EXPORT_FORMATS)}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    flat = flat_rows(rows)
    columns = ["id", *ROW_FIELDS]
    if fmt == "csv":
        with path.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(flat)
        return path
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise SparkBenchError("Parquet export needs pyarrow: pip install pyarrow") from None
    table = pa.table({c: [r.get(c) for r in flat] for c in columns})
    pq.write_table(table, path)
    return path
