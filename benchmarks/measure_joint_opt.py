"""SPARK's joint optimization like for like with the paper's Table 4: the prior, ``opt=spark``,
``opt=native`` and ``opt=native,sup=part-masks`` on a benchmark, mean +- std over prior seeds; the
toy cabinets' timing; the render-size study of ``opt=spark``.

    PYTHONPATH=tests python -m benchmarks.measure_joint_opt                  # toy cabinets (offline; tests/helpers_toy)
    python -m benchmarks.measure_joint_opt --bench synth-v1 --seeds 5        # Table 4, 4 rows x 5 seeds
    python -m benchmarks.measure_joint_opt --bench synth-v1 --calibrate      # fit the prior's noise first
    python -m benchmarks.measure_joint_opt --bench synth-v1 --spark-sizes 64,128,256 --limit 20
    python -m benchmarks.measure_joint_opt --bench synth-v1 --seeds 5 --ids A B ... --cached   # report only

Benchmark mode runs ``run_ours`` (annotation prior and geometry, dataset open state: the default
config, with ``prior.noise.seed`` = each seed and each variant's method) on every case, scores its
``prior/`` and refined objects with :func:`spark_bench.metrics.compute_metrics` (Hungarian matching),
and writes ``benchmarks/results/table4_<bench>.md``: each row's AxisErr / PivotErr / TypeErr as the
mean over objects (the paper's and the leaderboard's average) and over joints, each mean +- std over
the seeds, beside the paper's rows; the per-category means; the seconds per object. One prior seed is
one ``eval``; the rows differ only in the optimizer (the same prior draw per seed). Per-case results
are cached under ``--work`` (resumable; stale when the SPARK sources change; ``--cached`` reports the
cached runs of the same configuration whatever sources made them, and names those sources). Runs go
case by case (every seed and row of one case before the next), so a run cut short leaves whole cases,
which ``--cached --ids`` reports.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from rich.console import Console

from benchmarks.joint_opt_runs import (
    KEYS,
    RESULTS,
    VARIANTS,
    cached_results,
    case_dirs,
    resolve_bench,
    run_tasks,
    write_result,
)

#: The rows' names in the report.
ROW_LABELS = {"prior": "prior (w/o joint optimization)", "spark": "opt=spark", "native": "opt=native",
              "native-masks": "opt=native,sup=part-masks"}
#: The paper's Table 4 (URDF ablation).
PAPER_ROWS = {"paper: w/o joint optimization": (0.3148, 0.2388, 0.20), "paper: full model": (0.1577, 0.1653, 0.05)}


# ----- aggregation ---------------------------------------------------------------------------------
def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def row_means(rows: list[dict], variant: str) -> dict:
    """Per-object and per-joint means of one seed's rows (``variant``: ``prior`` or ``refined``)."""
    out = {f"{k}": _mean(r["scores"][variant][k] for r in rows) for k in KEYS}
    records = [j for r in rows for j in r["joints"][variant]]
    out.update({f"joint_{k}": _mean(j[k] for j in records) for k in KEYS})
    return out


def seed_table(results: dict[tuple, dict], variants: list[str], seeds: list[int]) -> dict[str, dict]:
    """Row -> metric -> list of per-seed means (the prior from the first variant's ``prior/``)."""
    out: dict[str, dict] = {}
    for row_name in ["prior", *variants]:
        source, variant = (variants[0], "prior") if row_name == "prior" else (row_name, "refined")
        per_metric = defaultdict(list)
        for seed in seeds:
            rows = [r for (v, s, _), r in results.items() if v == source and s == seed and variant in r["scores"]]
            if rows:
                for k, value in row_means(rows, variant).items():
                    per_metric[k].append(value)
        out[row_name] = dict(per_metric)
    return out


def _pm(values) -> str:
    values = [v for v in values if v is not None]
    if not values:
        return "n/a"
    return f"{np.mean(values):.4f} ± {np.std(values):.4f}" if len(values) > 1 else f"{values[0]:.4f}"


def _stats(values) -> str:
    values = np.asarray(values, float)
    return f"median {np.median(values):.1f}, mean {values.mean():.1f}, max {values.max():.1f}" if len(values) else "n/a"


