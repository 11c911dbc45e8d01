"""Where the time of ``spark-bench data prepare`` goes, per object and per stage.

For each shared real object (``../shared/real_objects``) this script runs
:func:`spark_bench.data.prepare.prepare_case` once with the default options (R=200 watertight
remesh, 512 px renders) and reports the seconds of each stage (load, merge, watertight,
normalize+write, render), the share of the total, the size of the written ground truth, and the
peak memory. The watertight stage is profiled (cProfile) to split it into voxelization, fill,
marching cubes and cleanup. As the peer measured in the same run, the watertight stage is repeated at
a coarser resolution (``--peer-resolution``, default 64) and the ratio printed: what R costs.

Run: ``python -m benchmarks.measure_prepare [--ids 40147 3763] [--resolution 200] [--peer-resolution 64]``
(the seven objects at R=200 take several minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import resource
import sys
import tempfile
import time
from pathlib import Path

from spark_bench.data.case import BenchmarkCase
from spark_bench.data.prepare import STAGES, PrepareOptions, StageTimer, ground_truth_asset, prepare_case
from spark_bench.data.readers import load_object

REAL_OBJECTS = Path(__file__).resolve().parents[1].parent / "shared" / "real_objects"
REAL_IDS = ("41083", "40147", "45780", "7179", "47645", "102442", "3763")
#: Steps of the watertight remesh whose cumulative time is reported: (file name part, function names).
WATERTIGHT_PARTS = {
    "voxelize surface": ("spark_bench/asset/voxel.py", ("voxelize_surface",)),
    "fill": ("spark_bench/asset/voxel.py", ("fill_holes",)),
    "marching cubes": ("skimage/measure", ("marching_cubes",)),
    "cleanup (weld, dedupe, split)": ("spark_bench/asset/mesh.py", ("shell_cleanup", "cleanup_with_watertight", "vertex_spacing")),
    "orientation (signed volume)": ("spark_bench/asset/mesh.py", ("signed_volume",)),
}


def folder_megabytes(folder: Path) -> float:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6


def cumulative_by_part(profile: cProfile.Profile) -> dict[str, float]:
    """Cumulative seconds of each step of :data:`WATERTIGHT_PARTS` (they never call each other)."""
    stats = pstats.Stats(profile).stats
    out = dict.fromkeys(WATERTIGHT_PARTS, 0.0)
    for (filename, _, func), (_, _, _, cumulative, _) in stats.items():
        for part, (where, name) in WATERTIGHT_PARTS.items():
            if func in name and where in filename.replace("\\", "/"):
                out[part] += cumulative
    return out


def run_object(object_id: str, out: Path, options: PrepareOptions, peer_resolution: int) -> dict:
    timer = StageTimer()
    profile = cProfile.Profile()
    source = load_object(REAL_OBJECTS / object_id)
    faces_in = sum(len(v.mesh.faces) for link in source.links.values() for v in link.visuals)
    # profile only the watertight stage: wrap make_watertight while prepare_case runs
    import spark_bench.asset.mesh as mesh_module

    original = mesh_module.make_watertight

    def profiled(*args, **kwargs):
        profile.enable()
        try:
            return original(*args, **kwargs)
        finally:
            profile.disable()

    mesh_module.make_watertight = profiled
    try:
        record = prepare_case(REAL_OBJECTS / object_id, out / object_id, options, object_id, timer)
    finally:
        mesh_module.make_watertight = original
    peer_timer = StageTimer()
    ground_truth_asset(source, resolution=peer_resolution, n_min=options.n_min, timer=peer_timer)
    faces_out = sum(r["n_faces"] for r in record["watertight"]["links"].values())
    return {"id": object_id, "category": record["category"], "seconds": timer.seconds,
            "faces_in": faces_in, "faces_out": faces_out, "gt_mb": folder_megabytes(BenchmarkCase(out / object_id).gt_dir),
            "parts": cumulative_by_part(profile), "peer_watertight": peer_timer.seconds.get("watertight", 0.0),
            "methods": sorted({r["method"] for r in record["watertight"]["links"].values()})}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ids", nargs="+", default=list(REAL_IDS))
    parser.add_argument("--resolution", type=int, default=200)
    parser.add_argument("--peer-resolution", type=int, default=64)
    parser.add_argument("--image-size", type=int, default=512)
    args = parser.parse_args(argv)
    if not REAL_OBJECTS.is_dir():
        print(f"skipped: {REAL_OBJECTS} is absent")
        return 0
    options = PrepareOptions(image_size=args.image_size, resolution=args.resolution)
    print(f"prepare per object: R={args.resolution} (peer R={args.peer_resolution}), "
          f"{args.image_size} px, {len(args.ids)} objects\n")
    rows = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for object_id in args.ids:
            row = run_object(object_id, Path(tmp), options, args.peer_resolution)
            rows.append(row)
            s = row["seconds"]
            print(f"  {object_id:>7} {row['category']:<17} total {sum(s[k] for k in STAGES):7.1f} s  "
                  + "  ".join(f"{k} {s.get(k, 0.0):6.2f}" for k in STAGES), flush=True)
    wall = time.perf_counter() - start

    header = (f"\n{'id':>7} {'category':<17} {'faces in':>9} {'faces out':>10} {'gt MB':>7} "
              + " ".join(f"{k:>15}" for k in STAGES) + f" {'total s':>8} {'wt share':>8} {'wt R/peer':>9}")
    print(header)
    totals = dict.fromkeys(STAGES, 0.0)
    for row in rows:
        s = row["seconds"]
        total = sum(s[k] for k in STAGES)
        for k in STAGES:
            totals[k] += s.get(k, 0.0)
        ratio = s.get("watertight", 0.0) / max(row["peer_watertight"], 1e-9)
        print(f"{row['id']:>7} {row['category']:<17} {row['faces_in']:>9} {row['faces_out']:>10} "
              f"{row['gt_mb']:>7.1f} " + " ".join(f"{s.get(k, 0.0):>15.2f}" for k in STAGES)
              + f" {total:>8.1f} {s.get('watertight', 0.0) / total:>8.0%} {ratio:>8.1f}x")
    grand = sum(totals.values())
    print(f"{'all':>7} {'':<17} {'':>9} {'':>10} {'':>7} " + " ".join(f"{totals[k]:>15.2f}" for k in STAGES)
          + f" {grand:>8.1f}")
    print("share of the total: " + ", ".join(f"{k} {totals[k] / grand:.0%}" for k in STAGES))
    scene = sum(r["seconds"].get("render.scene", 0.0) for r in rows)
    print(f"inside the render stage: building the MuJoCo scene {scene:.1f} s "
          f"({scene / max(totals['render'], 1e-9):.0%}), rendering and PNG writing the rest")
    parts = {p: sum(r["parts"][p] for r in rows) for p in WATERTIGHT_PARTS}
    print("\ninside the watertight stage (cProfile cumulative, all objects; profiling adds overhead):")
    for part, seconds in parts.items():
        print(f"  {part:<30} {seconds:8.1f} s  {seconds / max(totals['watertight'], 1e-9):5.0%}")
    peer = sum(r["peer_watertight"] for r in rows)
    print(f"\nwatertight at R={args.resolution}: {totals['watertight']:.1f} s; at R={args.peer_resolution}: "
          f"{peer:.1f} s; ratio {totals['watertight'] / max(peer, 1e-9):.1f}x")
    print(f"wall {wall:.1f} s (peer runs included); peak RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
