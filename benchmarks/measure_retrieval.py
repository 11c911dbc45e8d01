"""How fast and how good ``--method retrieval`` is, on 2 cores.

1. **Gallery build and index**: the default procedural gallery ``synth-gallery-v1`` (21 categories x 20
   objects) generated and indexed from scratch into a temporary folder (2 worker processes), as a first
   use does. Target: <= 3 min. Wall time, the CPU time of this process and its workers, and the load
   average (other work on the machine slows the wall time, not the CPU time).
2. **Per case**: the method on every case of ``synth-v1`` and of the shared real objects
   (``../shared/real_objects`` prepared with the default options into a temporary folder, or
   ``--real-bench DIR``), the gallery and its index loaded once (as in a run). Target: <= 2 s per case.
3. **Quality**: top-1 category accuracy (the retrieved object's category is the case's), and the shape
   metrics of the leaderboard (:func:`~spark_bench.metrics.compute_metrics`, 100k samples, no
   alignment): CD and F-Score at rest, plus AxisErr / PivotErr / TypeErr, per benchmark and per category.

Run: ``python -m benchmarks.measure_retrieval [--skip-build] [--real-bench DIR] [--out FILE.md]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REAL_OBJECTS = Path(__file__).resolve().parents[1].parent / "shared" / "real_objects"


def cpu_seconds() -> float:
    """CPU time (user + system) of this process and its finished children."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def measure_build(workers: int) -> tuple[list[str], object]:
    """Generate and index the default gallery from scratch in a temporary folder."""
    from spark_bench.methods.retrieval.gallery import (
        DEFAULT_GALLERY,
        Gallery,
        GalleryObject,
        build_synth_gallery,
    )
    from spark_bench.methods.retrieval.index import build_index, index_path

    lines = ["## Gallery build and index (from scratch)", ""]
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="retrieval-gallery-") as tmp:
        folder = Path(tmp) / DEFAULT_GALLERY.name
        cpu0, t0 = cpu_seconds(), time.perf_counter()
        marker = build_synth_gallery(DEFAULT_GALLERY, folder, workers=workers)
        t_gen, cpu_gen = time.perf_counter() - t0, cpu_seconds() - cpu0
        objects = tuple(GalleryObject(i, folder / "objects" / i, v["category"], v["content_hash"])
                        for i, v in sorted(marker["objects"].items()))
        gallery = Gallery(DEFAULT_GALLERY.name, folder, objects)
        cpu1, t1 = cpu_seconds(), time.perf_counter()
        index = build_index(gallery, workers=workers)
        t_idx, cpu_idx = time.perf_counter() - t1, cpu_seconds() - cpu1
        cached = index_path(gallery, index.options)
        if not cached.is_file():  # same content as the cached gallery's: keep it for the runs below
            cached.parent.mkdir(parents=True, exist_ok=True)
            index.save(cached)
    views = index.bits.shape[1] * index.bits.shape[2]
    lines += [f"{len(objects)} objects ({len(gallery.categories())} categories), {views} views each, "
              f"{workers} worker processes; load average at start {load[0]:.1f} (2 cores).", "",
              "| Step | Wall s | CPU s |", "|---|---|---|",
              f"| generate | {t_gen:.1f} | {cpu_gen:.1f} |", f"| index | {t_idx:.1f} | {cpu_idx:.1f} |",
              f"| **total** | **{t_gen + t_idx:.1f}** | {cpu_gen + cpu_idx:.1f} |", ""]
    return lines, gallery


def run_benchmark(folder: Path, name: str, method) -> list[dict]:
    """The method on every case of a benchmark; one row per case."""
    from spark_bench.data.case import Benchmark
    from spark_bench.data.readers import load_object
    from spark_bench.methods.base import CaseInput
    from spark_bench.metrics import compute_metrics

    rows = []
    for case in Benchmark(folder).cases():
        with tempfile.TemporaryDirectory(prefix="retrieval-case-") as out:
            start = time.perf_counter()
            generation = method.generate(CaseInput(case, frozenset(method.inputs)), Path(out))
            seconds = time.perf_counter() - start
            metrics = compute_metrics(load_object(out), case.load_gt(), workers=2).to_dict()
        info = generation.info["retrieval"]
        rows.append({"bench": name, "case": case.id, "category": case.category, "retrieved": info["object_id"],
                     "retrieved_category": info["category"], "yaw": info["yaw_deg"], "seconds": seconds,
                     "check": generation.info["gallery_check"]["status"], "cd": metrics["cd"],
                     "f01": metrics["fscore@0.1"], "f05": metrics["fscore@0.5"], "axis": metrics["axis_err"],
                     "pivot": metrics["pivot_err"], "type": metrics["type_err"]})
        print(f"{name} {case.id}: {info['object_id']} ({seconds:.2f} s, CD {metrics['cd']:.4f})", file=sys.stderr)
    return rows


