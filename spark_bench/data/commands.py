"""The ``spark-bench data`` command group: ``synth``, ``prepare``, ``build``, ``sheet``.

Heavy imports (trimesh, MuJoCo, the generator) happen inside each command, so ``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_commands(subparsers) -> None:
    """Register ``data`` and its sub-commands on the top-level ``spark-bench`` parser."""
    data = subparsers.add_parser("data", help="make datasets and benchmark cases",
                                 description="Generate procedural objects and prepare benchmark cases.")
    sub = data.add_subparsers(dest="data_command", required=True, metavar="SUBCOMMAND")

    synth = sub.add_parser("synth", help="generate procedural objects (PartNet-Mobility folders)")
    synth.add_argument("--out", type=Path, required=True, help="folder to write the object folders into")
    synth.add_argument("--n", type=int, default=50, help="number of objects (default 50)")
    synth.add_argument("--seed", type=int, default=0, help="generator seed (default 0)")
    synth.add_argument("--categories", nargs="+", default=None, metavar="CAT",
                       help="only these categories (default: all; a variant such as TopLoadingWasher only when named)")
    synth.set_defaults(func=run_synth)

    prepare = sub.add_parser("prepare", help="turn object folders into benchmark cases",
                             description="Merge, make watertight, normalize and render each object into "
                                         "a case folder of BENCH; failed objects are listed in BENCH's manifest. "
                                         "Re-running resumes: finished cases are kept.")
    prepare.add_argument("--src", type=Path, required=True, help="a folder of object folders, or one object")
    prepare.add_argument("--out", type=Path, default=None,
                         help="the benchmark folder to write (required unless --bench names a listed benchmark, "
                              "whose default is the cache folder `eval --bench NAME` reads)")
    prepare.add_argument("--ids", nargs="+", default=None, metavar="ID", help="only these object ids")
    prepare.add_argument("--bench", default=None, metavar="NAME",
                         help=f"a listed benchmark, the PartNet-Mobility test ids a method publishes "
                              f"({_listed_names()}): prepare the listed objects found under --src with the "
                              f"camera its method states (the default view where it states none), skip the "
                              f"others and report them as missing")
    _add_prepare_options(prepare)
    prepare.add_argument("--overwrite", action="store_true", help="rebuild cases that are already complete")
    prepare.add_argument("--executor", choices=("local", "ray"), default="local",
                         help="local: --workers processes; ray: one Ray task per object, on a cluster every node "
                              "of which sees --src and --out (docs/cluster.md)")
    prepare.add_argument("--ray-address", help="a Ray cluster's address (default: RAY_ADDRESS, else the cluster "
                         "`ray start` runs on this machine, else a private local Ray of --workers CPUs)")
    prepare.set_defaults(func=run_prepare)

    build = sub.add_parser("build", help="build a named benchmark into the cache (e.g. synth-v1)")
    build.add_argument("name", nargs="?", default="synth-v1", help="benchmark name (default synth-v1)")
    build.add_argument("--rebuild", action="store_true", help="delete and rebuild it")
    build.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    build.set_defaults(func=run_build)

    sheet = sub.add_parser("sheet", help="(re)write a benchmark's contact sheet PNG")
    sheet.add_argument("bench", type=Path, help="the benchmark folder")
    sheet.add_argument("--out", type=Path, default=None, help="output PNG (default: the benchmark's contact sheet)")
    sheet.add_argument("--thumb", type=int, default=192, help="image size in the sheet (default 192)")
    sheet.set_defaults(func=run_sheet)

    export = sub.add_parser("export-images", help="write each case's input image as DIR/<case id>.png (SPARK's image/)",
                            description="Copy every case's input image to DIR/<case id>.png, ready to be SPARK's "
                                        "image/ folder: run.py names each run <case id>_<timestamp>, which "
                                        "`spark-bench import spark` maps back to the case.")
    export.add_argument("bench", type=Path, help="the benchmark folder")
    export.add_argument("--out", type=Path, required=True, help="the folder to write (e.g. SPARK/image)")
    export.add_argument("--cases", help="comma-separated case ids (default: every case)")
    export.set_defaults(func=run_export_images)


def _listed_names() -> str:
    """``spark-test: SPARK, 42 ids; ...``: every published split (splits.py is plain data: cheap)."""
    from spark_bench.data.splits import SPLITS

    return "; ".join(f"{s.name}: {s.method}, {len(s.ids)} ids" for s in SPLITS.values())


def _add_prepare_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--image-size", type=int, default=None, help="render size in pixels (default 512)")
    parser.add_argument("--resolution", type=int, default=None,
                        help="watertight remesh voxels along a part's largest axis (default 200, as SPARK)")
    parser.add_argument("--seed", type=int, default=None, help="base seed of the camera views (default 0)")
    parser.add_argument("--render-mesh", choices=("source", "watertight"), default=None,
                        help="render the images from the source meshes (default, as SPARK does) or from the "
                             "watertight ground truth (a slower scene build, same ground truth, slightly "
                             "thicker thin parts)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run_synth(args) -> int:
    from spark_bench.data.synth import generate_dataset

    if args.n < 1:
        raise _usage(f"--n must be at least 1, got {args.n}")
    paths = generate_dataset(args.out, args.n, seed=args.seed, categories=args.categories)
    print(f"wrote {len(paths)} objects to {args.out}")
    return 0


def _options(args, base=None):
    """``base`` (default :class:`PrepareOptions`) with the options given on the command line."""
    from dataclasses import replace

    from spark_bench.data.prepare import PrepareOptions

    given = {k: getattr(args, k) for k in ("image_size", "resolution", "seed", "render_mesh")
             if getattr(args, k) is not None}
    return replace(base or PrepareOptions(), **given)


def run_prepare(args) -> int:
    from spark_bench.data.case import Benchmark
    from spark_bench.data.prepare import prepare_benchmark

    if args.bench is not None:
        return _run_prepare_listed(args)
    if args.out is None:
        raise _usage("data prepare needs --out BENCH_DIR (or --bench NAME of a listed benchmark)")
    where = _connect_ray(args) if args.executor == "ray" else None
    manifest = prepare_benchmark(args.src, args.out, ids=args.ids, options=_options(args), workers=args.workers,
                                 progress=not args.no_progress, overwrite=args.overwrite, executor=args.executor,
                                 ray_address=args.ray_address)
    if where:
        print(f"spark-bench: prepared on {where}", file=sys.stderr)
    print(f"{len(manifest['cases'])} cases in {args.out}, {len(manifest['failed'])} failed")
    for case_id, reason in manifest["failed"].items():
        print(f"  failed {case_id}: {reason}")
    if manifest["cases"]:
        print(f"contact sheet: {Benchmark(args.out).contact_sheet_path}")
    return 1 if manifest["failed"] else 0


def _connect_ray(args) -> str:
    """Connect to the Ray of ``--ray-address`` (:func:`~spark_bench.ray_executor.connect_ray`; a bad address is
    one line) before anything is read or written; returns which Ray it is."""
    from spark_bench.ray_executor import connect_ray

    return connect_ray(args.ray_address, args.workers)


def _run_prepare_listed(args) -> int:
    """``data prepare --bench NAME``: the listed objects found under ``--src``; 0 when at least one listed
    object is a case of the benchmark, else 1 with the reason."""
    from spark_bench.data.benchmarks import benchmark_spec, prepare_listed

    if args.executor == "ray":
        raise _usage("--executor ray prepares a folder (--out), not a listed benchmark (--bench) yet")
    spec = benchmark_spec(args.bench)
    if not spec.is_listed:
        raise _usage(f"--bench {args.bench}: a generated benchmark; build it with `spark-bench data build {args.bench}`")
    if args.ids:
        raise _usage("--ids and --bench exclude each other: the benchmark lists its ids")
    result = prepare_listed(spec, args.src, args.out, options=_options(args, spec.options), workers=args.workers,
                            progress=not args.no_progress, overwrite=args.overwrite)
    manifest, out = result.manifest, result.folder
    print(f"{spec.name}: {len(result.found)} of {len(spec.ids)} listed objects found in {args.src}, "
          f"{len(result.prepared)} prepared into {out}, {len(manifest['failed'])} failed")
    if result.missing:
        print(f"  missing ({len(result.missing)}): {' '.join(result.missing)}")
    for case_id, reason in manifest["failed"].items():
        print(f"  failed {case_id}: {reason}")
    if not result.prepared:
        print(f"error: none of the listed objects of {spec.name} could be prepared", file=sys.stderr)
        return 1
    return 0


def run_build(args) -> int:
    from spark_bench.data.benchmarks import ensure_benchmark

    folder = ensure_benchmark(args.name, rebuild=args.rebuild, workers=args.workers)
    print(folder)
    return 0


def run_sheet(args) -> int:
    from spark_bench.data.contact_sheet import write_contact_sheet

    print(write_contact_sheet(args.bench, args.out, thumb=args.thumb))
    return 0


def _usage(message: str):
    from spark_bench.errors import SparkBenchError

    return SparkBenchError(message)


def run_export_images(args) -> int:
    from spark_bench.data.export import export_images

    written, missing = export_images(args.bench, args.out, _case_list(args.cases))
    print(f"wrote {len(written)} images into {args.out}")
    for line in missing:
        print(f"  skipped {line}")
    return 0 if written else 1


def _case_list(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text else None
