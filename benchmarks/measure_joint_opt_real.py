"""Seconds per real object of SPARK's joint optimization, ``opt=spark`` and ``opt=native``, on
``../shared/partnet_dev`` prepared as a benchmark (75 PartNet-Mobility objects; aim: <= 10 s each on 2
cores).

    python benchmarks/measure_joint_opt_real.py                      # prepares partnet_dev once, then times
    python benchmarks/measure_joint_opt_real.py --bench /path/to/prepared --limit 10

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

sys.path.insert(0, str(Path(__file__).parent))
from measure_joint_opt import VARIANTS, case_dirs, run_tasks  # noqa: E402

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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", default=None, help="a prepared benchmark folder (default: partnet_dev, prepared once)")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--methods", default="spark,native")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--work", default="~/.cache/spark-bench/measure_joint_opt_real")
    args = parser.parse_args(argv)
    console = Console()
    bench = prepared(args.bench, console)
    cases = case_dirs(bench, args.limit)
    methods = [m for m in args.methods.split(",") if m]
    work = Path(args.work).expanduser() / bench.name
    tasks = [((m, 0, c.name), str(c), str(work / m / c.name), list(VARIANTS[m]), 0, False)
             for m in methods for c in cases]
    results = run_tasks(tasks, args.jobs, console)
    lines = [f"# Seconds per real object: SPARK's joint optimization on {bench.name}", "",
             f"{len(cases)} PartNet-Mobility objects of `../shared/partnet_dev` prepared as a benchmark "
             "(`spark-bench data prepare`, watertight R=200, 512 px); `run_ours` with the default config "
             "(annotation prior seed 0, annotation geometry, dataset open state) per method, torch 1 thread, "
             f"one object at a time; {os.cpu_count()} cores shared with other jobs. Produced by "
             "`python benchmarks/measure_joint_opt_real.py`.", "",
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
    lines += ["", "Slowest objects (optimizer CPU s, movable joints, revolute joints fitted by opt=spark):", ""]
    for method in methods:
        rows = sorted((r for (m, _, _), r in results.items() if m == method),
                      key=lambda r: -r["timings"]["optimize_cpu"])[:5]
        lines.append(f"- opt={method}: " + ", ".join(
            f"{r['case']} ({r['category']}) {r['timings']['optimize_cpu']:.1f} s, {r['n_joints']} joints"
            for r in rows))
    text = "\n".join(lines) + "\n"
    console.print(text)
    out = Path(__file__).parent / "results" / f"joint_opt_speed_{bench.name}.md"
    out.write_text(text)
    console.print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
