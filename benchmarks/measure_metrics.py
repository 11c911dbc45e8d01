"""Speed of the shape metrics (CD, F-Score) against the PartCrafter implementation, same run.

PartCrafter samples each mesh with ``trimesh.Trimesh.sample`` and finds nearest neighbours with
scikit-learn's ``NearestNeighbors(n_neighbors=1, leaf_size=30, algorithm="kd_tree")`` both ways; the
formulas are the same as ours. For each sample count this script times

- the whole metric (sampling both surfaces + distances + CD and F@0.1, F@0.5), each side its own way;
- the distance part alone, both on the same samples;

prints the ratios, and checks that both give the same distances and metrics (to 1e-6) on the same
samples. Run: ``python -m benchmarks.measure_metrics [--sizes 100000 1000000] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import trimesh
from sklearn.neighbors import NearestNeighbors

from spark_bench.metrics.sampling import sample_pair
from spark_bench.metrics.shape import ShapeScores, mutual_nearest_distances, scores_from_distances

THRESHOLDS = (0.1, 0.5)


def surfaces() -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A ground-truth sphere (20k faces) and a smoothly dented, shifted "prediction" of it."""
    gt = trimesh.creation.icosphere(subdivisions=5)
    v = gt.vertices
    dent = 0.08 * np.sin(3 * v[:, 0]) * np.cos(2 * v[:, 1]) + 0.05 * v[:, 2] ** 2
    pred = trimesh.Trimesh(v * (1.0 + dent)[:, None] + [0.03, -0.02, 0.01], gt.faces, process=False)
    return pred, gt


# ----- the peer: PartCrafter's evaluation code path -----------------------------------------------
def partcrafter_distances(pred_points: np.ndarray, gt_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    def nearest(a, b):
        nn = NearestNeighbors(n_neighbors=1, leaf_size=30, algorithm="kd_tree", metric="l2").fit(b)
        return nn.kneighbors(a)[0][:, 0]

    return nearest(pred_points, gt_points), nearest(gt_points, pred_points)


def partcrafter_metric(pred: trimesh.Trimesh, gt: trimesh.Trimesh, n: int) -> dict:
    pred_points, gt_points = pred.sample(n), gt.sample(n)
    d_pg, d_gp = partcrafter_distances(pred_points, gt_points)
    out = {"cd": float(np.mean(d_gp) + np.mean(d_pg))}
    for tau in THRESHOLDS:
        p, r = np.mean((d_pg < tau).astype(np.float32)), np.mean((d_gp < tau).astype(np.float32))
        out[tau] = float(2 * p * r / (p + r))
    return out


# ----- ours ---------------------------------------------------------------------------------------
def our_metric(pred_tris: np.ndarray, gt_tris: np.ndarray, n: int, seed: int = 0) -> dict:
    d_pg, d_gp = mutual_nearest_distances(*sample_pair(pred_tris, gt_tris, n, seed))
    scores = scores_from_distances(d_pg, d_gp, THRESHOLDS)
    return {"cd": scores.cd, **scores.fscore}


def best_times(fns: dict, repeats: int) -> dict[str, tuple[float, float]]:
    """Best wall time and best CPU time (all threads) of each function; runs alternate between them,
    so a load change on a shared machine hits both sides alike. CPU time shows the work saved even
    when other processes take the cores that our threads would use."""
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, (fn, fn_args) in fns.items():
            wall, cpu = time.perf_counter(), time.process_time()
            fn(*fn_args)
            times[name].append((time.perf_counter() - wall, time.process_time() - cpu))
    return {name: (min(w for w, _ in t), min(c for _, c in t)) for name, t in times.items()}


def measure(n: int, pred: trimesh.Trimesh, gt: trimesh.Trimesh, repeats: int) -> tuple[dict, float, ShapeScores]:
    """Timings for one sample count, and the largest difference between the two implementations."""
    # both sides start from ready triangles: trimesh caches them (and their areas) on the mesh
    pred_tris, gt_tris = pred.vertices[pred.faces], gt.vertices[gt.faces]
    whole = best_times({"peer": (partcrafter_metric, (pred, gt, n)),
                        "ours": (our_metric, (pred_tris, gt_tris, n))}, repeats)
    p_pts, g_pts = sample_pair(pred_tris, gt_tris, n, 0)
    distances = best_times({"peer": (partcrafter_distances, (p_pts, g_pts)),
                            "ours": (mutual_nearest_distances, (p_pts, g_pts))}, repeats)
    # the same numbers on the same samples
    peer_pg, peer_gp = partcrafter_distances(p_pts, g_pts)
    d_pg, d_gp = mutual_nearest_distances(p_pts, g_pts)
    ref = scores_from_distances(peer_pg, peer_gp, THRESHOLDS)
    ours = scores_from_distances(d_pg, d_gp, THRESHOLDS)
    diff = max(np.abs(d_pg - peer_pg).max(), np.abs(d_gp - peer_gp).max(), abs(ours.cd - ref.cd),
               *(abs(ours.fscore[t] - ref.fscore[t]) for t in THRESHOLDS))
    return {"whole": whole, "distances": distances}, float(diff), ours


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs (1e6: at most 2)")
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    pred, gt = surfaces()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"shape metrics: spark_bench vs PartCrafter (sklearn NearestNeighbors), {cores} cores "
          f"(load average {load:.1f}), meshes of {len(gt.faces)} faces; best of {args.repeats}")
    header = (f"{'points/side':>12} {'part':>10} {'PartCrafter s':>14} {'ours s':>9} {'ratio':>7}"
              f" {'| CPU s: PartCrafter':>20} {'ours':>7} {'ratio':>7}")
    print(header)
    print("-" * len(header))
    checks = []
    for n in args.sizes:
        repeats = args.repeats if n <= 200_000 else min(args.repeats, 2)
        timings, diff, ours = measure(n, pred, gt, repeats)
        for part, t in timings.items():
            (peer_wall, peer_cpu), (our_wall, our_cpu) = t["peer"], t["ours"]
            print(f"{n:>12,} {part:>10} {peer_wall:>14.3f} {our_wall:>9.3f} {peer_wall / our_wall:>6.1f}x"
                  f" {peer_cpu:>20.3f} {our_cpu:>7.3f} {peer_cpu / our_cpu:>6.1f}x", flush=True)
        checks.append((n, diff, ours))
    print()
    for n, diff, ours in checks:
        verdict = "same to 1e-6" if diff <= 1e-6 else "DIFFERENT"
        print(f"{n:>12,} points: max |ours - PartCrafter| over distances, CD, F = {diff:.2e} ({verdict}); "
              f"CD {ours.cd:.6f}, F@0.1 {ours.fscore[0.1]:.4f}, F@0.5 {ours.fscore[0.5]:.4f}")
    if any(diff > 1e-6 for _, diff, _ in checks):
        raise SystemExit("metrics differ from the PartCrafter implementation")


if __name__ == "__main__":
    main()
