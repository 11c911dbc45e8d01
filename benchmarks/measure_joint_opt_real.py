"""Seconds per real object of SPARK's joint optimization, ``opt=spark`` and ``opt=native``, on
``../shared/partnet_dev`` prepared as a benchmark (75 PartNet-Mobility objects; aim: <= 10 s each on 2
cores).

    python -m benchmarks.measure_joint_opt_real                      # prepares partnet_dev once, then times
    python -m benchmarks.measure_joint_opt_real --bench /path/to/prepared --limit 10
    python -m benchmarks.measure_joint_opt_real --ids 102278 7265 ... [--cached]   # a subset; report only

The benchmark is prepared on first use (``spark-bench data prepare --src ../shared/partnet_dev --out
$SPARK_BENCH_HOME/benchmarks/partnet_dev``: watertight R=200, 512 px renders; about 30 min on 2 busy
cores). Each object runs ``run_ours`` with the default config (annotation prior, seed 0; geometry
annotation; dataset open state) and each method, one process, torch at 1 thread. Reported per object:
the CPU seconds of the whole joint-optimization stage (``optimize_cpu``: the open state, the rendered
meshes' decimation and the fit) and of the whole ``run_ours`` (loading the ground truth's meshes and
writing two object folders too), and the wall seconds with the machine's load average. CPU seconds are
the cost (on a shared machine wall seconds grow with the load); the target is on the optimizer.
Writes ``benchmarks/results/joint_opt_speed_partnet_dev.md``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from rich.console import Console

from benchmarks.joint_opt_runs import VARIANTS, cached_results, case_dirs, run_tasks, write_result

#: Where the shared development objects are, relative to the repository.
SOURCE = Path(__file__).resolve().parents[1].parent / "shared" / "partnet_dev"
TARGET_S = 10.0


def prepared(bench: str | None, console: Console) -> Path:
    """The prepared benchmark folder: ``bench``, or partnet_dev prepared under the cache on first use."""
    if bench:
        return Path(bench).expanduser()
    from spark_bench.paths import cache_dir

    folder = cache_dir("benchmarks") / "partnet_dev"
    if not (folder / "manifest.json").is_file():
        if not SOURCE.is_dir():
            raise SystemExit(f"{SOURCE} not found: pass --bench with a prepared benchmark")
        console.print(f"preparing {SOURCE} into {folder} (once)")
        subprocess.run([sys.executable, "-m", "spark_bench.cli", "data", "prepare", "--src", str(SOURCE),
                        "--out", str(folder)], check=True)
    return folder


def _stats(values) -> str:
    values = np.asarray(values, float)
    return f"median {np.median(values):.1f}, mean {values.mean():.1f}, max {values.max():.1f}"


def per_object_lines(results: dict, methods: list[str]) -> list[str]:
    """One row per object: each method's optimizer CPU s and its whole ``run_ours`` (CPU s; the wall
    seconds of loading the ground truth and of writing the object folders)."""
    cases = sorted({k[2] for k in results}, key=lambda c: -max(r["timings"]["optimize_cpu"]
                                                               for (m, _, cc), r in results.items() if cc == c))
    head = " | ".join(f"opt={m}: optimizer CPU s | opt={m}: run_ours CPU s (load, export wall s)" for m in methods)
    lines = [f"| object | category | movable joints | {head} |", "|---" * (3 + 2 * len(methods)) + "|"]
    for case in cases:
        cells, any_row = [], None
        for method in methods:
            row = results.get((method, 0, case))
            if row is None:
                cells += ["n/a", "n/a"]
                continue
            any_row, t = row, row["timings"]
            cells += [f"{t['optimize_cpu']:.1f}",
                      f"{row['cpu_seconds']:.1f} ({t.get('load', 0.0):.1f}, {t.get('export', 0.0):.1f})"]
        lines.append(f"| {case} | {any_row['category']} | {any_row['n_joints']} | " + " | ".join(cells) + " |")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", default=None, help="a prepared benchmark folder (default: partnet_dev, prepared once)")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--ids", nargs="*", default=None, help="only these case ids (a documented subset)")
    parser.add_argument("--methods", default="spark,native")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--work", default="~/.cache/spark-bench/measure_joint_opt_real")
    parser.add_argument("--cached", action="store_true",
                        help="run nothing: report the runs cached under --work, whatever code made them")
    parser.add_argument("--note", action="append", default=[], help="a line added under the heading")
    args = parser.parse_args(argv)
    console = Console()
    bench = prepared(args.bench, console)
    cases = case_dirs(bench, args.limit, args.ids)
    methods = [m for m in args.methods.split(",") if m]
    work = Path(args.work).expanduser() / bench.name
    tasks = [((m, 0, c.name), str(c), str(work / m / c.name), list(VARIANTS[m]), 0, False)
             for m in methods for c in cases]
    results = cached_results(tasks, console) if args.cached else run_tasks(tasks, args.jobs, console)
    codes = sorted({r["code"] for r in results.values()})
    subset = "" if not args.ids else f" (a subset: {' '.join(c.name for c in cases)})"
    lines = [f"# Seconds per real object: SPARK's joint optimization on {bench.name}", "",
             f"{len(cases)} PartNet-Mobility objects{subset} of `../shared/partnet_dev` prepared as a benchmark "
             "(`spark-bench data prepare`, watertight R=200, 512 px); `run_ours` with the default config "
             "(annotation prior seed 0, annotation geometry, dataset open state) per method, torch 1 thread, "
             f"one object at a time; {os.cpu_count()} cores shared with other jobs (the load column: the "
             "1-min load average while they ran; wall seconds grow with it, CPU seconds hardly). Produced by "
             f"`python -m benchmarks.measure_joint_opt_real`; SPARK sources {', '.join(codes)}.", "",
             *[x for note in args.note for x in (note, "")],
             "| method | objects | optimizer CPU s | objects <= 10 s | run_ours CPU s | run_ours wall s | load |",
             "|---|---|---|---|---|---|---|"]
    for method in methods:
        rows = [r for (m, _, _), r in results.items() if m == method]
        if not rows:
            continue
        opt = [r["timings"]["optimize_cpu"] for r in rows]
        lines.append(f"| opt={method} | {len(rows)} | {_stats(opt)} | {sum(v <= TARGET_S for v in opt)} | "
                     f"{_stats([r['cpu_seconds'] for r in rows])} | {_stats([r['seconds'] for r in rows])} | "
                     f"{np.mean([r['load'] for r in rows]):.1f} |")
    lines += ["", "Per object, slowest optimizer first (the optimizer: `optimize_cpu`, the whole stage 4; "
              "`run_ours` adds loading the ground truth's meshes, the prior and writing two object folders):", ""]
    lines += per_object_lines(results, methods)
    return write_result(console, lines, f"joint_opt_speed_{bench.name}.md")


if __name__ == "__main__":
    sys.exit(main())
