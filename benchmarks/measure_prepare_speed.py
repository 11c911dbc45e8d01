"""``data prepare`` now against an earlier revision: CPU seconds per object and the same ground truth.

For every object (default: the seven of ``../shared/real_objects``; ``--src ../shared/partnet_dev --ids
...`` for others) this script runs :func:`spark_bench.data.prepare.prepare_case` (R=200 watertight
remesh, 512 px renders) in a child process twice: with the package of this checkout, and with the
package of the git revision ``--baseline`` (extracted with ``git archive`` into a temporary folder; the
working tree is not touched). Each child reports the CPU seconds (``time.process_time``: every thread
of the process) and wall seconds of each stage and of the whole call, imports excluded. The ground
truth each wrote (every file under the case's ``gt`` folder) is compared byte for byte.

CPU seconds are the number to compare on a shared machine: wall seconds depend on what else runs
(the script says how loaded the machine was). Writes ``benchmarks/results/prepare_speed.md``.

Run: ``nice -n 10 python benchmarks/measure_prepare_speed.py [--ids 47645 7179] [--baseline REV]``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REAL_OBJECTS = ROOT.parent / "shared" / "real_objects"
RESULTS = ROOT / "benchmarks" / "results" / "prepare_speed.md"
#: The revision before the watertight speed-up of issue #12: the code whose prepare time the issue measured.
BASELINE = "9813d43^"
#: Text of the report below this line is written by people (analysis) and kept on a rewrite.
NOTES = "<!-- notes: kept when the script rewrites the file -->"

#: Run in the child: prepare one object with the package on ``sys.path`` and print its timings as JSON.
CHILD = r"""
import contextlib, json, sys, time
from spark_bench.data.prepare import PrepareOptions, prepare_case

class Timer:
    def __init__(self):
        self.seconds, self.cpu = {}, {}
    @contextlib.contextmanager
    def __call__(self, stage):
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - wall
            self.cpu[stage] = self.cpu.get(stage, 0.0) + time.process_time() - cpu

src, out, resolution, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
timer = Timer()
wall, cpu = time.perf_counter(), time.process_time()
prepare_case(src, out, PrepareOptions(image_size=size, resolution=resolution), "case", timer)
print(json.dumps({"wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu,
                  "stage_cpu": timer.cpu, "stage_wall": timer.seconds}))
"""


def extract(revision: str, into: Path) -> Path:
    """The ``spark_bench`` package of ``revision`` under ``into`` (``git archive``, no checkout)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "spark_bench"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def prepare_in_child(package_root: Path, src: Path, out: Path, resolution: int, size: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(package_root))
    proc = subprocess.run([sys.executable, "-c", CHILD, str(src), str(out), str(resolution), str(size)],
                          capture_output=True, text=True, env=env, cwd=str(out.parent))
    if proc.returncode != 0:
        raise RuntimeError(f"prepare of {src.name} with {package_root} failed: {proc.stderr.strip()[-500:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def tree_digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, default=REAL_OBJECTS, help="folder of object folders")
    parser.add_argument("--ids", nargs="*", default=None, help="object ids (default: all in --src)")
    parser.add_argument("--baseline", default=BASELINE, help="git revision to compare with")
    parser.add_argument("--resolution", type=int, default=200)
    parser.add_argument("--image-size", type=int, default=512)
    parser.add_argument("--out", type=Path, default=RESULTS, help="Markdown report ('-': none)")
    args = parser.parse_args(argv)
    if not args.src.is_dir():
        print(f"skipped: {args.src} is absent")
        return 0
    ids = args.ids or sorted(p.name for p in args.src.iterdir() if (p / "mobility.urdf").is_file())
    load_before = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory(prefix="spark_prepare_speed_") as tmp:
        tmp = Path(tmp)
        (tmp / "baseline").mkdir()
        baseline = extract(args.baseline, (tmp / "baseline").resolve())
        for object_id in ids:
            row = {"id": object_id}
            for name, package in (("before", baseline), ("now", ROOT)):
                out = tmp / name / object_id
                out.parent.mkdir(parents=True, exist_ok=True)
                row[name] = prepare_in_child(package, args.src / object_id, out, args.resolution, args.image_size)
                row[f"{name}_gt"] = tree_digest(out / "gt")
            row["same_gt"] = row["before_gt"] == row["now_gt"]
            rows.append(row)
            print(f"{object_id:>7}: CPU {row['before']['cpu']:6.1f} s -> {row['now']['cpu']:6.1f} s "
                  f"({row['before']['cpu'] / row['now']['cpu']:.2f}x); wall {row['before']['wall']:6.1f} -> "
                  f"{row['now']['wall']:6.1f} s; ground truth {'identical' if row['same_gt'] else 'DIFFERS'}",
                  flush=True)
    load_after = os.getloadavg()[0]
    stages = sorted({k for r in rows for k in r["now"]["stage_cpu"]})
    total_before = sum(r["before"]["cpu"] for r in rows)
    total_now = sum(r["now"]["cpu"] for r in rows)
    lines = ["# `data prepare`: speed against the code the issue measured", "",
             f"Written by `benchmarks/measure_prepare_speed.py` ({time.strftime('%Y-%m-%d %H:%M')}): "
             f"`prepare_case` at R={args.resolution}, {args.image_size} px, each object in a child process "
             f"with this checkout's package and with `{args.baseline}`'s (git archive). CPU seconds are "
             f"`time.process_time` of the call (all threads; imports excluded). The machine "
             f"({os.cpu_count()} cores) was shared with other work: load average {load_before:.1f} before, "
             f"{load_after:.1f} after, so wall seconds are inflated and only the CPU seconds compare.", "",
             "| object | CPU s before | CPU s now | ratio | wall s before | wall s now | ground truth |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['before']['cpu']:.2f} | {r['now']['cpu']:.2f} | "
                     f"{r['before']['cpu'] / r['now']['cpu']:.2f}x | {r['before']['wall']:.1f} | "
                     f"{r['now']['wall']:.1f} | {'identical' if r['same_gt'] else 'differs'} |")
    lines += ["", f"All objects: CPU {total_before:.1f} s before, {total_now:.1f} s now: "
              f"{total_before / max(total_now, 1e-9):.2f}x. Ground truth byte-identical for "
              f"{sum(r['same_gt'] for r in rows)}/{len(rows)} objects.", "",
              "CPU seconds per stage, summed over the objects (before -> now): " + ", ".join(
                  f"{k} {sum(r['before']['stage_cpu'].get(k, 0.0) for r in rows):.1f} -> "
                  f"{sum(r['now']['stage_cpu'].get(k, 0.0) for r in rows):.1f}" for k in stages)]
    text = "\n".join(lines) + "\n"
    print(text)
    if str(args.out) != "-":
        args.out.parent.mkdir(parents=True, exist_ok=True)
        old = args.out.read_text() if args.out.is_file() else ""
        notes = old[old.index(NOTES):] if NOTES in old else f"{NOTES}\n"
        args.out.write_text(text + "\n" + notes)  # the notes below the marker are kept
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
