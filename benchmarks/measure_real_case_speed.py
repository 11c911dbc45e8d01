"""Seconds of a real benchmark case's sim checks and opening score, cold (issue 12, item 5).

For each case of a prepared benchmark (default: ``partnet_dev``, prepared by ``spark-bench data
prepare``), in a fresh child process with a fresh, empty ``$SPARK_BENCH_HOME`` (no CoACD, link-shape or
contact cache), this script times, one after the other as ``spark-bench eval`` runs them for a
prediction:

1. the sim checks of the case's ground truth (:func:`spark_bench.sim.run_checks` on the ``gt``
   folder: the call ``spark-bench eval`` makes for a prediction, here the oracle's);
2. the oracle's opening score (:func:`spark_bench.opening.judge.open_with_predicted_joints`, the
   ground truth predicted by itself, every joint matched with itself, as
   ``benchmarks/measure_opener_real.py --score`` does).

Per stage: wall seconds, and CPU seconds of the child itself plus those of its CoACD workers
(``RUSAGE_CHILDREN``). Per case the verdicts too (each check, each joint's opening), so two runs
(before and after a change: ``--compare OLD.json``) show that the verdicts stayed the same. The
machine's load average is recorded at the start and end of every case: on a shared machine wall
seconds carry the other work, CPU seconds much less.

Run: ``nice -n 10 python -m benchmarks.measure_real_case_speed --cases 48492 100435 ...
[--bench DIR] [--out runs.json] [--compare old.json] [--results benchmarks/results/real_case_speed.md]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "real_case_speed.md"
TARGET_MEDIAN_S, TARGET_MAX_S = 30.0, 120.0


def _cpu() -> tuple[float, float]:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime


def _stage(fn) -> tuple[object, dict]:
    """Run ``fn``; its result and ``{"wall_s", "cpu_s", "workers_cpu_s"}`` (CPU of this process + its
    finished worker processes, and of the workers alone)."""
    own0, kids0 = _cpu()
    start = time.perf_counter()
    result = fn()
    wall = time.perf_counter() - start
    own1, kids1 = _cpu()
    return result, {"wall_s": round(wall, 2), "cpu_s": round(own1 - own0 + kids1 - kids0, 2),
                    "workers_cpu_s": round(kids1 - kids0, 2)}


def child(bench: Path, case_id: str) -> dict:
    """One case, in this process (run by :func:`run_case` with a fresh ``$SPARK_BENCH_HOME``)."""
    from spark_bench.data import load_object
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.opening.judge import open_with_predicted_joints
    from spark_bench.sim import run_checks

    gt_dir = BenchmarkCase(bench / "cases" / case_id).gt_dir
    report, checks = _stage(lambda: run_checks(gt_dir))
    checks["passed"] = bool(report.passed)
    checks["verdicts"] = {name: bool(c.passed) for name, c in report.checks.items()}
    checks["stages"] = {k: round(float(v), 2) for k, v in report.seconds.items()}
    gt_bench = load_object(gt_dir, load_meshes=False)
    matching = {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in gt_bench.movable_joints()]}
    result, score = _stage(lambda: open_with_predicted_joints(gt_dir, gt_dir, matching, seed=0))
    score["success_rate"] = result.get("success_rate")
    score["verdicts"] = {name: j.get("success") for name, j in result["joints"].items()}
    return {"case": case_id, "category": gt_bench.category, "checks": checks, "score": score}


def run_case(bench: Path, case_id: str, timeout: float) -> dict:
    """:func:`child` in a fresh process with a fresh, empty ``$SPARK_BENCH_HOME``."""
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="spark_case_speed_") as home, \
            tempfile.NamedTemporaryFile(suffix=".json") as out:
        env = dict(os.environ, SPARK_BENCH_HOME=home)
        command = [sys.executable, "-m", "benchmarks.measure_real_case_speed", "--child", case_id, "--bench",
                   str(Path(bench).resolve()), "--child-out", out.name]
        start = time.perf_counter()
        try:
            proc = subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
            text = Path(out.name).read_text()
            row = json.loads(text) if proc.returncode == 0 and text else {
                "case": case_id, "error": (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]}
        except subprocess.TimeoutExpired:
            row = {"case": case_id, "error": f"ran over {timeout:g} s"}
        row["process_wall_s"] = round(time.perf_counter() - start, 2)
    row["load_before"] = [round(x, 2) for x in load_before]
    row["load_after"] = [round(x, 2) for x in os.getloadavg()]
    return row


def total(row: dict, key: str) -> float | None:
    if "error" in row:
        return None
    return round(row["checks"][key] + row["score"][key], 2)


def verdict_changes(rows: list[dict], old: list[dict]) -> list[str]:
    """One line per case whose check or opening verdicts differ from ``old``'s."""
    before = {r["case"]: r for r in old if "error" not in r}
    out = []
    for row in rows:
        prev = before.get(row["case"])
        if prev is None or "error" in row:
            continue
        for stage in ("checks", "score"):
            if row[stage]["verdicts"] != prev[stage]["verdicts"]:
                out.append(f"{row['case']} {stage}: {prev[stage]['verdicts']} -> {row[stage]['verdicts']}")
    return out


