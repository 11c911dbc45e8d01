"""Does the joint optimization help on imperfect geometry? ``ours`` on retrieved objects vs ``retrieval``.

Reads the stored rows of three labels on one benchmark from a results store and compares them per
category, on the cases all three have (like for like: the same cases, the same evaluation settings):

- ``retrieval (gallery=synth-gallery-v1)``: the retrieved object as is;
- ``ours (prior=retrieval,geometry=retrieval,open=dataset,opt=native)`` ``w/o joint opt.``: the same
  object re-assembled as ``ours``' prior (axes named in the object's turned frame, limits its own);
- the same ``ours`` after the native joint optimization against the open-state image.

Metrics: AxisErr, PivotErr, TypeErr (per-case means over matched joints, then the mean over cases), CD
and open-state CD (``cd_open``), sim-readiness pass rate and opening success, plus how many cases the
optimization made better or worse (by more than 1e-3) on each joint error and on ``cd_open``.

Make the rows first (one worker, the machine is shared)::

    spark-bench eval --method retrieval --bench synth-v1 --workers 1
    spark-bench eval --method ours --config benchmarks/configs/ours_retrieval.toml --bench synth-v1 --workers 1

Run: ``python -m benchmarks.measure_ours_retrieval [--db FILE] [--bench synth-v1] [--out FILE.md]``.
"""

from __future__ import annotations

import argparse
import math
import subprocess
from collections import defaultdict
from pathlib import Path

RETRIEVAL = "retrieval (gallery=synth-gallery-v1)"
OURS = "ours (prior=retrieval,geometry=retrieval,open=dataset,opt=native)"
PRIOR_VARIANT = "w/o joint opt."
JOINT = ("axis_err", "pivot_err", "type_err")
SHAPE = ("cd", "cd_open")
NAMES = {"axis_err": "AxisErr↓", "pivot_err": "PivotErr↓", "type_err": "TypeErr↓", "cd": "CD↓",
         "cd_open": "CD open↓", "sim_pass": "Sim pass↑", "open_success": "Open success↑"}
ROWS = (("retrieval", RETRIEVAL, ""), ("ours w/o opt.", OURS, PRIOR_VARIANT), ("ours", OURS, ""))
#: A case counts as changed by the optimization when a metric moves by more than this.
CHANGE = 1e-3


def _mean(values) -> float | None:
    values = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    return sum(values) / len(values) if values else None


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.4f}"


def load(db: Path, bench: str) -> tuple[dict, list[str], dict]:
    """``({row name: {case: row}}, the cases every row has, {row name: eval settings})``."""
    from spark_bench.evaluation.store import ResultsStore

    out, settings = {}, {}
    with ResultsStore(db) as store:
        for name, label, variant in ROWS:
            rows = [r for r in store.rows(bench=bench, label=label) if r["variant"] == variant]
            out[name] = {r["case_id"]: r for r in rows}
            settings[name] = sorted({str(r["config"].get("eval")) for r in rows})
    common = sorted(set.intersection(*(set(v) for v in out.values()))) if out else []
    return out, common, settings


