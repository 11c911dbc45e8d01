"""Conversion benchmark: spark-bench's MJCF conversion against MuJoCo's own URDF import, same run.

For each object (default: the seven shared PartNet-Mobility objects) it measures

- cold conversion (empty cache) and cached conversion: wall seconds, and CPU seconds including the
  CoACD worker processes;
- the number of collision hulls and CoACD calls;
- the sweep reach (smallest fraction of a joint's range reached out and back) and whether every
  check passes;
- MuJoCo's built-in URDF import of the same ``mobility.urdf``: whether it compiles, its collision geom
  count and, where it compiles, the sweep reach of its model under the same sweep;

and, on 41083, CoACD with its default parameters on each link's mesh (the reference the 45 s target
is set against), so that the speed-up is a ratio measured under the same CPU load. With ``--synth N``
it also reports the pass rate of N generated objects.

Run: ``python -m benchmarks.measure_convert [--ids 41083 7179] [--synth 40] [--no-reference]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from pathlib import Path

REAL = Path(__file__).resolve().parents[2] / "shared" / "real_objects"
IDS = ("41083", "40147", "45780", "7179", "47645", "102442", "3763")


def cpu_seconds() -> float:
    """CPU time of this process and its finished children (the CoACD workers)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def timed(fn):
    wall, cpu = time.perf_counter(), cpu_seconds()
    result = fn()
    return result, time.perf_counter() - wall, cpu_seconds() - cpu


def ours(src: Path, home: Path, out: Path) -> dict:
    """Cold and cached conversion, then every check (cached)."""
    from spark_bench.data.readers import read_json
    from spark_bench.sim import convert, run_checks
    from spark_bench.sim.converter import REPORT_JSON

    os.environ["SPARK_BENCH_HOME"] = str(home)
    xml, cold_wall, cold_cpu = timed(lambda: convert(src, out / "cold"))
    report = read_json(xml.parent / REPORT_JSON)
    _, cached_wall, cached_cpu = timed(lambda: convert(src, out / "cached"))
    checks = run_checks(src)
    sweep = checks.checks["joint_sweep"]
    return {"cold_s": round(cold_wall, 2), "cold_cpu_s": round(cold_cpu, 2), "cached_s": round(cached_wall, 3),
            "cached_cpu_s": round(cached_cpu, 3), "hulls": sum(report["hulls"].values()),
            "coacd_calls": report["coacd"]["calls"], "reach": sweep.value, "passed": checks.passed,
            "failures": checks.failures(),
            "joints": {k: (v["reached"], v["returned"]) for k, v in sweep.details["joints"].items()}}


def mujoco_import(src: Path) -> dict:
    """MuJoCo's URDF importer on the same file, and the same sweep where it compiles."""
    from spark_bench.mujoco_gl import mujoco_module
    from spark_bench.sim.sweep import check_joint_sweep, swept_joints_of_model

    mujoco = mujoco_module()
    try:
        spec = mujoco.MjSpec.from_file(str(src / "mobility.urdf"))
        spec.meshdir = str(src / "textured_objs")
        spec.strippath = True
        model = spec.compile()
    except Exception as exc:  # the importer's verdict is the measurement
        return {"compiles": False, "error": " ".join(str(exc).split())[:160]}
    joints = swept_joints_of_model(model)
    collision = int(sum(1 for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]))
    try:
        sweep = check_joint_sweep(spec, joints)
        reach = sweep.value
    except Exception as exc:
        return {"compiles": True, "collision_geoms": collision, "sweep_error": str(exc)[:160]}
    return {"compiles": True, "collision_geoms": collision, "reach": reach}


def coacd_reference(src: Path) -> dict:
    """CoACD with its own defaults on every link's merged mesh (2 worker processes, no cache)."""
    from spark_bench.data import load_object
    from spark_bench.sim.decompose import DecomposeStats, decompose_many
    from spark_bench.sim.options import CoacdParams

    asset = load_object(src)
    meshes = [link.merged_mesh() for link in asset.links.values() if link.has_geometry]
    stats = DecomposeStats()
    hulls, wall, cpu = timed(lambda: decompose_many([(m.vertices, m.faces) for m in meshes],
                                                   CoacdParams.coacd_defaults(), cache=None, workers=2,
                                                   stats=stats, progress=True))
    return {"wall_s": round(wall, 1), "cpu_s": round(cpu, 1), "coacd_cpu_s": round(stats.coacd_cpu_s, 1),
            "hulls": sum(len(h) for h in hulls), "failed": len(stats.failed)}


def synth_pass_rate(n: int, work: Path) -> dict:
    from tqdm import tqdm

    from spark_bench.data.synth import generate_dataset
    from spark_bench.sim import run_checks

    folders = generate_dataset(work / "synth", n, seed=0, progress=False)
    failed = {}
    for folder in tqdm(folders, desc="synth checks"):
        report = run_checks(folder)
        if not report.passed:
            failed[folder.name] = report.failures()
    return {"objects": len(folders), "passed": len(folders) - len(failed), "failed": failed}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", nargs="+", default=list(IDS))
    parser.add_argument("--synth", type=int, default=0, help="also check N generated objects")
    parser.add_argument("--no-reference", action="store_true", help="skip CoACD defaults on 41083")
    parser.add_argument("--json", type=Path, default=None, help="write all numbers here")
    args = parser.parse_args()
    load = os.getloadavg()
    results = {"load_average": load, "cpus": os.cpu_count(), "objects": {}}
    with tempfile.TemporaryDirectory(prefix="bench_convert_") as tmp:
        tmp = Path(tmp)
        for oid in args.ids:
            src = REAL / oid
            if not src.is_dir():
                print(f"{oid}: {src} absent, skipped")
                continue
            row = {"ours": ours(src, tmp / f"home_{oid}", tmp / f"out_{oid}"), "mujoco": mujoco_import(src)}
            results["objects"][oid] = row
            o, m = row["ours"], row["mujoco"]
            theirs = (f"compiles, {m['collision_geoms']} geoms, reach {m.get('reach', float('nan')):.0%}"
                      if m["compiles"] else f"fails: {m['error'][:70]}")
            print(f"{oid:>7}  cold {o['cold_s']:6.2f} s (cpu {o['cold_cpu_s']:6.2f})  cached {o['cached_s']:5.2f} s  "
                  f"hulls {o['hulls']:4d}  coacd {o['coacd_calls']:3d}  reach {o['reach']:.0%}  "
                  f"{'PASS' if o['passed'] else 'FAIL'}  | MuJoCo import: {theirs}", flush=True)
            for failure in o["failures"]:
                print(f"{'':>9}{failure[:200]}")
        if not args.no_reference and (REAL / "41083").is_dir():
            ref = coacd_reference(REAL / "41083")
            results["coacd_defaults_41083"] = ref
            mine = results["objects"].get("41083", {}).get("ours")
            ratio = f", ours cold is {mine['cold_s'] / ref['wall_s']:.3f}x of it" if mine else ""
            print(f"CoACD defaults on 41083's links: {ref['wall_s']} s wall, {ref['cpu_s']} s CPU, "
                  f"{ref['hulls']} hulls{ratio}")
        if args.synth:
            results["synth"] = synth_pass_rate(args.synth, tmp)
            s = results["synth"]
            print(f"synth: {s['passed']}/{s['objects']} pass every check ({s['passed'] / s['objects']:.1%})")
    print(f"load average at start {load[0]:.2f} on {os.cpu_count()} CPUs")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