def markdown(rows: list[dict], old: list[dict] | None, note: str) -> str:
    ok = [r for r in rows if "error" not in r]
    walls = [total(r, "wall_s") for r in ok]
    cpus = [total(r, "cpu_s") for r in ok]
    lines = ["# A real case's sim checks + opening score, cold", "",
             "Written by `benchmarks/measure_real_case_speed.py`: per case, in a fresh process with an empty "
             "`$SPARK_BENCH_HOME` (no CoACD, link-shape or contact cache), `spark_bench.sim.run_checks` on the "
             "case's `gt` folder (what `spark-bench eval` runs on a prediction; here the oracle's), then the "
             "oracle's opening score (`rl.scoring.open_with_predicted_joints`). CPU seconds include the "
             f"CoACD worker processes. Machine: {os.cpu_count()} cores"
             + (f"; {note}" if note else "") + ".", "",
             "| case | category | checks wall s | checks CPU s | score wall s | score CPU s | total wall s | "
             "total CPU s | load avg (1 min) before / after | verdicts |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    old_by = {r["case"]: r for r in (old or []) if "error" not in r}
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | ? | error: {r['error']} | | | | | | | |")
            continue
        checks, score = r["checks"], r["score"]
        failed = [k for k, v in checks["verdicts"].items() if not v]
        opened = sum(1 for v in score["verdicts"].values() if v)
        scored = sum(1 for v in score["verdicts"].values() if v is not None)
        verdict = (f"checks {'pass' if checks['passed'] else 'FAIL ' + ','.join(failed)}; "
                   f"opened {opened}/{scored} scored, {len(score['verdicts']) - scored} left out")
        if r["case"] in old_by:
            verdict += "; same as before" if not verdict_changes([r], [old_by[r["case"]]]) else "; CHANGED"
        lines.append(f"| {r['case']} | {r['category']} | {checks['wall_s']} | {checks['cpu_s']} | {score['wall_s']} | "
                     f"{score['cpu_s']} | {total(r, 'wall_s')} | {total(r, 'cpu_s')} | "
                     f"{r['load_before'][0]} / {r['load_after'][0]} | {verdict} |")
    if ok:
        med_w, max_w = statistics.median(walls), max(walls)
        lines += ["", f"Per case (checks + score), {len(ok)} cases: wall median {med_w:.1f} s, max {max_w:.1f} s; "
                      f"CPU median {statistics.median(cpus):.1f} s, max {max(cpus):.1f} s. Target (issue 12): "
                      f"<= {TARGET_MEDIAN_S:g} s median, <= {TARGET_MAX_S:g} s max: wall "
                      f"{'met' if med_w <= TARGET_MEDIAN_S and max_w <= TARGET_MAX_S else 'NOT met'}."]
        stages = sorted({k for r in ok for k in r["checks"]["stages"]} - {"total"})
        lines += ["", "Sim-check stages, wall s (median over the cases): " + ", ".join(
            f"{k} {statistics.median(r['checks']['stages'].get(k, 0.0) for r in ok):.2f}" for k in stages)]
    if old is not None:
        changes = verdict_changes(rows, old)
        lines += ["", f"Verdicts against the earlier run: {len(changes)} changed"] + [f"- {c}" for c in changes]
        old_ok = [r for r in old if "error" not in r and r["case"] in {x["case"] for x in ok}]
        if old_ok:
            lines += [f"Earlier run on the same cases: wall median {statistics.median(total(r, 'wall_s') for r in old_ok):.1f} s, "
                      f"max {max(total(r, 'wall_s') for r in old_ok):.1f} s; CPU median "
                      f"{statistics.median(total(r, 'cpu_s') for r in old_ok):.1f} s, "
                      f"max {max(total(r, 'cpu_s') for r in old_ok):.1f} s."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bench", type=Path, default=Path.home() / ".cache" / "spark-bench" / "benchmarks" / "partnet_dev",
                        help="a prepared benchmark folder")
    parser.add_argument("--cases", nargs="*", default=None, help="case ids (default: every case)")
    parser.add_argument("--out", type=Path, default=None, help="write the rows as JSON here (after each case)")
    parser.add_argument("--compare", type=Path, default=None, help="an earlier run's --out JSON")
    parser.add_argument("--results", type=Path, default=RESULTS, help="Markdown report ('-': none)")
    parser.add_argument("--note", default="", help="a line for the report (what else ran on the machine)")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds one case may take")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--child-out", type=Path, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        args.child_out.write_text(json.dumps(child(args.bench, args.child), default=float))
        return 0
    cases = args.cases or sorted(p.name for p in (args.bench / "cases").iterdir() if p.is_dir())
    old = json.loads(args.compare.read_text()) if args.compare else None
    rows = []
    for case_id in cases:
        row = run_case(args.bench, case_id, args.timeout)
        rows.append(row)
        if "error" in row:
            print(f"{case_id}: error: {row['error']}", flush=True)
        else:
            print(f"{case_id} ({row['category']}): checks {row['checks']['wall_s']} s wall / {row['checks']['cpu_s']} s CPU, "
                  f"score {row['score']['wall_s']} s wall / {row['score']['cpu_s']} s CPU, total "
                  f"{total(row, 'wall_s')} s wall, load {row['load_before'][0]} -> {row['load_after'][0]}", flush=True)
        if args.out is not None:
            args.out.write_text(json.dumps(rows, indent=1, default=float))
    text = markdown(rows, old, args.note)
    print(text)
    if str(args.results) != "-":
        args.results.write_text(text)
        print(f"wrote {args.results}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
