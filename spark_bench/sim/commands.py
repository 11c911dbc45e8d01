"""``spark-bench convert`` and ``spark-bench check``.

Exit codes of ``check``: 0 every check passed, 1 some failed, 2 the input cannot be read at all (the
CLI prints one line naming the file and the problem).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

#: What ``convert --to`` and ``check --export`` write (:mod:`spark_bench.sim.export`).
EXPORT_FORMATS = ("mjcf", "urdf", "usd")


def add_commands(subparsers) -> None:
    """Register ``convert`` and ``check`` on the top-level ``spark-bench`` parser."""
    convert = subparsers.add_parser(
        "convert", help="object folder, URDF, MJCF or USD -> a sim-ready MJCF, URDF or USD with convex hulls",
        description="Write DIR/model.xml (MuJoCo), DIR/model.urdf (PyBullet), DIR/meshes/ and "
                    "DIR/conversion.json; --to urdf adds DIR/object.urdf (fixed base, loads in PyBullet, "
                    "MuJoCo and SAPIEN), --to usd DIR/object.usda (UsdPhysics articulation for Isaac Sim); their "
                    "hulls are within PhysX's 255 vertices and 255 polygons (one over them split, as "
                    "conversion.json's \"export\" says). CoACD results are cached under $SPARK_BENCH_HOME/coacd.")
    convert.add_argument("src", type=Path, help="object folder (mobility.urdf inside), or a URDF, MJCF (.xml) "
                                                "or USD (.usd/.usda/.usdc) file, read as it lies")
    convert.add_argument("--out", type=Path, required=True, help="output folder")
    convert.add_argument("--to", choices=EXPORT_FORMATS, default="mjcf",
                         help="the simulator format to write (default mjcf)")
    _add_options(convert)
    convert.add_argument("--json", action="store_true", help="print conversion.json instead of a summary")
    convert.set_defaults(func=run_convert)

    check = subparsers.add_parser(
        "check", help="sim-readiness checks (compile, PyBullet, mass, rest, penetration, joint sweep)",
        description="Convert SRC and run every check; exit 0 when all pass, 1 when any fails, 2 when SRC "
                    "cannot be read.")
    check.add_argument("src", type=Path, help="object folder, or a URDF, MJCF (.xml) or USD file, read as it lies")
    check.add_argument("--export", type=Path, default=None, metavar="DIR",
                       help="after a passing check, write the sim-ready asset into DIR (see --to)")
    check.add_argument("--to", choices=EXPORT_FORMATS, default="mjcf", help="the format --export writes")
    check.add_argument("--json", action="store_true",
                       help='print {"passed": bool, "checks": {name: {"passed", "value", ...}}}')
    check.add_argument("--engine", choices=("mujoco", "physx", "all"), default="mujoco",
                       help="the simulator(s) the checks run in (default mujoco; physx: SAPIEN 3 on the CPU, "
                            'pip install -e ".[physx]"; all: both, each verdict per check)')
    check.add_argument("--render", nargs="?", type=Path, const=Path(""), default=None, metavar="PNG",
                       help="write a PNG strip: rest and each joint opened, visuals above, hulls below "
                            "(default name check_<object>.png)")
    _add_options(check)
    check.set_defaults(func=run_check)


def _add_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--package-path", type=Path, action="append", default=[], metavar="DIR",
                        help="a folder holding ROS packages, for a URDF's package://NAME/ mesh paths "
                             "(repeatable; then $ROS_PACKAGE_PATH)")
    parser.add_argument("--density", type=float, default=None,
                        help="kg/m^3 for every link (default: by the object's category material)")
    parser.add_argument("--threshold", type=float, default=None, help="CoACD concavity threshold")
    parser.add_argument("--workers", type=int, default=0, help="CoACD processes (default: one per core)")
    parser.add_argument("--no-cache", action="store_true", help="do not read or write the CoACD cache")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def options_from_args(args):
    """:class:`ConvertOptions` from the shared command-line options."""
    from spark_bench.sim.options import ConvertOptions

    options = ConvertOptions(density=args.density, workers=args.workers, use_cache=not args.no_cache)
    if args.threshold is not None:
        options.coacd.threshold = float(args.threshold)
    return options


def source_of(args):
    """What ``check`` and ``convert`` read: an object folder as a path (its URDF confined to it, as before);
    a file named directly read as it lies (:func:`spark_bench.data.readers.load_object`: a URDF's mesh paths
    as ROS resolves them, ``--package-path``; MJCF with its own collision geoms; USD). A ``model.xml`` that
    ``convert`` wrote (``conversion.json`` beside it) stays a path: ``check`` checks it as converted."""
    from spark_bench.data.readers import load_object
    from spark_bench.sim.converter import MODEL_XML, REPORT_JSON

    src = Path(args.src)
    converted = src.name == MODEL_XML and (src.parent / REPORT_JSON).is_file()
    if not src.is_file() or converted:
        return src
    return load_object(src, package_paths=args.package_path)


def run_convert(args) -> int:
    from spark_bench.data.readers import read_json
    from spark_bench.sim.converter import REPORT_JSON
    from spark_bench.sim.export import export

    written = export(source_of(args), args.out, args.to, options_from_args(args), progress=not args.no_progress)
    path = written.model
    report = read_json(path.parent / REPORT_JSON)
    if args.json:
        print(json.dumps(report, indent=1, sort_keys=True))
    else:
        print(f"{path}  ({sum(report['hulls'].values())} hulls, {report['coacd']['calls']} CoACD calls, "
              f"{report['seconds']['total']:.2f} s){_split_note(written)}")
    return 0


def _split_note(written) -> str:
    """What PhysX's hull limits did to an export's hulls, for its one line (empty when nothing was split)."""
    hulls = written.physx_hulls
    if hulls is None or not hulls.n_split:
        return ""
    return (f"; {hulls.n_split} hull(s) over PhysX's 255 vertices or polygons split into pieces within them "
            f"({hulls.hulls} hulls written)")


def _export_after_check(args, src) -> None:
    """``check --export DIR``: write the checked asset as ``--to`` says (:mod:`spark_bench.sim.export`)."""
    from spark_bench.sim.export import export

    written = export(src, args.export, args.to, options_from_args(args), progress=False)
    print(f"exported {written.model}{_split_note(written)}", file=sys.stderr)


def run_check(args) -> int:
    from spark_bench.sim.checks import run_checks

    render = None
    if args.render is not None:
        render = args.render if str(args.render) not in ("", ".") else Path(f"check_{Path(args.src).resolve().name}.png")
    engine = getattr(args, "engine", "mujoco")
    if engine != "mujoco":
        return _run_engines_check(args, engine, render)
    src = source_of(args)
    report = run_checks(src, options_from_args(args), render=render, progress=not args.no_progress)
    if args.json:
        print(json.dumps(report.to_dict(), indent=1))
    else:
        width = max(len(name) for name in report.checks)
        for name, result in report.checks.items():
            mark = "pass" if result.passed else "FAIL"
            reason = f"  {result.details['reason']}" if "reason" in result.details else ""
            print(f"{name:<{width}}  {mark}  {result.value:.4g}{reason}")
        print(f"{report.name}: {'passed' if report.passed else 'failed'}")
    return _after_check(args, src, report.passed, render)


def _after_check(args, src, passed: bool, render: Path | None) -> int:
    """What follows a check's report: where its render went, the export (only when it passed), the exit code."""
    if render is not None and not args.json:
        print(f"wrote {render}", file=sys.stderr)
    if args.export is not None:
        if passed:
            _export_after_check(args, src)
        else:
            print(f"not exported to {args.export}: the check failed", file=sys.stderr)
    return 0 if passed else 1


def _run_engines_check(args, engine: str, render: Path | None) -> int:
    """``check --engine physx|all``: each engine's verdict per check (:mod:`spark_bench.sim.physx.engines`)."""
    from spark_bench.sim.physx import sapien_module
    from spark_bench.sim.physx.engines import check_engines, engine_names

    engines = engine_names(engine)
    if "physx" in engines:
        sapien_module()  # SAPIEN missing: one line saying what to install, before anything is converted
    src = source_of(args)
    reports = check_engines(src, engines, options_from_args(args), render=render, progress=not args.no_progress)
    if args.json:
        print(json.dumps(reports.to_dict(), indent=1))
    else:
        print("\n".join(reports.lines()))
    return _after_check(args, src, reports.passed, render)
