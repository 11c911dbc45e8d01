"""``spark-bench convert`` and ``spark-bench check``.

Exit codes of ``check``: 0 every check passed, 1 some failed, 2 the input cannot be read at all (the
CLI prints one line naming the file and the problem).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_commands(subparsers) -> None:
    """Register ``convert`` and ``check`` on the top-level ``spark-bench`` parser."""
    convert = subparsers.add_parser(
        "convert", help="object folder or URDF -> MJCF + PyBullet URDF with convex collision hulls",
        description="Write DIR/model.xml (MuJoCo), DIR/model.urdf (PyBullet), DIR/meshes/ and "
                    "DIR/conversion.json. CoACD results are cached under $SPARK_BENCH_HOME/coacd.")
    convert.add_argument("src", type=Path, help="object folder (mobility.urdf inside) or URDF file")
    convert.add_argument("--out", type=Path, required=True, help="output folder")
    _add_options(convert)
    convert.add_argument("--json", action="store_true", help="print conversion.json instead of a summary")
    convert.set_defaults(func=run_convert)

    check = subparsers.add_parser(
        "check", help="sim-readiness checks (compile, PyBullet, mass, rest, penetration, joint sweep)",
        description="Convert SRC and run every check; exit 0 when all pass, 1 when any fails, 2 when SRC "
                    "cannot be read.")
    check.add_argument("src", type=Path, help="object folder or URDF file")
    check.add_argument("--json", action="store_true",
                       help='print {"passed": bool, "checks": {name: {"passed", "value", ...}}}')
    check.add_argument("--render", nargs="?", type=Path, const=Path(""), default=None, metavar="PNG",
                       help="write a PNG strip: rest and each joint opened, visuals above, hulls below "
                            "(default name check_<object>.png)")
    _add_options(check)
    check.set_defaults(func=run_check)


def _add_options(parser: argparse.ArgumentParser) -> None:
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


def run_convert(args) -> int:
    from spark_bench.data.readers import read_json
    from spark_bench.sim.converter import REPORT_JSON, convert

    path = convert(args.src, args.out, options_from_args(args), progress=not args.no_progress)
    report = read_json(path.parent / REPORT_JSON)
    if args.json:
        print(json.dumps(report, indent=1, sort_keys=True))
    else:
        print(f"{path}  ({sum(report['hulls'].values())} hulls, {report['coacd']['calls']} CoACD calls, "
              f"{report['seconds']['total']:.2f} s)")
    return 0


def run_check(args) -> int:
    from spark_bench.sim.checks import run_checks

    render = None
    if args.render is not None:
        render = args.render if str(args.render) not in ("", ".") else Path(f"check_{Path(args.src).resolve().name}.png")
    report = run_checks(args.src, options_from_args(args), render=render, progress=not args.no_progress)
    if args.json:
        print(json.dumps(report.to_dict(), indent=1))
    else:
        width = max(len(name) for name in report.checks)
        for name, result in report.checks.items():
            mark = "pass" if result.passed else "FAIL"
            reason = f"  {result.details['reason']}" if "reason" in result.details else ""
            print(f"{name:<{width}}  {mark}  {result.value:.4g}{reason}")
        print(f"{report.name}: {'passed' if report.passed else 'failed'}")
        if render is not None:
            print(f"wrote {render}", file=sys.stderr)
    return 0 if report.passed else 1
