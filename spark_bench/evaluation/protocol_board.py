"""The leaderboard "as each paper reports it": the rows ``eval --protocol`` stored, one table per protocol
(:func:`spark_bench.metrics.protocols.tables.protocol_table`: the paper's columns, its way of pooling cases, a
footnote with its source and what differs from spark-bench's convention)."""

from __future__ import annotations

from spark_bench.convention import CONVENTION_VERSION
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.leaderboard import selected_labels
from spark_bench.evaluation.store import ResultsStore
from spark_bench.metrics.protocols import protocol_names
from spark_bench.metrics.protocols.tables import protocol_table

#: ``spark-bench leaderboard --format`` -> the tables' format names.
TABLE_FORMATS = {"md": "markdown", "latex": "latex", "html": "html", "csv": "csv"}


def protocol_results(rows: list[dict], protocol: str) -> tuple[dict[str, list[dict]], dict[str, int]]:
    """``({method label: [ProtocolResult dict per case]}, {method label: cases without a score})`` of one
    protocol over stored rows (the method's own rows: variants and failed cases aside; a case whose protocol
    failed, or that was evaluated without it, is counted as without a score).

    :param rows: result rows of one benchmark
    :param protocol: the protocol's name
    """
    results: dict[str, list[dict]] = {}
    missing: dict[str, int] = {}
    for row in rows:
        if row["variant"] or row["status"] != "ok" or row["convention"] != CONVENTION_VERSION:
            continue
        scored = (row["metrics"].get("protocols") or {}).get(protocol)
        if scored is None or "error" in scored:
            missing[row["label"]] = missing.get(row["label"], 0) + 1
            continue
        results.setdefault(row["label"], []).append(scored)
    return results, missing


def protocol_boards(store: ResultsStore, bench: str, requested: list[str], fmt: str,
                    labels: list[str] | None = None) -> str:
    """Each requested protocol's table of ``bench`` in ``fmt`` (``md``, ``latex``, ``html``, ``csv``), one
    after the other, each with the number of cases it covers and those left out per method.

    :param store: the results store
    :param bench: the benchmark's name
    :param requested: protocol names (``all`` allowed)
    :param fmt: the output format
    :param labels: only these method labels (as ``leaderboard --methods``)
    :raises SparkBenchError: an unknown protocol, or no row of ``bench`` scored under one
    """
    rows = store.rows(bench=bench)
    if labels:
        wanted = selected_labels(labels, {r["label"] for r in rows})
        rows = [r for r in rows if r["label"] in wanted]
    regimes = {r["label"]: r["regime"] for r in rows}
    parts = []
    for name in protocol_names(requested):
        results, missing = protocol_results(rows, name)
        if not results:
            raise SparkBenchError(f"no row of benchmark {bench!r} was scored under protocol {name!r}; run "
                                  f"`spark-bench eval ... --protocol {name}` first")
        coverage = "; ".join(f"{label} (regime: {regimes.get(label) or 'n/a'}): {len(results.get(label, []))} "
                             f"cases scored, {missing.get(label, 0)} without"
                             for label in sorted(set(results) | set(missing)))
        table = protocol_table(results, name, TABLE_FORMATS[fmt])
        if fmt == "md":
            parts.append(f"## {name}\n\n{table}\nCoverage: {coverage}.\n")
        elif fmt == "csv":
            parts.append(f"# protocol: {name}; coverage: {coverage}\n{table}")
        elif fmt == "latex":
            parts.append(f"% protocol: {name}; coverage: {coverage}\n{table}")
        else:
            parts.append(f"<h2>{name}</h2>\n{table}\n<p>Coverage: {coverage}.</p>\n")
    text = "\n".join(parts)
    if fmt == "html":
        return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{bench}: as each paper reports it"
                f"</title></head>\n<body>\n<h1>{bench}: as each paper reports it</h1>\n{text}</body></html>\n")
    return text