def _mean(values) -> str:
    values = [v for v in values if v is not None and np.isfinite(v)]
    return f"{np.mean(values):.4f}" if values else "n/a"


def report(rows: list[dict], name: str, gallery_categories: set[str]) -> list[str]:
    seconds = np.array([r["seconds"] for r in rows])
    known = [r for r in rows if r["category"] in gallery_categories]
    correct = sum(r["retrieved_category"] == r["category"] for r in known)
    lines = [f"## {name}: {len(rows)} cases", "",
             f"- per case: mean {seconds.mean():.2f} s, median {np.median(seconds):.2f} s, max {seconds.max():.2f} s "
             f"(first case includes loading the index)",
             f"- top-1 category accuracy: **{correct}/{len(known)} = {correct / max(1, len(known)):.3f}**"
             + (f" ({len(rows) - len(known)} case(s) of a category the gallery lacks left out)"
                if len(known) < len(rows) else ""),
             f"- gallery check: {', '.join(sorted({r['check'] for r in rows}))}", "",
             "| Category | Cases | Top-1 | CD↓ | F-Score@0.1↑ | F-Score@0.5↑ | AxisErr↓ | PivotErr↓ | TypeErr↓ |",
             "|---|---|---|---|---|---|---|---|---|"]
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r["category"], []).append(r)
    for category, items in [*sorted(groups.items()), ("**all**", rows)]:
        hits = sum(r["retrieved_category"] == r["category"] for r in items)
        lines.append(f"| {category} | {len(items)} | {hits}/{len(items)} | {_mean(r['cd'] for r in items)} | "
                     f"{_mean(r['f01'] for r in items)} | {_mean(r['f05'] for r in items)} | "
                     f"{_mean(r['axis'] for r in items)} | {_mean(r['pivot'] for r in items)} | "
                     f"{_mean(r['type'] for r in items)} |")
    lines += ["", "<details><summary>per case</summary>", "", "| Case | Retrieved | Yaw° | s | CD |", "|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['retrieved']} | {r['yaw']:.1f} | {r['seconds']:.2f} | {r['cd']:.4f} |" for r in rows]
    return lines + ["", "</details>", ""]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="processes for the gallery build (default 2)")
    parser.add_argument("--skip-build", action="store_true", help="do not time a build from scratch")
    parser.add_argument("--real-bench", type=Path, help="an already prepared benchmark of the real objects")
    parser.add_argument("--no-real", action="store_true", help="skip the shared real objects")
    parser.add_argument("--no-synth", action="store_true", help="skip synth-v1")
    parser.add_argument("--out", type=Path, help="also write the report (markdown) here")
    args = parser.parse_args(argv)
    os.environ.setdefault("MUJOCO_GL", "egl")

    from spark_bench.data.benchmarks import ensure_benchmark
    from spark_bench.methods.retrieval.gallery import open_gallery
    from spark_bench.methods.retrieval.index import gallery_index
    from spark_bench.methods.retrieval.method import RetrievalMethod

    lines = ["# Retrieval (`--method retrieval`, gallery synth-gallery-v1)", ""]
    if not args.skip_build:
        build_lines, _ = measure_build(args.workers)
        lines += build_lines
    method = RetrievalMethod()
    start = time.perf_counter()
    gallery = open_gallery(None, workers=args.workers)
    gallery_index(gallery, method.options.index, workers=args.workers)
    lines += [f"Gallery and index ready (cache) in {time.perf_counter() - start:.2f} s; "
              f"gallery hash `{gallery.content_hash[:16]}`.", ""]
    categories = set(gallery.categories())
    if not args.no_synth:
        lines += report(run_benchmark(ensure_benchmark("synth-v1", progress=False), "synth-v1", method),
                        "synth-v1", categories)
    if not args.no_real:
        if args.real_bench:
            lines += report(run_benchmark(args.real_bench, "real", method), "shared real objects", categories)
        elif REAL_OBJECTS.is_dir():
            from spark_bench.data.prepare import prepare_benchmark

            with tempfile.TemporaryDirectory(prefix="retrieval-real-") as tmp:
                prepare_benchmark(REAL_OBJECTS, Path(tmp) / "real", progress=False, name="real")
                lines += report(run_benchmark(Path(tmp) / "real", "real", method), "shared real objects",
                                categories)
        else:
            lines += [f"(shared real objects not found at {REAL_OBJECTS})", ""]
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
