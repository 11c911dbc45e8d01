"""Time SPARK's native joint optimization per object, and show where the time goes.

    python benchmarks/bench_joint_opt.py                   # toy cabinets, noisy priors (offline)
    python benchmarks/bench_joint_opt.py --bench ~/.cache/spark-bench/benchmarks/synth-v1 --limit 10

Per object: seconds for the discrete search and the final fit, the prior's and the refined joint errors
(matched by part name), and the total as a multiple of one forward+backward soft render at 128 px
measured in the same run (the peer, so numbers compare across machines). Then a cProfile of one object
split into rendering, forward kinematics, backward pass, loss and the rest. Aim: under 10 s per object
on 2 cores.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time
from pathlib import Path

import numpy as np
import torch
from rich.console import Console
from rich.table import Table

from spark_bench.spark.assemble import assemble_asset, joint_summary
from spark_bench.spark.diagnostics import joint_errors, mean_errors
from spark_bench.spark.geometry import annotation_geometry
from spark_bench.spark.optimize import OpenStateScene
from spark_bench.spark.prior import NoiseModel, annotation_prior
from spark_bench.spark.refine import RefineSettings, prior_hypotheses, refine
from spark_bench.spark.render import rasterize_mask
from spark_bench.spark.toy import toy_cabinet, toy_camera


def toy_problems(n: int):
    """``n`` toy cabinets with different opening values, each with a seeded noisy prior."""
    rng = np.random.default_rng(0)
    camera = toy_camera(512)
    for k in range(n):
        gt = toy_cabinet(door_angle=float(rng.uniform(0.8, 1.5)), drawer_travel=float(rng.uniform(0.3, 0.6)))
        opened = gt.mesh(gt.open_configuration())
        yield f"toy{k}", gt, camera, rasterize_mask(opened.vertices, opened.faces, camera, supersample=1)


def bench_problems(bench: Path, limit: int):
    """Cases of a prepared benchmark (needs spark_bench.data)."""
    from spark_bench.data import load_object
    from spark_bench.spark.camera import load_camera
    from spark_bench.spark.open_state import dataset_open_state

    cases = sorted(p for p in (bench / "cases").iterdir() if (p / "case.json").is_file())[:limit]
    for case in cases:
        yield case.name, load_object(case / "gt"), load_camera(case / "camera.json"), dataset_open_state(case).mask


def peer_seconds(scene: OpenStateScene, hypotheses, repeats: int = 20) -> float:
    """One forward + backward soft render of the whole object at 128 px."""
    vertices = scene.world_vertices(hypotheses).detach().requires_grad_(True)
    renderer = scene.renderer(128, 0.6)
    start = time.perf_counter()
    for _ in range(repeats):
        renderer.render(vertices, scene.faces).sum().backward()
    return (time.perf_counter() - start) / repeats


def run_one(case_id, gt, camera, mask, noise, settings):
    prior_asset = assemble_asset(annotation_prior(gt, case_id, noise), annotation_geometry(gt))
    start = time.perf_counter()
    scene = OpenStateScene(prior_asset, camera, mask, settings.max_faces)
    result = refine(prior_asset, scene, settings)
    total = time.perf_counter() - start
    truth = joint_summary(gt, [j.name for j in gt.movable_joints()])
    names = [j.name for j in prior_asset.joints.values() if j.parent != "base"]
    before = joint_errors(joint_summary(prior_asset, names), truth)
    after = joint_errors(joint_summary(result.asset, names), truth)
    return scene, result, total, before, after


def profile_split(case_id, gt, camera, mask, noise, settings) -> dict[str, float]:
    """Seconds by kind of work in one object's optimization (cumulative cProfile times)."""
    profiler = cProfile.Profile()
    profiler.enable()
    run_one(case_id, gt, camera, mask, noise, settings)
    profiler.disable()
    stats = pstats.Stats(profiler)
    total = max(v[3] for v in stats.stats.values())
    buckets = {"render (forward)": ("render.py", "render"), "forward kinematics": ("torch_fk.py", "link_poses_torch"),
               "backward pass": ("_tensor.py", "backward"), "loss": ("optimize.py", "silhouette_loss"),
               "targets (distance transform)": ("optimize.py", "halo_target"),
               "mesh prep (decimate, weld)": ("optimize.py", "__init__")}
    out = {}
    for label, (filename, function) in buckets.items():
        out[label] = sum(v[3] for k, v in stats.stats.items() if k[0].endswith(filename) and k[2] == function)
    out["other"] = max(0.0, total - sum(out.values()))
    out["total"] = total
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", type=Path, help="a prepared benchmark folder (default: toy cabinets)")
    parser.add_argument("--limit", type=int, default=4, help="objects to time")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads (1: on a busy 2-core machine, 2 threads ran 20x slower)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    console = Console()
    noise, settings = NoiseModel(), RefineSettings()
    problems = list(bench_problems(args.bench, args.limit) if args.bench else toy_problems(args.limit))
    table = Table(title=f"joint optimization per object ({args.threads} threads)")
    for col in ("object", "search s", "final s", "total s", "x peer", "AxisErr b/a", "PivotErr b/a", "TypeErr b/a"):
        table.add_column(col)
    befores, afters, totals = [], [], []
    for case_id, gt, camera, mask in problems:
        scene, result, total, before, after = run_one(case_id, gt, camera, mask, noise, settings)
        peer = peer_seconds(scene, prior_hypotheses(result.asset))
        befores.append(before)
        afters.append(after)
        totals.append(total)

        def pair(key, b=before, a=after):
            fmt = lambda v: "-" if v is None else f"{v:.3f}"  # noqa: E731
            return f"{fmt(b[key])} / {fmt(a[key])}"

        table.add_row(case_id, f"{result.timings['discrete_search']:.2f}", f"{result.timings['final_fit']:.2f}",
                      f"{total:.2f}", f"{total / peer:.0f}", pair("axis_err"), pair("pivot_err"), pair("type_err"))
    console.print(table)
    mb, ma = mean_errors(befores), mean_errors(afters)
    console.print(f"mean seconds per object: {np.mean(totals):.2f} (aim: < 10); "
                  f"errors before -> after: " + ", ".join(f"{k} {mb[k]} -> {ma[k]}" for k in mb))
    split = profile_split(*problems[0], noise, settings)
    console.print(f"where the time goes ({problems[0][0]}, cProfile, cumulative):")
    for label, seconds in split.items():
        console.print(f"  {label:32s} {seconds:7.2f} s  {100 * seconds / split['total']:5.1f} %")
    console.print(f"stages: screen {settings.screen}, short fits {settings.short_steps} steps x top {settings.top_k}, "
                  f"final {[(s.size, s.steps) for s in settings.final]}; peer = one 128 px render+backward")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