def table(rows: dict, cases: list[str], metrics) -> list[str]:
    """One line per category (and all): each metric for each compared row."""
    by_category = defaultdict(list)
    for case in cases:
        by_category[rows["ours"][case]["category"]].append(case)
    head = ["Category", "Cases"] + [f"{NAMES[m]} {name}" for m in metrics for name, _, _ in ROWS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    groups = sorted(by_category.items()) + [("**all**", cases)]
    for category, members in groups:
        cells = [category, str(len(members))]
        for m in metrics:
            values = [_mean(_metric(rows[name][c], m) for c in members) for name, _, _ in ROWS]
            shown = [_fmt(v) for v in values]  # the best as printed is bold, unless all print alike
            numbers = [float(t) for t in shown if t != "n/a"]
            best = None if len(set(numbers)) < 2 else _fmt(max(numbers) if m in ("sim_pass", "open_success")
                                                           else min(numbers))
            cells += [f"**{t}**" if t == best else t for t in shown]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _metric(row: dict, name: str):
    if row["status"] != "ok":
        return None
    value = row.get(name)
    if name == "sim_pass" and value is not None:
        return float(bool(value))
    return value


def changes(rows: dict, cases: list[str]) -> list[str]:
    """How many cases the optimization made better / worse / left (within CHANGE), per metric."""
    lines = ["| Metric | Better | Worse | Same | Mean change |", "|---|---|---|---|---|"]
    for m in (*JOINT, "cd_open"):
        before = [(_metric(rows["ours w/o opt."][c], m), _metric(rows["ours"][c], m)) for c in cases]
        pairs = [(b, a) for b, a in before if b is not None and a is not None]
        better = sum(a < b - CHANGE for b, a in pairs)
        worse = sum(a > b + CHANGE for b, a in pairs)
        mean = _mean(a - b for b, a in pairs)
        lines.append(f"| {NAMES[m]} | {better} | {worse} | {len(pairs) - better - worse} | "
                     f"{'n/a' if mean is None else f'{mean:+.4f}'} |")
    return lines


def per_case(rows: dict, cases: list[str]) -> list[str]:
    lines = ["| Case | Retrieved | AxisErr w/o → ours | PivotErr w/o → ours | TypeErr w/o → ours | "
             "CD open w/o → ours | Sim | Open |", "|---|---|---|---|---|---|---|---|"]
    for case in cases:
        before, after = rows["ours w/o opt."][case], rows["ours"][case]
        found = (after.get("info") or {}).get("retrieval", {})
        cells = [case, f"{found.get('object_id', '?')}"]
        for m in (*JOINT, "cd_open"):
            cells.append(f"{_fmt(_metric(before, m))} → {_fmt(_metric(after, m))}")
        sim = after.get("sim_pass")
        cells += ["n/a" if sim is None else ("pass" if sim else "fail"), _fmt(after.get("open_success"))]
        if after["status"] != "ok":
            cells[-1] += f" (failed: {after.get('reason', '')[:60]})"
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def icp_section(db: Path, bench: str) -> list[str]:
    """The rows of another store evaluated with ``--align icp`` (a subset): that the alignment runs on
    retrieved meshes, and what it gives, per case and row."""
    rows, cases, settings = load(db, bench)
    aligns = sorted({s for v in settings.values() for s in v})
    lines = [f"## With `--align icp` ({len(cases)} cases, store `{db.name}`)", "",
             f"Evaluation settings: {aligns}.", "",
             "| Case | Row | Status | CD | CD open | AxisErr | PivotErr | TypeErr |", "|---|---|---|---|---|---|---|---|"]
    for case in cases:
        for name, _, _ in ROWS:
            row = rows[name][case]
            cells = [case, name, row["status"] + (f" ({row.get('reason', '')[:60]})" if row["status"] != "ok" else "")]
            cells += [_fmt(_metric(row, m)) for m in (*SHAPE, *JOINT)]
            lines.append("| " + " | ".join(cells) + " |")
    return lines + [""]


def main() -> None:
    from spark_bench.paths import home

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--db", type=Path, default=None, help="results store (default: $SPARK_BENCH_HOME's)")
    parser.add_argument("--bench", default="synth-v1")
    parser.add_argument("--out", type=Path, help="also write the Markdown here")
    parser.add_argument("--note", default="", help="a line about how the rows were made (machine, load)")
    parser.add_argument("--icp-db", type=Path, help="a store of the same rows evaluated with --align icp (a subset)")
    args = parser.parse_args()
    db = args.db or home() / "results.sqlite"
    rows, cases, settings = load(db, args.bench)
    if not cases:
        raise SystemExit(f"no case has all of {[r[1] + (' ' + r[2] if r[2] else '') for r in ROWS]} in {db}")
    commit = subprocess.run(["git", "log", "-1", "--format=%h"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    failed = {name: sum(rows[name][c]["status"] != "ok" for c in cases) for name, _, _ in ROWS}
    lines = [f"# `ours` on retrieved objects vs `retrieval`: {args.bench}", "",
             f"Does the joint optimization help on imperfect geometry? {len(cases)} cases that all three rows "
             f"have; failed cases: {failed}. Rows from `{db.name}`, tables by "
             f"`benchmarks/measure_ours_retrieval.py` at commit {commit}.", "",
             f"- **retrieval**: `{RETRIEVAL}` (image + gt camera): the retrieved gallery object as is.",
             f"- **ours w/o opt.**: `{OURS}` `{PRIOR_VARIANT}`: that object as `ours`' prior (structure and part "
             "meshes of the one retrieval; axes named in the object's own turned frame, its own limits).",
             "- **ours**: the same after the native joint optimization (type/axis search + fit against the "
             "open-state image's silhouette; image + gt camera + gt open image, no ground-truth structure, "
             "geometry or masks).", "",
             f"Evaluation settings per row: {settings}.", ""]
    if args.note:
        lines += [args.note, ""]
    lines += ["## Joint errors", "", *table(rows, cases, JOINT), "",
              "## Shape (CD at rest; CD open: at the open state) and simulation", "",
              *table(rows, cases, (*SHAPE, "sim_pass", "open_success")), "",
              "## What the optimization changed (ours vs ours w/o opt., per case)", "", *changes(rows, cases), "",
              "<details><summary>per case</summary>", "", *per_case(rows, cases), "", "</details>", ""]
    if args.icp_db:
        lines += icp_section(args.icp_db, args.bench)
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
