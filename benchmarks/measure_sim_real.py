"""Sim-readiness checks on real objects: verdicts, reasons and seconds per object.

For every object folder (default: the 75 of ``../shared/partnet_dev`` and the 7 of
``../shared/real_objects``) and every prepared benchmark case given with ``--cases BENCH`` (its
``gt`` folder: the watertight R=200 remesh the evaluation checks), this script runs
``spark-bench check OBJECT --json`` in a child process and records

- the verdict of each check, the reason of each failure (which joint, which hulls, how far);
- wall seconds and CPU seconds (the child and its CoACD workers), the seconds spent converting
  (collision hulls, CoACD) and the CoACD calls and cache hits;

then writes ``benchmarks/results/sim_real.md``: the pass rate over all objects, per category and over
the objects with a drawer, door or lid (their ``semantics.txt``), every failure with its reason and
the reviewed verdict (``benchmarks/results/sim_real_review.json``: what a person looking at the check strip decided), and the
seconds per prepared case.

Each object's result is stored as ``<store>/<label>/<id>.json`` and reused on the next run
(``--fresh`` reruns), so a sweep interrupted half-way resumes, and two labels (before and after a
change) can be compared with ``--compare LABEL``: the verdicts that changed are printed.

Timing: ``--cold`` gives every object an empty CoACD cache (a temporary ``$SPARK_BENCH_HOME``): what a
benchmark case costs the first time it is checked. Without it, the shared cache of ``--home`` is used
(fast reruns of the verdict sweep).

``--report-only`` writes the report of the stored results without checking anything (a sweep still
running in another process); with ``--fill-from LABEL`` the objects not yet checked under ``--label``
take LABEL's stored result, marked as such in the report.

Run: ``nice -n 10 python -m benchmarks.measure_sim_real [--ids 100247 7310] [--subset] [--cases BENCH]
[--cold] [--workers 1] [--label after] [--compare before] [--report-only [--fill-from before]]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
SOURCES = (SHARED / "partnet_dev", SHARED / "real_objects")
RESULTS = ROOT / "benchmarks" / "results" / "sim_real.md"
#: Text of the report below this line is written by people (analysis, reviews) and kept on a rewrite.
NOTES = "<!-- notes: kept when the script rewrites the file -->"
#: Parts whose presence makes an object a "drawer, door or lid" object (PartNet-Mobility semantics).
OPENABLE = re.compile(r"(^|_)(drawer|door|lid)$")

#: Reviewed verdicts of the failures: ``{object id: {"reason": the check's reason when reviewed,
#: "verdict": ..., "fix": what a person would fix}}``, written by the person who looked at each failing
#: object's check strip (``spark-bench check OBJ --render``), meshes and sweep. Data, not code: no
#: verdict depends on it. A failure whose reason changed since its review is reported as such.
REVIEW_FILE = ROOT / "benchmarks" / "results" / "sim_real_review.json"


def load_review() -> dict[str, dict]:
    return json.loads(REVIEW_FILE.read_text()) if REVIEW_FILE.is_file() else {}


# ----- one object ---------------------------------------------------------------------------------
def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def semantics(folder: Path) -> list[tuple[str, str, str]]:
    """``(link, joint kind, part label)`` of ``folder/semantics.txt`` (empty when absent)."""
    path = folder / "semantics.txt"
    if not path.is_file():
        return []
    return [tuple(line.split()[:3]) for line in path.read_text().splitlines() if len(line.split()) >= 3]


def category_of(folder: Path) -> str:
    for name in ("meta.json", "case.json"):
        for path in (folder / name, folder.parent / name):
            if path.is_file():
                data = json.loads(path.read_text())
                for key in ("model_cat", "category"):
                    if data.get(key):
                        return str(data[key])
    return "?"


def run_one(folder: Path, workers: int, home: Path | None, timeout: float, render: Path | None) -> dict:
    """``spark-bench check folder --json`` in a child process; its verdicts, reasons and seconds."""
    env = dict(os.environ)
    tmp = None
    if home is None:
        tmp = tempfile.TemporaryDirectory(prefix="spark_sim_real_")
        env["SPARK_BENCH_HOME"] = tmp.name
    else:
        home.mkdir(parents=True, exist_ok=True)
        env["SPARK_BENCH_HOME"] = str(home.resolve())
    command = [sys.executable, "-m", "spark_bench.cli", "check", str(Path(folder).resolve()), "--json",
               "--no-progress", "--workers", str(workers)]
    if render is not None:
        command += ["--render", str(Path(render).resolve())]
    cpu, wall = children_cpu(), time.perf_counter()
    try:
        # run from the home folder: ``-m`` puts the working directory first on sys.path, and the
        # package measured must be the installed one (or the one on PYTHONPATH), not a checkout there
        proc = subprocess.run(command, capture_output=True, text=True, env=env, timeout=timeout,
                              cwd=env["SPARK_BENCH_HOME"])
        code, out, err = proc.returncode, proc.stdout, proc.stderr
    except subprocess.TimeoutExpired as exc:
        code, out, err = None, "", f"ran over {timeout:g} s"
        del exc
    finally:
        if tmp is not None:
            tmp.cleanup()
    row = {"folder": str(folder), "category": category_of(folder), "exit": code,
           "wall_s": round(time.perf_counter() - wall, 2), "cpu_s": round(children_cpu() - cpu, 2),
           "parts": sorted({label for _, _, label in semantics(folder)}), "workers": workers,
           "cold": home is None}
    row["openable"] = any(OPENABLE.search(label) for label in row["parts"])
    try:
        report = json.loads(out) if code in (0, 1) else None
    except ValueError:
        report = None
    if report is None:  # crashed, timed out or unreadable: recorded, the sweep goes on
        row.update(passed=False, error=(err.strip().splitlines() or ["no output"])[-1][:300])
        return row
    row["passed"] = bool(report["passed"])
    row["checks"] = {name: {"passed": c["passed"], "value": c["value"], "reason": c.get("reason")}
                     for name, c in report["checks"].items()}
    compiled = report["checks"].get("mjcf_compiles", {})
    row["convert_s"] = compiled.get("convert_seconds")
    row["coacd_calls"], row["coacd_cache_hits"] = compiled.get("coacd_calls"), compiled.get("coacd_cache_hits")
    row["hulls"] = sum((compiled.get("hulls") or {}).values())
    row["seconds"] = report.get("seconds", {})
    row["phantom"] = [f"{b['child']} in {b['parent']} ({b['joint']})" for b in compiled.get("phantom_blocks", [])]
    row["relief"] = sorted((compiled.get("relief") or {}).keys())
    sweep_check = report["checks"].get("joint_sweep", {})
    failed = set(sweep_check.get("failed", []))
    row["sweep"] = {name: {**{k: j.get(k) for k in ("reached", "returned", "blocked_by", "opened_first")},
                           "passed": name not in failed, **stop_summary(j)}
                    for name, j in sweep_check.get("joints", {}).items()}
    return row


def stop_summary(joint: dict) -> dict:
    """What held a swept joint that stopped short (``stopped_by``, else ``stopped_back_by``): the cause, the
    drive's force and the contacts' share of it; empty for a joint that did not stop short (or a check from
    before the stops were explained)."""
    cause = joint.get("stopped_by") or joint.get("stopped_back_by")
    if not cause:
        return {}
    return {"stop_cause": cause["cause"], "drive": cause["drive"], "contact": cause["opposing"].get("contact", 0.0),
            "way": "out" if joint.get("stopped_by") else "back"}


# ----- the sweep ----------------------------------------------------------------------------------
def object_folders(sources, ids, subset: bool) -> dict[str, Path]:
    found: dict[str, Path] = {}
    for source in sources:
        if not Path(source).is_dir():
            print(f"skipped: {source} is absent")
            continue
        for folder in sorted(Path(source).iterdir()):
            if (folder / "mobility.urdf").is_file() and (not ids or folder.name in ids):
                found[folder.name] = folder
    # objects with a drawer, door or lid first: the pass rate that matters most is known soonest
    found = dict(sorted(found.items(), key=lambda kv: not any(OPENABLE.search(p) for _, _, p in semantics(kv[1]))))
    if subset:  # every category once
        chosen: dict[str, Path] = {}
        for folder in found.values():
            chosen.setdefault(category_of(folder), folder)
        found = {f.name: f for f in chosen.values()}
    return found


def case_folders(benches, ids) -> dict[str, Path]:
    found = {}
    for bench in benches:
        for case in sorted((Path(bench) / "cases").iterdir()):
            if (case / "gt" / "mobility.urdf").is_file() and (not ids or case.name in ids):
                found[f"case:{case.name}"] = case / "gt"
    return found


def sweep(folders: dict[str, Path], store: Path, args) -> dict[str, dict]:
    from tqdm import tqdm

    store.mkdir(parents=True, exist_ok=True)
    rows = {}
    bar = tqdm(folders.items(), desc="check", unit="object")
    for key, folder in bar:
        path = store / f"{key.replace(':', '_')}.json"
        if path.is_file() and not args.fresh:
            rows[key] = json.loads(path.read_text())
            if not (args.rerun_failed and not rows[key]["passed"]):
                continue
        if args.report_only:
            older = args.store / args.fill_from / path.name if args.fill_from else None
            if older is not None and older.is_file():
                rows[key] = dict(json.loads(older.read_text()), from_label=args.fill_from)
            continue
        bar.set_postfix_str(key)
        render = Path(args.renders) / f"{key.replace(':', '_')}.png" if args.renders else None
        row = run_one(folder, args.workers, None if args.cold else Path(args.home), args.timeout, render)
        path.write_text(json.dumps(row, indent=1) + "\n")
        rows[key] = row
        tqdm.write(f"{key:>14} {row['category']:<17} {'pass' if row['passed'] else 'FAIL'} "
                   f"{row['wall_s']:7.1f} s wall {row['cpu_s']:7.1f} s cpu  {failure_line(row)[:150]}")
    return rows


def failure_line(row: dict) -> str:
    if row.get("error"):
        return f"error: {row['error']}"
    return "; ".join(f"{name}: {c['reason'] or 'failed'}" for name, c in row.get("checks", {}).items()
                     if not c["passed"])


# ----- report -------------------------------------------------------------------------------------
def rate(rows) -> str:
    rows = list(rows)
    passed = sum(1 for r in rows if r["passed"])
    return f"{passed}/{len(rows)} ({passed / len(rows):.0%})" if rows else "-"


def verdict_changes(rows: dict[str, dict], other: dict[str, dict]) -> list[str]:
    out = []
    for key in sorted(set(rows) & set(other)):
        a, b = other[key], rows[key]
        checks_a = {k: v["passed"] for k, v in a.get("checks", {}).items()}
        checks_b = {k: v["passed"] for k, v in b.get("checks", {}).items()}
        if a["passed"] != b["passed"] or checks_a != checks_b:
            changed = sorted(k for k in set(checks_a) | set(checks_b) if checks_a.get(k) != checks_b.get(k))
            out.append(f"{key}: {'pass' if a['passed'] else 'FAIL'} -> {'pass' if b['passed'] else 'FAIL'} "
                       f"({', '.join(changed) or 'error'})")
    return out


def joint_changes(rows: dict[str, dict], other: dict[str, dict]) -> list[str]:
    """The swept joints whose own sweep verdict differs between two labels (a joint's verdict can flip while its
    object's stays: another check fails it)."""
    out = []
    for key in sorted(set(rows) & set(other)):
        before, after = other[key].get("sweep") or {}, rows[key].get("sweep") or {}
        for name in sorted(set(before) & set(after)):
            a, b = before[name], after[name]
            if "passed" in a and "passed" in b and a["passed"] != b["passed"]:
                out.append(f"{key} {name}: {'pass' if a['passed'] else 'FAIL'} -> {'pass' if b['passed'] else 'FAIL'} "
                           f"(reached {a['reached']:.0%} -> {b['reached']:.0%}, returned {a['returned']:.0%} -> "
                           f"{b['returned']:.0%})")
    return out


def stop_lines(objects: dict[str, dict]) -> list[str]:
    """The report's section on the joints that stop short: how many by cause, and each failing one with the
    drive's force and what the contacts opposed (a contact weaker than the drive cannot be what holds it)."""
    stops = [(key, name, j) for key, r in sorted(objects.items()) for name, j in (r.get("sweep") or {}).items()
             if j.get("stop_cause")]
    if not stops:
        return []
    causes = Counter(j["stop_cause"] for _, _, j in stops)
    lines = ["", "## What holds the joints that stop short", "",
             f"{len(stops)} swept joints stop short of 98 % of their range (out or back) in "
             f"{len({key for key, _, _ in stops})} objects; by the cause the check names "
             f"(`spark_bench.sim.explain.stop_cause`): " + ", ".join(f"{c} {n}" for c, n in causes.most_common())
             + ". The failing ones (below 90 %), with the servo's force (N on a slide, N m on a hinge; at least the "
             "part's weight) and what the contacts opposed:", "",
             "| object | joint | way | reached / returned | cause | drive | contacts oppose |", "|---|---|---|---|---|---|---|"]
    for key, name, j in stops:
        if j.get("passed", True):
            continue
        lines.append(f"| {key} | {name} | {j['way']} | {j['reached']:.0%} / {j['returned']:.0%} | {j['stop_cause']} | "
                     f"{j['drive']:.3g} | {j['contact']:.3g} |")
    return lines


def timing_lines(rows: list[dict]) -> list[str]:
    if not rows:
        return []
    walls = [r["wall_s"] for r in rows]
    return [f"median {statistics.median(walls):.1f} s, max {max(walls):.1f} s wall; "
            f"median {statistics.median(r['cpu_s'] for r in rows):.1f} s CPU"]


def markdown(rows: dict[str, dict], args, baseline: dict[str, dict] | None) -> str:
    objects = {k: r for k, r in rows.items() if not k.startswith("case:")}
    cases = {k: r for k, r in rows.items() if k.startswith("case:")}
    lines = ["# Sim-readiness checks on real objects", "",
             f"Written by `benchmarks/measure_sim_real.py` ({time.strftime('%Y-%m-%d')}): "
             f"`spark-bench check OBJECT --json --workers {args.workers}` per object, one at a time, "
             f"{'each with an empty CoACD cache' if args.cold else 'with the shared CoACD cache'}, "
             f"on {os.cpu_count()} cores shared with other work (`nice`).", ""]
    if objects:
        openable = [r for r in objects.values() if r["openable"]]
        found = getattr(args, "found", len(objects))
        lines += ["## Pass rate", "",
                  f"- objects checked: {len(objects)} of the {found} found"
                  + (" (the sweep had not reached the others when this was written)" if len(objects) < found else ""),
                  *([f"- {sum(1 for r in objects.values() if r.get('from_label'))} of them carry the stored result of "
                     f"the label `{args.fill_from}` (an earlier version of the checks; marked in the failures)"]
                    if any(r.get("from_label") for r in objects.values()) else []),
                  f"- all objects: {rate(objects.values())}",
                  f"- objects with a drawer, door or lid (`semantics.txt`): {rate(openable)}", "",
                  "| category | objects | passed | with drawer/door/lid | passed |", "|---|---|---|---|---|"]
        by_cat: dict[str, list] = {}
        for r in objects.values():
            by_cat.setdefault(r["category"], []).append(r)
        for cat, rs in sorted(by_cat.items()):
            op = [r for r in rs if r["openable"]]
            lines.append(f"| {cat} | {len(rs)} | {sum(r['passed'] for r in rs)} | {len(op)} | "
                         f"{sum(r['passed'] for r in op)} |")
        failing_checks = Counter(name for r in objects.values() for name, c in r.get("checks", {}).items()
                                 if not c["passed"])
        lines += ["", "Failed checks: " + (", ".join(f"{k} {v}" for k, v in failing_checks.most_common())
                                           or "none"), "", "## Failures", "",
                  "| object | category | drawer/door/lid | reason (from the check) | reviewed verdict | "
                  "what a person would fix |", "|---|---|---|---|---|---|"]
        review = load_review()
        for key, r in sorted(objects.items()):
            if r["passed"]:
                continue
            entry = review.get(key)
            if entry is None:
                verdict, fix = "not reviewed", ""
            else:
                verdict, fix = entry["verdict"], entry["fix"]
                if entry.get("checks") and sorted(entry["checks"]) != sorted(
                        n for n, c in r.get("checks", {}).items() if not c["passed"]):
                    verdict = f"{verdict} (reviewed when other checks failed: {', '.join(entry['checks'])})"
            label = f" (result of `{r['from_label']}`)" if r.get("from_label") else ""
            lines.append(f"| {key}{label} | {r['category']} | {'yes' if r['openable'] else 'no'} | "
                         f"{failure_line(r).replace('|', '/')} | {verdict} | {fix} |")
    lines += stop_lines(objects)
    if cases:
        lines += ["", "## Seconds per prepared case (gt: watertight R=200 remesh)", ""]
        lines += ["| case | category | verdict | wall s | CPU s | convert s | CoACD calls | hulls |",
                  "|---|---|---|---|---|---|---|---|"]
        for key, r in sorted(cases.items()):
            lines.append(f"| {key[5:]} | {r['category']} | {'pass' if r['passed'] else 'FAIL'} | {r['wall_s']} | "
                         f"{r['cpu_s']} | {r.get('convert_s')} | {r.get('coacd_calls')} | {r.get('hulls')} |")
        lines += ["", *timing_lines(list(cases.values()))]
        stages = sorted({k for r in cases.values() for k in r.get("seconds", {})} - {"total"})
        if stages:
            lines += ["", "Wall seconds per stage (median over the cases; `coacd_cpu` is the CPU time of the "
                      "CoACD workers inside `shapes`): " + ", ".join(
                          f"{k} {statistics.median(r.get('seconds', {}).get(k, 0.0) for r in cases.values()):.2f}"
                          for k in stages)]
    if baseline is not None:
        changes = verdict_changes(rows, baseline)
        lines += ["", f"## Verdicts against `{args.compare}`", "",
                  f"{len(set(rows) & set(baseline))} objects in both; changed: {len(changes)}", ""]
        lines += [f"- {c}" for c in changes]
        joints = joint_changes(rows, baseline)
        lines += ["", f"Swept joints whose own sweep verdict changed: {len(joints)}", "", *[f"- {c}" for c in joints]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", nargs="*", type=Path, default=list(SOURCES), help="folders of object folders")
    parser.add_argument("--cases", nargs="*", type=Path, default=[], help="prepared benchmarks: check cases/*/gt")
    parser.add_argument("--ids", nargs="*", default=None, help="only these object or case ids")
    parser.add_argument("--subset", action="store_true", help="one object per category")
    parser.add_argument("--workers", type=int, default=1, help="CoACD processes per check")
    parser.add_argument("--cold", action="store_true", help="an empty CoACD cache for every object")
    parser.add_argument("--home", type=Path, default=Path(tempfile.gettempdir()) / "spark_sim_real_home",
                        help="$SPARK_BENCH_HOME of the checks (the shared cache) without --cold")
    parser.add_argument("--store", type=Path, default=Path(tempfile.gettempdir()) / "spark_sim_real",
                        help="per-object results, under STORE/LABEL/")
    parser.add_argument("--label", default="current", help="name of this run's results")
    parser.add_argument("--compare", default=None, help="print verdicts that differ from this label")
    parser.add_argument("--fresh", action="store_true", help="rerun objects that have a stored result")
    parser.add_argument("--rerun-failed", action="store_true", help="rerun the objects whose stored result failed")
    parser.add_argument("--report-only", action="store_true",
                        help="no checks: the report of the stored results (a sweep still running)")
    parser.add_argument("--fill-from", default=None,
                        help="with --report-only: objects this label has no result for take LABEL's, marked")
    parser.add_argument("--renders", type=Path, default=None, help="write each object's check strip here")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds one check may take")
    parser.add_argument("--out", type=Path, default=RESULTS, help="Markdown report ('-': none)")
    args = parser.parse_args(argv)
    ids = set(args.ids) if args.ids else None
    folders: dict[str, Path] = {}
    if args.src:
        folders.update(object_folders(args.src, ids, args.subset))
    folders.update(case_folders(args.cases, ids))
    if not folders:
        print("nothing to check (shared objects absent?)")
        return 0
    args.found = sum(1 for key in folders if not key.startswith("case:"))
    rows = sweep(folders, args.store / args.label, args)
    baseline = None
    if args.compare:
        base_dir = args.store / args.compare
        baseline = {p.stem.replace("case_", "case:", 1): json.loads(p.read_text()) for p in base_dir.glob("*.json")}
        for line in verdict_changes(rows, baseline) or ["no verdict changed"]:
            print(line)
    text = markdown(rows, args, baseline)
    print(text)
    if str(args.out) != "-":
        args.out.parent.mkdir(parents=True, exist_ok=True)
        old = args.out.read_text() if args.out.is_file() else ""
        notes = old[old.index(NOTES):] if NOTES in old else f"{NOTES}\n"
        args.out.write_text(text + "\n" + notes)  # the reviewed notes below the marker are kept
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