def markdown(bench: str, n_cases: int, table: dict, results: dict, variants: list[str], seeds: list[int],
             notes: list[str]) -> str:
    """Table 4 (rows +- std over seeds, beside the paper's), the per-category means and the times."""
    from spark_bench import CONVENTION_VERSION

    lines = [f"# Table 4 on {bench}: joint optimization, like for like with the paper", "",
             f"Benchmark `{bench}` ({n_cases} cases), method `ours` (prior=annotation, geometry=annotation, "
             f"open=dataset), prior seeds {seeds[0]}-{seeds[-1]} ({len(seeds)}): each cell is the mean ± std "
             f"over the seeds of the benchmark's mean; metrics `{CONVENTION_VERSION}` "
             "(`spark_bench.metrics.compute_metrics`, Hungarian part matching; PivotErr as FreeArt3D: every "
             "ground-truth revolute joint's line distance, whatever the predicted type).", "",
             *[x for note in notes for x in (note, "")],
             "| row | AxisErr | PivotErr | TypeErr | AxisErr per joint | PivotErr per joint | TypeErr per joint |",
             "|---|---|---|---|---|---|---|"]
    for name, values in PAPER_ROWS.items():
        lines.append(f"| {name} | " + " | ".join(f"{v:.4f}" for v in values) + " | | | |")
    for name in ["prior", *variants]:
        row = table.get(name, {})
        cells = [_pm(row.get(k, [])) for k in KEYS] + [_pm(row.get(f"joint_{k}", [])) for k in KEYS]
        lines.append(f"| {ROW_LABELS[name]} | " + " | ".join(cells) + " |")
    lines += ["", "Per object: the mean of each object's own mean over its joints, then over objects (the "
              "paper's and the leaderboard's average); per joint: every joint weighs the same.", ""]
    lines += goal_lines(table)
    lines += ["", "## Per category (mean over objects and seeds): "
              + " / ".join(ROW_LABELS[name] for name in ["prior", *variants]), "",
              "| category | objects | AxisErr | PivotErr | TypeErr |", "|---|---|---|---|---|"]
    lines += category_lines(results, variants)
    lines += ["", "## Seconds per object", ""] + time_lines(results, variants)
    return "\n".join(lines) + "\n"


def goal_lines(table: dict) -> list[str]:
    """Where ``opt=native`` (whole silhouette) stands against the paper's full model."""
    row = table.get("native")
    if not row:
        return []
    paper = PAPER_ROWS["paper: full model"]
    out = ["Goal, `opt=native` (whole silhouette) below the paper's full model (per object):"]
    for key, target in zip(KEYS, paper):
        values = [v for v in row.get(key, []) if v is not None]
        if not values:
            continue
        mean = float(np.mean(values))
        verdict = "below" if mean < target else f"above by {mean - target:.4f} ({100 * (mean - target) / target:.0f} %)"
        out.append(f"- {key}: {mean:.4f} vs {target:.4f}: {verdict}")
    return out


def category_lines(results: dict, variants: list[str]) -> list[str]:
    groups: dict[str, dict] = defaultdict(lambda: defaultdict(list))
    for (variant, _, _), row in results.items():
        groups[row["category"]][variant].append(row)
        if variant == variants[0] and "prior" in row["scores"]:
            groups[row["category"]]["prior"].append(row)
    out = []
    for category, by_row in sorted(groups.items()):
        n = len({r["case"] for r in by_row.get(variants[0], [])})
        cells = []
        for key in KEYS:
            parts = []
            for name in ["prior", *variants]:
                source = "prior" if name == "prior" else "refined"
                value = _mean(r["scores"][source][key] for r in by_row.get(name, []))
                parts.append("n/a" if value is None else f"{value:.3f}")
            cells.append(" / ".join(parts))
        out.append(f"| {category} | {n} | " + " | ".join(cells) + " |")
    return out


