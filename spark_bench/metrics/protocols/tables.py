"""The leaderboard "as each paper reports it": one table per protocol, its columns named and ordered as in
that paper's table, with a footnote giving the protocol's source and what differs from spark-bench.

Input: ``{method label: [ProtocolResult dicts, one per case]}`` (``ProtocolResult.to_dict()``, as ``eval``
stores them). Per method the cases are combined as the paper's code combines them (:func:`pooled`): rates
that the paper pools over joints are weighted by each case's joint count (Articulate-Anything,
URDF-Anything); every other number is the mean over the cases that have it.
"""

from __future__ import annotations

import csv
import html
import io
from collections.abc import Mapping, Sequence

from spark_bench.errors import SparkBenchError
from spark_bench.metrics.protocols import protocol_module

FORMATS = ("markdown", "latex", "html", "csv")

#: ``{protocol: {metric: the count that weighs it}}``: rates the paper's code pools over joints.
POOLED_OVER_JOINTS: dict[str, dict[str, str]] = {
    "articulate-anything": {
        "joint_success_rate": "n_joints", "revolute_success_rate": "n_revolute",
        "prismatic_success_rate": "n_prismatic",
        **{f"failure_{r}": "n_joints" for r in ("joint_type", "joint_axis", "joint_origin", "joint_limit",
                                                 "no_valid_result")}},
    "urdf-anything": {key: "num_gt_joints" for key in ("type_correct", "axis_within", "origin_within",
                                                       "joint_success_rate", "missing_rate")},
}


def pooled(protocol: str, results: Sequence[Mapping]) -> dict[str, float | None]:
    """One method's cases combined as the paper's code combines them.

    :param protocol: the protocol's name
    :param results: ``ProtocolResult.to_dict()`` of each case (or their ``metrics`` dicts)
    """
    metrics = [r.get("metrics", r) for r in results]
    weights = POOLED_OVER_JOINTS.get(protocol, {})
    keys = list(dict.fromkeys(k for m in metrics for k in m))
    out: dict[str, float | None] = {}
    for key in keys:
        values = [(m[key], float(m.get(weights[key], 0.0) or 0.0) if key in weights else 1.0)
                  for m in metrics if m.get(key) is not None]
        total = sum(w for _, w in values)
        out[key] = sum(v * w for v, w in values) / total if total > 0 else None
    return out


def _cell(value: float | None) -> str:
    return "–" if value is None else f"{value:.4g}"


def footnote(protocol: str, n_cases: Mapping[str, int]) -> str:
    """The footnote of a protocol's table: the paper, its code, what differs from spark-bench.

    :param protocol: the protocol's name
    :param n_cases: cases per method
    """
    info = protocol_module(protocol).INFO
    counts = ", ".join(f"{label}: {n}" for label, n in n_cases.items())
    return (f"Scored as {info.paper} scores (protocol `{info.name}`; source: {info.source}). "
            f"Differs from spark-bench: {info.differs} Cases per method: {counts}.")


def protocol_rows(results: Mapping[str, Sequence[Mapping]], protocol: str
                  ) -> tuple[list[str], list[list[str]], str]:
    """``(headers, rows, footnote)`` of one protocol's table.

    :param results: ``{method label: [ProtocolResult dicts, one per case]}``
    :param protocol: the protocol's name
    """
    info = protocol_module(protocol).INFO
    headers = ["Method", *(header for _, header in info.columns)]
    rows = []
    for label, cases in results.items():
        wrong = {r.get("protocol") for r in cases if isinstance(r, Mapping) and "protocol" in r} - {protocol}
        if wrong:
            raise SparkBenchError(f"method {label!r}: results of protocol {sorted(wrong)} in the {protocol} table")
        numbers = pooled(protocol, cases)
        rows.append([label, *(_cell(numbers.get(metric)) for metric, _ in info.columns)])
    return headers, rows, footnote(protocol, {label: len(cases) for label, cases in results.items()})


def protocol_table(results: Mapping[str, Sequence[Mapping]], protocol: str, fmt: str = "markdown") -> str:
    """One protocol's leaderboard as text.

    :param results: ``{method label: [ProtocolResult dicts, one per case]}``
    :param protocol: the protocol's name
    :param fmt: one of :data:`FORMATS` (CSV ends with the footnote on a ``#`` line)
    :raises SparkBenchError: an unknown format or protocol
    """
    if fmt not in FORMATS:
        raise SparkBenchError(f"unknown table format {fmt!r}; known: {', '.join(FORMATS)}")
    headers, rows, note = protocol_rows(results, protocol)
    if fmt == "markdown":
        lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in rows]
        return "\n".join(lines) + f"\n\n{note}\n"
    if fmt == "latex":
        def tex(text: str) -> str:
            for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"), ("#", r"\#")):
                text = text.replace(a, b)
            return text

        lines = [r"\begin{tabular}{l" + "r" * (len(headers) - 1) + "}", r"\toprule",
                 " & ".join(tex(h) for h in headers) + r" \\", r"\midrule"]
        lines += [" & ".join(tex(c) for c in row) + r" \\" for row in rows]
        lines += [r"\bottomrule", r"\end{tabular}", "", r"\footnotesize{" + tex(note.replace("`", "")) + "}"]
        return "\n".join(lines) + "\n"
    if fmt == "html":
        head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in rows)
        return (f"<table>\n<thead><tr>{head}</tr></thead>\n<tbody>{body}</tbody>\n</table>\n"
                f"<p><small>{html.escape(note)}</small></p>\n")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(headers)
    writer.writerows(rows)
    return buffer.getvalue() + f"# {note}\n"
