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

The checkout's run renders from the source meshes (the default of
:class:`~spark_bench.data.prepare.PrepareOptions`, as SPARK renders; ``--render-mesh watertight`` for the
remesh); the script also measures how its images differ from the baseline's (whose renders are of the
watertight ground truth): foreground-mask IoU, per-pixel part-label agreement and mean absolute RGB
difference (0-255) of each rendered state.

The checkout's ``prepare_case`` runs with one BLAS thread; ``--baseline-blas-threads 1`` gives the
baseline the same, to separate that from the rest of the speed-up.

Run: ``nice -n 10 python -m benchmarks.measure_prepare_speed [--ids 47645 7179] [--baseline REV]
[--render-mesh watertight] [--baseline-blas-threads 1] [--src FOLDER_OF_OBJECTS]``.
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

import numpy as np

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
extra = {"render_mesh": sys.argv[5]} if len(sys.argv) > 5 else {}
timer = Timer()
wall, cpu = time.perf_counter(), time.process_time()
prepare_case(src, out, PrepareOptions(image_size=size, resolution=resolution, **extra), "case", timer)
print(json.dumps({"wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu,
                  "stage_cpu": timer.cpu, "stage_wall": timer.seconds}))
"""


def extract(revision: str, into: Path) -> Path:
    """The ``spark_bench`` package of ``revision`` under ``into`` (``git archive``, no checkout)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "spark_bench"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def prepare_in_child(package_root: Path, src: Path, out: Path, resolution: int, size: int,
                     render_mesh: str | None = None, blas_threads: int | None = None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(package_root))
    if blas_threads:  # the checkout limits its own BLAS threads; this gives the baseline the same limit
        env.update({k: str(blas_threads) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")})
    extra = [render_mesh] if render_mesh else []
    proc = subprocess.run([sys.executable, "-c", CHILD, str(src), str(out), str(resolution), str(size), *extra],
                          capture_output=True, text=True, env=env, cwd=str(out.parent))
    if proc.returncode != 0:
        raise RuntimeError(f"prepare of {src.name} with {package_root} failed: {proc.stderr.strip()[-500:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def tree_digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def render_difference(before: Path, now: Path) -> dict[str, dict[str, float]]:
    """Per rendered state of two case folders: foreground IoU, part-label agreement, mean |RGB| difference."""
    from PIL import Image

    from spark_bench.data.case import BenchmarkCase
    from spark_bench.data.prepare import read_segmentation

    out = {}
    for state in ("input", "open"):
        (rgb_a, seg_a), (rgb_b, seg_b) = BenchmarkCase(before).state_files(state), BenchmarkCase(now).state_files(state)
        labels_a, labels_b = read_segmentation(seg_a), read_segmentation(seg_b)
        fg_a, fg_b = labels_a > 0, labels_b > 0
        rgb_a = np.asarray(Image.open(rgb_a).convert("RGB"), dtype=np.int16)
        rgb_b = np.asarray(Image.open(rgb_b).convert("RGB"), dtype=np.int16)
        out[state] = {"iou": float((fg_a & fg_b).sum() / max(int((fg_a | fg_b).sum()), 1)),
                      "labels": float((labels_a == labels_b).mean()),
                      "mad": float(np.abs(rgb_a - rgb_b).mean()),
                      "identical": bool(np.array_equal(rgb_a, rgb_b) and np.array_equal(labels_a, labels_b))}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, default=REAL_OBJECTS, help="folder of object folders")
    parser.add_argument("--ids", nargs="*", default=None, help="object ids (default: all in --src)")
    parser.add_argument("--baseline", default=BASELINE, help="git revision to compare with")
    parser.add_argument("--resolution", type=int, default=200)
    parser.add_argument("--image-size", type=int, default=512)
    parser.add_argument("--render-mesh", default=None, choices=("watertight", "source"),
                        help="PrepareOptions.render_mesh of the checkout's run (default: the option's default)")
    parser.add_argument("--baseline-blas-threads", type=int, default=None,
                        help="BLAS threads of the baseline's child (default: the library's default; the "
                             "checkout runs prepare_case with one)")
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
                row[name] = prepare_in_child(package, args.src / object_id, out, args.resolution, args.image_size,
                                             args.render_mesh if name == "now" else None,
                                             args.baseline_blas_threads if name == "before" else None)
                row[f"{name}_gt"] = tree_digest(out / "gt")
            row["same_gt"] = row["before_gt"] == row["now_gt"]
            row["renders"] = render_difference(tmp / "before" / object_id, tmp / "now" / object_id)
            rows.append(row)
            print(f"{object_id:>7}: CPU {row['before']['cpu']:6.1f} s -> {row['now']['cpu']:6.1f} s "
                  f"({row['before']['cpu'] / row['now']['cpu']:.2f}x); wall {row['before']['wall']:6.1f} -> "
                  f"{row['now']['wall']:6.1f} s; ground truth {'identical' if row['same_gt'] else 'DIFFERS'}; "
                  f"render IoU {min(d['iou'] for d in row['renders'].values()):.4f}",
                  flush=True)
    load_after = os.getloadavg()[0]
    from spark_bench.data.prepare import RENDER_MESHES
    stages = sorted({k for r in rows for k in r["now"]["stage_cpu"]})
    total_before = sum(r["before"]["cpu"] for r in rows)
    total_now = sum(r["now"]["cpu"] for r in rows)
    lines = ["# `data prepare`: speed against the code the issue measured", "",
             f"Written by `benchmarks/measure_prepare_speed.py` ({time.strftime('%Y-%m-%d %H:%M')}): "
             f"`prepare_case` at R={args.resolution}, {args.image_size} px, each object in a child process "
             f"with this checkout's package and with `{args.baseline}`'s (git archive"
             + (f", {args.baseline_blas_threads} BLAS thread(s)" if args.baseline_blas_threads else "")
             + "). CPU seconds are "
             f"`time.process_time` of the call (all threads; imports excluded). The machine "
             f"({os.cpu_count()} cores) was shared with other work: load average {load_before:.1f} before, "
             f"{load_after:.1f} after, so wall seconds are inflated and only the CPU seconds compare. "
             f"Objects: `{args.src}`; the checkout renders from the "
             f"`{args.render_mesh or 'default (' + RENDER_MESHES[0] + ')'}` meshes. Renders: IoU of the foreground masks, "
             f"share of pixels with the same part label, mean absolute RGB difference (0-255), now against "
             f"before, input/open state.", "",
             "| object | CPU s before | CPU s now | ratio | wall s before | wall s now | ground truth "
             "| mask IoU | same label | RGB MAD |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["renders"]
        lines.append(f"| {r['id']} | {r['before']['cpu']:.2f} | {r['now']['cpu']:.2f} | "
                     f"{r['before']['cpu'] / r['now']['cpu']:.2f}x | {r['before']['wall']:.1f} | "
                     f"{r['now']['wall']:.1f} | {'identical' if r['same_gt'] else 'differs'} | "
                     + " | ".join("/".join(f"{d[s][k]:.{p}f}" for s in ("input", "open"))
                                  for k, p in (("iou", 4), ("labels", 4), ("mad", 2))) + " |")
    lines += ["", f"All objects: CPU {total_before:.1f} s before, {total_now:.1f} s now: "
              f"{total_before / max(total_now, 1e-9):.2f}x. Ground truth byte-identical for "
              f"{sum(r['same_gt'] for r in rows)}/{len(rows)} objects. Mask IoU over all images: min "
              f"{min(d['iou'] for r in rows for d in r['renders'].values()):.4f}, mean "
              f"{np.mean([d['iou'] for r in rows for d in r['renders'].values()]):.4f}; RGB MAD max "
              f"{max(d['mad'] for r in rows for d in r['renders'].values()):.2f}; images identical (RGB and "
              f"labels) for {sum(d['identical'] for r in rows for d in r['renders'].values())}/{2 * len(rows)}.",
              "",
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