def time_lines(results: dict, variants: list[str]) -> list[str]:
    out = []
    for variant in variants:
        rows = [r for (v, _, _), r in results.items() if v == variant]
        if not rows:
            continue
        opt = [r["timings"].get("opt_fit_cpu", r["timings"].get("opt_discrete_search_cpu", 0.0)
                                + r["timings"].get("opt_final_fit_cpu", 0.0)) for r in rows]
        out.append(f"- {ROW_LABELS[variant]}: run_ours CPU s {_stats([r['cpu_seconds'] for r in rows])}; wall s "
                   f"{_stats([r['seconds'] for r in rows])}; the optimizer's CPU s {_stats(opt)} "
                   f"({len(rows)} runs, torch 1 thread; 1-min load average while they ran: mean "
                   f"{np.mean([r['load'] for r in rows]):.1f} on {os.cpu_count()} cores)")
    return out


# ----- the render-size study of opt=spark ----------------------------------------------------------
def sizes_main(args, console: Console) -> int:
    """``opt=spark`` at several render sizes on the same priors: PivotErr and the fitted pivots' spread."""
    bench = resolve_bench(args.bench)
    cases = case_dirs(bench, args.limit)
    sizes = [int(s) for s in args.spark_sizes.split(",")]
    work = Path(args.work).expanduser() / bench.name / "sizes"
    tasks = [((f"size{size}", 0, c.name), str(c), str(work / f"size{size}" / c.name),
              ["optimize.method=spark", f"optimize.spark.size={size}", *args.set], args.n_samples, False)
             for size in sizes for c in cases]
    results = run_tasks(tasks, args.jobs, console)
    reference = {k[2]: r for k, r in results.items() if k[0] == f"size{max(sizes)}"}
    lines = [f"Render size of `opt=spark` on {bench.name} ({len(cases)} cases, prior seed 0):", "",
             "| size (px) | PivotErr per object | per joint | mean abs. change of PivotErr per object vs "
             f"{max(sizes)} px | optimizer CPU s median |", "|---|---|---|---|---|"]
    for size in sizes:
        rows = [r for k, r in results.items() if k[0] == f"size{size}"]
        if not rows:
            continue
        means = row_means(rows, "refined")
        changes = [abs(r["scores"]["refined"]["pivot_err"] - reference[r["case"]]["scores"]["refined"]["pivot_err"])
                   for r in rows if r["case"] in reference and r["scores"]["refined"]["pivot_err"] is not None
                   and reference[r["case"]]["scores"]["refined"]["pivot_err"] is not None]
        cpu = np.median([r["timings"].get("opt_fit_cpu", 0.0) for r in rows])
        lines.append(f"| {size} | {means['pivot_err']:.4f} | {means['joint_pivot_err']:.4f} | "
                     f"{np.mean(changes):.4f} | {cpu:.2f} |")
    return write_result(console, lines, f"spark_sizes_{bench.name}.md")


# ----- Table 4 --------------------------------------------------------------------------------------
def view_only_errors(cases: list[Path]) -> dict:
    """The annotation prior's errors without noise (name-matched): what the camera-frame snapping of the
    axes alone costs."""
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.methods.ours.assemble import joint_summary
    from spark_bench.methods.ours.diagnostics import joint_errors, mean_errors
    from spark_bench.methods.ours.geometry import annotation_geometry
    from spark_bench.methods.ours.prior import NoiseModel, annotation_prior, assemble_prior, camera_axis_frame

    clean = NoiseModel(p_type=0.0, p_axis=0.0, p_sign=0.0, sigma_origin=0.0, p_range=0.0)
    per_object = []
    for folder in cases:
        case = BenchmarkCase(folder)
        gt = case.load_gt()
        frame = camera_axis_frame(case.read_camera()["camera_to_world"])
        prior = assemble_prior(annotation_prior(gt, case.id, clean, axis_frame=frame), annotation_geometry(gt), frame)
        per_object.append(joint_errors(joint_summary(prior), joint_summary(gt, [j.name for j in gt.movable_joints()])))
    return mean_errors(per_object)


