"""Exact boxes against CoACD on orthogonal parts (issue 37, conv-8), measured in the same run.

For the ground truth of each of the first N cases of ``synth-v1`` (built into a fresh home), its link meshes
alone, without its ``<collision>`` boxes (what the main job's predictions carry: ``ours`` with ground-truth
geometry writes no collision geometry), the sim checks run twice from an empty cache:
with conv-8's conversion (a non-convex part that is an orthogonal polyhedron cut exactly into boxes,
:mod:`spark_bench.sim.boxes`) and with every non-convex part sent to CoACD (``ConvertOptions(exact_boxes=False)``,
conv-7's hulls). Per case and summed: CPU seconds of the checks (this process and its CoACD workers), parts
boxed, CoACD calls, hulls, the parent-child pairs excluded from contact because their hulls overlap at rest, and
the verdicts. Writes ``benchmarks/results/boxes.md`` and ``boxes.json``.

Run: ``python -m benchmarks.measure_boxes [--cases 50] [--out benchmarks/results/boxes.md]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

from tqdm import tqdm

from benchmarks.measure_convert import cpu_seconds

RESULTS = Path(__file__).resolve().parent / "results"


def visual_only(case) -> object:
    """The case's ground truth with its ``<collision>`` boxes dropped: its link meshes alone, as a method
    that writes no collision geometry gives them (``ours`` with ``geometry=annotation``, the main job)."""
    asset = case.load_gt()
    for link in asset.links.values():
        link.collisions = []
    return asset


def checked(asset, exact_boxes: bool) -> dict:
    """The sim checks of ``asset`` from an empty cache, converted with or without exact boxes."""
    from spark_bench.sim import run_checks
    from spark_bench.sim.options import ConvertOptions

    start = cpu_seconds()
    report = run_checks(asset, options=ConvertOptions(exact_boxes=exact_boxes, use_cache=False))
    cpu = cpu_seconds() - start
    compiled = report.checks["mjcf_compiles"].details
    return {"cpu_s": round(cpu, 2), "passed": bool(report.passed), "failures": report.failures(),
            "boxed": compiled.get("boxed", 0), "coacd_calls": compiled.get("coacd_calls", 0),
            "hulls": sum((compiled.get("hulls") or {}).values()), "excluded": compiled.get("excluded", []),
            "sweep": report.checks["joint_sweep"].value}


def measure(n: int, work: Path) -> list[dict]:
    """Both conversions of the ground truth of each of the first ``n`` cases of ``synth-v1``, built into the
    empty home ``work``, alternating which runs first."""
    os.environ["SPARK_BENCH_HOME"] = str(work)
    from spark_bench.data.benchmarks import ensure_benchmark
    from spark_bench.data.case import Benchmark

    bench = Benchmark(ensure_benchmark("synth-v1", progress=False))
    rows = []
    for index, case_id in enumerate(tqdm(bench.case_ids()[:n], desc="cases")):
        order = (True, False) if index % 2 == 0 else (False, True)  # neither side always runs on a warm process
        runs = {("boxes" if flag else "coacd"): checked(visual_only(bench.case(case_id)), flag) for flag in order}
        rows.append({"case": case_id, **runs})
    return rows


def summary(rows: list[dict]) -> dict:
    """Sums and counts over the cases."""
    def total(side: str, key: str) -> float:
        return round(sum(r[side][key] for r in rows), 2)

    return {
        "cases": len(rows),
        "cpu_s": {side: total(side, "cpu_s") for side in ("boxes", "coacd")},
        "coacd_calls": {side: total(side, "coacd_calls") for side in ("boxes", "coacd")},
        "boxed": total("boxes", "boxed"),
        "hulls": {side: total(side, "hulls") for side in ("boxes", "coacd")},
        "cases_with_excluded_pairs": {side: sum(bool(r[side]["excluded"]) for r in rows) for side in ("boxes", "coacd")},
        "passed": {side: sum(r[side]["passed"] for r in rows) for side in ("boxes", "coacd")},
        "verdicts_differ": [r["case"] for r in rows if r["boxes"]["passed"] != r["coacd"]["passed"]],
    }


def markdown(rows: list[dict], total: dict, commit: str) -> str:
    ratio = total["cpu_s"]["coacd"] / max(total["cpu_s"]["boxes"], 1e-9)
    lines = [
        "# Exact boxes against CoACD on `synth-v1`'s ground truth (conv-8)", "",
        "Written by `benchmarks/measure_boxes.py` (issue 37). Each case's sim checks from an empty cache, converted",
        "with exact boxes for orthogonal parts (conv-8) and with CoACD for every non-convex part (conv-7's hulls),",
        "in the same run, alternating which goes first. CPU s: this process and its CoACD workers.", "",
        f"- code: commit {commit}",
        f"- cases: the ground truth of the first {total['cases']} cases of `synth-v1`, its link meshes without its "
        "`<collision>` boxes (as the main job's predictions carry them)", "",
        "| | exact boxes (conv-8) | CoACD (conv-7) |", "|---|---|---|",
        f"| CPU s, all checks | {total['cpu_s']['boxes']} | {total['cpu_s']['coacd']} |",
        f"| CoACD calls | {total['coacd_calls']['boxes']} | {total['coacd_calls']['coacd']} |",
        f"| parts cut into boxes | {total['boxed']} | 0 |",
        f"| collision hulls | {total['hulls']['boxes']} | {total['hulls']['coacd']} |",
        f"| cases with a parent-child pair excluded (hulls overlap at rest) | "
        f"{total['cases_with_excluded_pairs']['boxes']} | {total['cases_with_excluded_pairs']['coacd']} |",
        f"| cases passing every check | {total['passed']['boxes']} | {total['passed']['coacd']} |", "",
        f"**CoACD's checks took {ratio:.1f}x the CPU of the exact boxes'.** Verdicts that differ: "
        f"{', '.join(total['verdicts_differ']) or 'none'}.", "",
        "| case | CPU s boxes / CoACD | boxed | CoACD calls boxes / CoACD | excluded pairs boxes / CoACD | passed |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        b, c = r["boxes"], r["coacd"]
        lines.append(f"| {r['case']} | {b['cpu_s']} / {c['cpu_s']} | {b['boxed']} | {b['coacd_calls']} / "
                     f"{c['coacd_calls']} | {len(b['excluded'])} / {len(c['excluded'])} | {b['passed']} / {c['passed']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=50, help="synth-v1 cases to check (50: all)")
    parser.add_argument("--out", type=Path, default=RESULTS / "boxes.md", help="report (JSON beside it)")
    args = parser.parse_args(argv)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip() or "unknown"
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="spark_boxes_") as tmp:
        rows = measure(args.cases, Path(tmp))
    total = summary(rows)
    total["wall_s"] = round(time.perf_counter() - started, 1)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(markdown(rows, total, commit))
    args.out.with_suffix(".json").write_text(json.dumps({"summary": total, "cases": rows}, indent=1) + "\n")
    print(json.dumps(total, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
