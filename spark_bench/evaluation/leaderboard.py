"""The leaderboard: the paper's tables from the results store, as Markdown, LaTeX, HTML or CSV.

Three tables, one row per method label, variant and input regime (the latest run of each):

1. shape (paper Table 1): CD, F-Score@0.1, F-Score@0.5;
2. articulation (paper Table 2): AxisErr, PivotErr, TypeErr;
3. sim-readiness: sim pass rate, scripted-opening success (and, when measured, the RL transfer score,
   fine-tuned and zero-shot, beside it; the oracle's row is the policy's ceiling). Where some run checked its
   predictions in PhysX too (``eval --engine physx|all``), the PhysX sim pass beside MuJoCo's, with how many
   cases have a PhysX verdict (the LaTeX caption says it).

Only rows of the current metric convention (:data:`spark_bench.CONVENTION_VERSION`) are shown; the note
under the tables counts the rows of older conventions left out. The articulation errors are per object
(mean over its joints, then over objects), and the note says so. With ``per_part_class`` the articulation
errors are also broken down by GAPartNet part class (hinge door, slider drawer, hinge lid, ...), over the
joints of that class, for ground truths with GAPartNet annotations.

Best and second best of each column are marked (LaTeX: ``\\cellcolor{Palette5}`` and
``\\cellcolor{Palette4}`` as in the paper; Markdown: bold and italics). Reference rows (the oracle,
regime ``ground truth``) are shown but never ranked. Shape metrics of a method whose geometry is the
ground truth's are ``n/a``, never zeros. The HTML page adds bar charts and, per case, the input image
and renders of the ground truth and each method's prediction, at rest and open.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from spark_bench.convention import CONVENTION_VERSION
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.aggregate import summarize
from spark_bench.evaluation.board import (
    HEADERS,
    LATEX_HEADERS,
    PALETTE,
    PART_CLASS_NOTE,
    Entry,
    Leaderboard,
    Table,
    fmt_case_coverage,
    fmt_value,
    is_number,
    mark_version_mismatches,
    unpinned_kernels_note,
)
from spark_bench.evaluation.store import ResultsStore
from spark_bench.metrics.names import BY_KEY, HEADLINE, RATES, Headline

FORMATS = ("md", "latex", "html", "csv")


# ----- building -----------------------------------------------------------------------------------
def _entries(rows: list[dict]) -> list[Entry]:
    runs: dict[tuple[str, str, str], list[dict]] = {}
    for row in rows:
        runs.setdefault((row["label"], row["variant"], row["config_hash"]), []).append(row)
    latest: dict[tuple[str, str], tuple[float, str]] = {}
    for (label, variant, chash), run_rows in runs.items():
        stamp = max(r["finished_at"] or 0.0 for r in run_rows)
        if (label, variant) not in latest or stamp > latest[(label, variant)][0]:
            latest[(label, variant)] = (stamp, chash)
    out = []
    for (label, variant), (_, chash) in latest.items():
        run_rows = runs[(label, variant, chash)]
        first = run_rows[0]
        # a rate whose stage never ran in this run is None (n/a) on its own
        metrics = summarize(run_rows, sim=True, extra=("cd_open",), rl=True, physx=True)
        out.append(Entry(label, variant, first["regime"], first["method"], first["method_version"], chash,
                         len(run_rows), sum(r["status"] == "failed" for r in run_rows), metrics, run_rows))
    # references first, then by label; a variant right after its method
    out.sort(key=lambda e: (e.ranked, e.label, e.variant))
    return out


def selected_labels(selectors: list[str], stored: set[str]) -> set[str]:
    """The labels ``--methods`` names: each selector is a stored label (labels such as ``ours (prior=...,
    opt=spark)`` contain commas), else a comma-separated list of stored labels.

    :param selectors: the ``--methods`` values
    :param stored: the labels of the benchmark's rows
    :raises SparkBenchError: a name that is not a stored label, with the labels there are
    """
    out: set[str] = set()
    for selector in selectors:
        names = [selector] if selector in stored else [n.strip() for n in selector.split(",") if n.strip()]
        unknown = [n for n in names if n not in stored]
        if unknown:
            raise SparkBenchError(f"no results labelled {unknown[0]!r}; the labels are: "
                                  + "; ".join(sorted(stored)))
        out.update(names)
    return out


def default_bench(store: ResultsStore) -> str:
    """The benchmark a leaderboard shows when none is named: the only one in the store, else ``synth-v1``.

    :param store: the results store
    :raises SparkBenchError: an empty store, or several benchmarks and none of them ``synth-v1``
    """
    benches = store.benches()
    if not benches:
        raise SparkBenchError(f"no results in {store.path}; run `spark-bench eval` first")
    if len(benches) == 1:
        return benches[0]
    if "synth-v1" in benches:
        return "synth-v1"
    raise SparkBenchError(f"results for several benchmarks ({', '.join(benches)}): choose one with --bench")


def build_leaderboard(store: ResultsStore, bench: str | None = None, labels: list[str] | None = None
                      ) -> Leaderboard:
    """The leaderboard of one benchmark from the store.

    :param store: the results store
    :param bench: the benchmark (default: the only one in the store, else ``synth-v1``)
    :param labels: only these method labels: each entry a stored label, or labels joined by commas (a label
        that itself contains commas is taken whole)
    :raises SparkBenchError: a label that no row of the benchmark has
    """
    bench = bench or default_bench(store)
    rows = store.rows(bench=bench)
    if labels:
        wanted = selected_labels(labels, {r["label"] for r in rows})
        rows = [r for r in rows if r["label"] in wanted]
    if not rows:
        raise SparkBenchError(f"no results for benchmark {bench!r} in {store.path}")
    left_out: dict[str, int] = {}
    for row in rows:
        if row["convention"] != CONVENTION_VERSION:
            left_out[row["convention"]] = left_out.get(row["convention"], 0) + 1
    rows = [r for r in rows if r["convention"] == CONVENTION_VERSION]
    if not rows:
        found = ", ".join(f"{c or 'no convention'} ({n} rows)" for c, n in sorted(left_out.items()))
        raise SparkBenchError(f"no results for benchmark {bench!r} under the current metric definitions "
                              f"({CONVENTION_VERSION}) in {store.path}, only under {found}; re-run "
                              "`spark-bench eval` to score them again (generations are cached)")
    categories: dict[str, list[Entry]] = {}
    for category in sorted({r["category"] for r in rows if r["category"]}):
        categories[category] = _entries([r for r in rows if r["category"] == category])
        mark_version_mismatches(categories[category])
    entries = _entries(rows)
    note = mark_version_mismatches(entries)
    entries.sort(key=lambda e: (e.ranked, e.label, e.variant))
    return Leaderboard(bench, entries, categories, CONVENTION_VERSION, left_out, note, unpinned_kernels_note(entries))


# ----- text formats ---------------------------------------------------------------------------------
def _md_table(table: Table) -> str:
    ranks = table.ranks()
    head = ["Method", "Regime", *[HEADERS[m] for m in table.metrics], *table.count_headers()]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i, e in enumerate(table.entries):
        cells = []
        for m in table.metrics:
            text = fmt_value(e.metrics.get(m))
            rank = ranks.get((i, m))
            cells.append(f"**{text}**" if rank == 1 else f"_{text}_" if rank == 2 else text)
        lines.append("| " + " | ".join([e.name.replace("|", "\\|"), e.regime, *cells,
                                        *table.count_cells(e)]) + " |")
    return "\n".join(lines)


def _part_class_tables(board: Leaderboard) -> list[Table]:
    tables = board.part_class_tables()
    if not tables:
        raise SparkBenchError(f"no GAPartNet part classes in the results of {board.bench!r}: its ground truths "
                              "carry no GAPartNet annotations (link_annotation_gapartnet.json in the source "
                              "object folders, prepared under the current metric convention)")
    return tables


def to_markdown(board: Leaderboard, per_category: bool = False, per_part_class: bool = False) -> str:
    """Markdown tables (best in bold, second best in italics).

    :param per_category: add per-category tables
    :param per_part_class: add one articulation table per GAPartNet part class
    """
    parts = [f"# spark-bench leaderboard: {board.bench}", ""]
    for table in board.tables():
        parts += [f"## {table.title}", "", _md_table(table), ""]
    if per_category:
        for category, entries in board.categories.items():
            parts += [f"## {category}", ""]
            for table in board.tables(entries):
                parts += [f"### {table.title}", "", _md_table(table), ""]
    if per_part_class:
        for table in _part_class_tables(board):
            parts += [f"## {table.title}", "", _md_table(table), ""]
        parts += [PART_CLASS_NOTE, ""]
    parts.append(" ".join(["Best **bold**, second best _italics_ (reference rows with regime `ground truth` are "
                           "not ranked). n/a: not measured or not meaningful (geometry taken from the ground "
                           "truth).", *board.notes()]))
    return "\n".join(parts) + "\n"


_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                  "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}


def latex_escape(text: str) -> str:
    return "".join(_LATEX_SPECIAL.get(c, c) for c in text)


def _latex_table(table: Table, caption: str, label: str) -> str:
    ranks = table.ranks()
    cols = "p{1.6in}l" + "c" * len(table.metrics)
    lines = [r"\begin{table}[t]", r"\centering", rf"\caption{{{latex_escape(caption)}}}", rf"\label{{{label}}}",
             r"\small{", rf"\begin{{tabular}}{{{cols}}}", r"\hline",
             r"\textbf{Methods} & Regime & " + " & ".join(LATEX_HEADERS[m] for m in table.metrics) + r" \\",
             r"\hline"]
    for i, e in enumerate(table.entries):
        cells = []
        for m in table.metrics:
            text = fmt_value(e.metrics.get(m))
            rank = ranks.get((i, m))
            cells.append(rf"\cellcolor{{Palette5}}{{{text}}}" if rank == 1 else
                         rf"\cellcolor{{Palette4}}{{{text}}}" if rank == 2 else text)
        lines.append(f"{latex_escape(e.name)} & {latex_escape(e.regime)} & " + " & ".join(cells) + r" \\")
    lines += [r"\hline", r"\end{tabular}", "}", r"\end{table}"]
    return "\n".join(lines)


def _coverage_caption(table: Table) -> str:
    """The coverage in cases of a table's rates (the PhysX sim pass's), for its LaTeX caption (the LaTeX tables have
    no count columns): `` Sim pass (PhysX) over the cases with a PhysX verdict: A 48/50, B 50/50.``; empty where the
    table has no such rate."""
    out = ""
    for key in table.metrics:
        declared = BY_KEY[key].rate.coverage if BY_KEY[key].rate else None
        if declared is not None and declared.unit == "case":
            covered = ", ".join(f"{e.name} {fmt_case_coverage(e.metrics.get(declared.key))}" for e in table.entries)
            out += f" {BY_KEY[key].label} over the cases with {declared.what}: {covered}."
    return out


def to_latex(board: Leaderboard, per_category: bool = False, per_part_class: bool = False) -> str:
    """LaTeX tables in the paper's style (needs ``\\usepackage[table]{xcolor}`` and the palette below);
    the notes as comments at the end."""
    parts = ["% spark-bench leaderboard: " + board.bench,
             r"% needs \usepackage[table]{xcolor} and the paper's colours:",
             *[rf"\providecolor{{{name}}}{{RGB}}{{{r},{g},{b}}}" for name, (r, g, b) in PALETTE.items()], ""]
    for table in board.tables():
        parts += [_latex_table(table, f"{table.title} on {board.bench}.{_coverage_caption(table)}",
                               f"tab:{table.key}"), ""]
    if per_category:
        for category, entries in board.categories.items():
            for table in board.tables(entries):
                parts += [_latex_table(table, f"{table.title}: {category}.{_coverage_caption(table)}",
                                       f"tab:{table.key}-{category.lower()}"), ""]
    if per_part_class:
        for table in _part_class_tables(board):
            parts += [_latex_table(table, f"{table.title} on {board.bench} (mean over joints).",
                                   f"tab:{table.key}"), ""]
    parts += [f"% {note}" for note in board.notes()]
    return "\n".join(parts)


#: The CSV columns of the scale ``--align icp`` applied (n/a for a run scored without alignment).
SCALE_COLUMNS = ("alignment_scale_median", "alignment_scale_min", "alignment_scale_max")
#: The CSV columns of a rate's coverage, by its unit: ``(column suffix, key of the coverage)`` (the columns of
#: ``open_coverage``: ``open_coverage_scored``, ``open_coverage_total``).
COVERAGE_COLUMNS = {"joint": (("scored", "joints_scored"), ("total", "joints_total")),
                    "case": (("with_verdict", "with_verdict"), ("cases", "cases"))}


def csv_rates(board: Leaderboard) -> list[str]:
    """The rates the board's CSV writes, in :data:`~spark_bench.metrics.names.HEADLINE` order: every one
    listed in every summary or appended (n/a where not measured), the others where some entry has them
    (:meth:`Leaderboard.rates`: a board of runs without PhysX has no PhysX columns)."""
    shown = set(board.rates())
    return [h.key for h in RATES if _written_always(h) or h.key in shown]


def _written_always(h: Headline) -> bool:
    return h.summary or h.rate.appended


def to_csv(board: Leaderboard, per_category: bool = False, per_part_class: bool = False) -> str:
    """One CSV line per entry (and per category and entry with ``per_category``); every metric. With
    ``per_part_class`` two more columns, ``part_class`` and ``n_joints``, and one more line per GAPartNet part
    class and entry (its articulation errors over the joints of that class; the other metrics n/a). The rates of
    :func:`csv_rates`, then their coverages (:data:`COVERAGE_COLUMNS`): those of the rates written always first,
    then those of the others (a board without PhysX: neither its rate nor its coverage columns)."""
    rates = csv_rates(board)
    keys = [h.key for h in HEADLINE if h.rate is None or h.key in rates]
    listed = sorted((BY_KEY[k] for k in rates), key=lambda h: not _written_always(h))  # stable: always first
    coverages = [h.rate.coverage for h in listed if h.rate.coverage]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["bench", "category", "method", "label", "variant", "regime", "version", "config_hash",
                     "n_cases", "n_failed", *keys,
                     *(f"{c.key}_{suffix}" for c in coverages for suffix, _ in COVERAGE_COLUMNS[c.unit]),
                     *SCALE_COLUMNS, *(["part_class", "n_joints"] if per_part_class else [])])

    def values(metrics: dict) -> list[str]:
        numbers = ["n/a" if not is_number(metrics.get(k)) else repr(float(metrics[k])) for k in keys]
        for declared in coverages:
            found = metrics.get(declared.key) or {}
            numbers += [str(found.get(field, "n/a")) for _, field in COVERAGE_COLUMNS[declared.unit]]
        scales = metrics.get("alignment_scale") or {}
        numbers += [repr(float(scales[k])) if k in scales else "n/a" for k in ("median", "min", "max")]
        return numbers

    groups = [("", board.entries)] + (list(board.categories.items()) if per_category else [])
    for category, entries in groups:
        for e in entries:
            writer.writerow([board.bench, category, e.method, e.label, e.variant, e.regime, e.version,
                             e.config_hash, e.n_cases, e.n_failed, *values(e.metrics),
                             *(["", ""] if per_part_class else [])])
    if per_part_class:
        for table in _part_class_tables(board):
            name = table.key.removeprefix("part-")
            for e in table.entries:
                writer.writerow([board.bench, "", e.method, e.label, e.variant, e.regime, e.version,
                                 e.config_hash, e.n_cases, e.n_failed, *values(e.metrics), name,
                                 e.metrics.get("n_joints", 0)])
    return buffer.getvalue()


def render(board: Leaderboard, fmt: str, per_category: bool = False, out: Path | None = None,
           max_cases: int = 24, per_part_class: bool = False) -> str:
    """The leaderboard as text in ``fmt`` (``html`` writes its images beside ``out``).

    :param per_category: add per-category tables
    :param per_part_class: add the articulation errors per GAPartNet part class (SparkBenchError when no
        ground truth of the benchmark carries GAPartNet annotations)
    """
    if fmt == "md":
        return to_markdown(board, per_category, per_part_class)
    if fmt == "latex":
        return to_latex(board, per_category, per_part_class)
    if fmt == "csv":
        return to_csv(board, per_category, per_part_class)
    if fmt == "html":
        if out is None:
            raise SparkBenchError("the HTML leaderboard needs an output file for its images")
        from spark_bench.evaluation.leaderboard_html import to_html

        if per_part_class:
            _part_class_tables(board)  # the same error as the text formats, before any image is drawn
        return to_html(board, Path(out), per_category, max_cases, per_part_class)
    raise SparkBenchError(f"unknown format {fmt!r}; choose from {', '.join(FORMATS)}")