def bench_main(args, console: Console) -> int:
    bench = resolve_bench(args.bench)
    cases = case_dirs(bench, args.limit, args.ids)
    seeds = list(range(args.seed0, args.seed0 + args.seeds))
    variants = [v for v in args.variants.split(",") if v]
    overrides = list(args.set)
    notes = []
    if args.calibrate:
        from dataclasses import asdict

        from spark_bench.data.case import BenchmarkCase
        from spark_bench.methods.ours.diagnostics import calibrate_noise
        from spark_bench.methods.ours.prior import NoiseModel, camera_axis_frame

        gts = [(c.name, BenchmarkCase(c).load_gt(), camera_axis_frame(BenchmarkCase(c).read_camera()["camera_to_world"]))
               for c in cases]
        noise, measured = calibrate_noise(gts, NoiseModel(), seeds=range(args.calibration_seeds), progress=console.print)
        console.print(f"calibrated noise model: {asdict(noise)}; prior errors (name-matched) {measured}")
        overrides += [f"prior.noise.{k}={v}" for k, v in asdict(noise).items() if k in ("p_axis", "p_type", "sigma_origin")]
        notes.append(f"Noise model calibrated in this run: {asdict(noise)}; name-matched prior errors "
                     f"{ {k: round(v, 4) for k, v in measured.items()} }.")
    from spark_bench.methods.ours.config import SparkConfig

    noise = SparkConfig().with_overrides(overrides).prior.noise
    clean = view_only_errors(cases)
    notes.append(f"Prior: the ground truth's coarse URDF, axes snapped to the camera frame's canonical axes, with "
                 f"the noise model p_type {noise.p_type:.3f}, p_axis {noise.p_axis:.3f}, sigma_origin "
                 f"{noise.sigma_origin:.3f}, p_sign {noise.p_sign}, p_range {noise.p_range}. Without any noise "
                 f"the camera-frame snapping alone gives (name-matched) AxisErr {clean['axis_err']:.4f}, "
                 f"PivotErr {clean['pivot_err']:.4f}, TypeErr {clean['type_err']:.4f}.")
    notes.extend(args.note)
    work = Path(args.work).expanduser() / bench.name
    tasks = []  # case by case (one worker runs them in order): a run cut short leaves whole cases
    for c in cases:
        for seed in seeds:
            for variant in variants:
                tasks.append(((variant, seed, c.name), str(c), str(work / variant / f"seed{seed}" / c.name),
                              [*VARIANTS[variant], *overrides, f"prior.noise.seed={seed}"], args.n_samples,
                              variant == variants[0]))
    results = cached_results(tasks, console) if args.cached else run_tasks(tasks, args.jobs, console)
    notes.append(f"SPARK sources (joint_opt_runs.code_version): {', '.join(sorted({r['code'] for r in results.values()}))}"
                 f"; {len(results)} of {len(tasks)} runs.")
    table = seed_table(results, variants, seeds)
    text = markdown(bench.name, len(cases), table, results, variants, seeds, notes)
    if args.appendix:  # the reading of these numbers, written by a person
        text += "\n" + Path(args.appendix).read_text()
    console.print(text)
    out = Path(args.out) if args.out else RESULTS / f"table4_{bench.name}.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    (out.with_suffix(".json")).write_text(json.dumps({"table": table, "seeds": seeds, "cases": [c.name for c in cases]},
                                                     indent=1))
    console.print(f"wrote {out}")
    return 0


