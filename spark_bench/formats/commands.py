"""``spark-bench import FORMAT``: another program's output -> a predictions folder (one object folder per
case): ``import spark`` (SPARK's run folders, :mod:`spark_bench.formats.spark`) and one sub-command per format
of :data:`spark_bench.formats.FORMATS` (:mod:`spark_bench.formats.runs`)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from spark_bench.formats import FORMATS, RUN_FILE_SUFFIXES


def add_commands(subparsers) -> None:
    """Register ``import`` and its formats (``import spark``)."""
    imp = subparsers.add_parser("import", help="import another method's output as a predictions folder")
    isub = imp.add_subparsers(dest="import_command", required=True, metavar="SOURCE")
    p = isub.add_parser("spark", help="SPARK's run folders (SPARK/output) -> PRED/<case id>/",
                        description="Map SPARK's output/<case id>_<YYYYmmdd_HHMMSS>/ folders to the benchmark's "
                                    "cases (newest wins), read each into the benchmark frame and write "
                                    "PRED/<case id>/ with its import.json. Exit 0 when at least one run was "
                                    "imported, 1 when none could be, 2 on bad arguments.")
    p.add_argument("--runs", type=Path, required=True, help="SPARK's output folder (SPARK/output)")
    p.add_argument("--bench", type=Path, required=True, help="the benchmark folder the images came from")
    p.add_argument("--out", type=Path, required=True, help="the predictions folder to write")
    p.add_argument("--tag", default=None, help="inference tag, inference/<tag>/ (default: FT5_G1_0, else the only one)")
    p.add_argument("--align", choices=("icp", "camera"), default="icp",
                   help="icp (default): leave the turn about the up axis and the scale to `eval --align icp`; "
                        "camera: turn SPARK's +Z (towards its camera) to face the case camera")
    p.add_argument("--cases", help="comma-separated case ids (default: every case)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=run_import_spark)
    for name in sorted(FORMATS):
        files = "".join(f" or DIR/<case id>{suffix}" for suffix in RUN_FILE_SUFFIXES.get(name, ()))
        f = isub.add_parser(name, help=f"{name} runs, DIR/<case id>/ -> PRED/<case id>/",
                            description=f"Read DIR/<case id>/{files} (one case's output, as the method writes it) with "
                                        f"the {name} reader into the benchmark frame and write PRED/<case id>/ "
                                        f"with its import.json. Exit 0 when at least one run was imported, 1 "
                                        f"when none could be, 2 on bad arguments.")
        f.add_argument("--runs", type=Path, required=True, help="the folder of runs, one per case id")
        f.add_argument("--bench", type=Path, required=True, help="the benchmark folder")
        f.add_argument("--out", type=Path, required=True, help="the predictions folder to write")
        f.add_argument("--cases", help="comma-separated case ids (default: every case)")
        f.add_argument("--json", action="store_true", help="print the report as JSON")
        f.set_defaults(func=run_import_format, format=name)


def _cases(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text else None


def run_import_spark(args) -> int:
    from spark_bench.formats.spark.importer import import_runs

    report = import_runs(args.runs, args.bench, args.out, tag=args.tag, alignment=args.align, cases=_cases(args.cases))
    if args.json:
        print(json.dumps(report.to_dict(), indent=1))
    else:
        print("\n".join(report.lines()))
    if not report.imported:
        print("spark-bench: no SPARK run could be imported", file=sys.stderr)
    return report.exit_code


def run_import_format(args) -> int:
    from spark_bench.formats.runs import import_runs

    report = import_runs(args.format, args.runs, args.bench, args.out, cases=_cases(args.cases))
    print(json.dumps(report.to_dict(), indent=1) if args.json else "\n".join(report.lines()))
    if not report.imported:
        print(f"spark-bench: no {args.format} run could be imported", file=sys.stderr)
    return report.exit_code