# ----- toy mode ------------------------------------------------------------------------------------
def toy_main(args, console: Console) -> int:
    """Each method on toy cabinets with noisy priors: seconds and errors before -> after."""
    import torch
    from helpers_toy import toy_cabinet, toy_camera

    from spark_bench.methods.ours.assemble import assemble_asset, joint_summary
    from spark_bench.methods.ours.config import SparkFitConfig
    from spark_bench.methods.ours.diagnostics import joint_errors, mean_errors
    from spark_bench.methods.ours.geometry import annotation_geometry
    from spark_bench.methods.ours.optimize import OpenStateScene
    from spark_bench.methods.ours.prior import NoiseModel, annotation_prior
    from spark_bench.methods.ours.refine import RefineSettings, refine
    from spark_bench.methods.ours.render import rasterize_mask
    from spark_bench.methods.ours.spark_fit import spark_fit

    torch.set_num_threads(args.threads)
    rng = np.random.default_rng(0)
    camera = toy_camera(512)
    noise = NoiseModel(p_type=0.0, p_axis=0.0)
    for method in ("spark", "native"):
        befores, afters, seconds = [], [], []
        for k in range(args.limit or 4):
            gt = toy_cabinet(door_angle=float(rng.uniform(0.8, 1.5)), drawer_travel=float(rng.uniform(0.3, 0.6)))
            opened, rest = gt.mesh(gt.open_configuration()), gt.mesh(gt.rest_configuration())
            target = rasterize_mask(opened.vertices, opened.faces, camera, supersample=1)
            prior = assemble_asset(annotation_prior(gt, f"toy{k}", noise), annotation_geometry(gt))
            start = time.process_time()
            scene = OpenStateScene(prior, camera, target)
            if method == "spark":
                closed = rasterize_mask(rest.vertices, rest.faces, camera, supersample=1)
                asset = spark_fit(prior, scene, closed, SparkFitConfig()).asset
            else:
                asset = refine(prior, scene, RefineSettings.from_config()).asset
            seconds.append(time.process_time() - start)
            truth = joint_summary(gt, [j.name for j in gt.movable_joints()])
            names = [j.name for j in prior.joints.values() if j.parent != "base"]
            befores.append(joint_errors(joint_summary(prior, names), truth))
            afters.append(joint_errors(joint_summary(asset, names), truth))
        before, after = mean_errors(befores), mean_errors(afters)
        console.print(f"opt={method}: CPU s per object {_stats(seconds)}; errors (name-matched) before -> after: "
                      + ", ".join(f"{k} {before[k]:.4f} -> {after[k]:.4f}" for k in KEYS))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", help="a benchmark name (synth-v1) or folder: Table 4 mode (default: toy cabinets)")
    parser.add_argument("--limit", type=int, default=None, help="objects (toy default 4; benchmark: all)")
    parser.add_argument("--ids", nargs="*", default=None, help="benchmark mode: only these case ids")
    parser.add_argument("--threads", type=int, default=1, help="toy mode: torch CPU threads")
    parser.add_argument("--jobs", type=int, default=1, help="benchmark mode: cases run in parallel")
    parser.add_argument("--seeds", type=int, default=5, help="benchmark mode: prior seeds (one eval each)")
    parser.add_argument("--seed0", type=int, default=0, help="benchmark mode: first prior seed")
    parser.add_argument("--variants", default="spark,native,native-masks", help=f"rows besides the prior: {list(VARIANTS)}")
    parser.add_argument("--n-samples", type=int, default=5000, help="benchmark mode: metric surface samples")
    parser.add_argument("--work", default="~/.cache/spark-bench/measure_joint_opt", help="benchmark mode: outputs")
    parser.add_argument("--out", default=None, help="benchmark mode: the Markdown file (default results/table4_<bench>.md)")
    parser.add_argument("--set", action="append", default=[], help="config override section.key=value")
    parser.add_argument("--note", action="append", default=[], help="a line added under the table's heading")
    parser.add_argument("--appendix", default=None, help="benchmark mode: a Markdown file appended to the table")
    parser.add_argument("--cached", action="store_true",
                        help="benchmark mode: run nothing, report the runs cached under --work (any sources)")
    parser.add_argument("--calibrate", action="store_true", help="benchmark mode: calibrate the noise model first")
    parser.add_argument("--calibration-seeds", type=int, default=64,
                        help="prior seeds the calibration averages over (64 on synth-v1: about 10 s an "
                             "iteration; with 8, TypeErr's seed scatter, about 0.02, stays in p_type)")
    parser.add_argument("--spark-sizes", default=None, help="render-size study of opt=spark, e.g. 64,128,256")
    args = parser.parse_args(argv)
    console = Console()
    if args.bench and args.spark_sizes:
        return sizes_main(args, console)
    if args.bench:
        return bench_main(args, console)
    return toy_main(args, console)


if __name__ == "__main__":
    sys.exit(main())
