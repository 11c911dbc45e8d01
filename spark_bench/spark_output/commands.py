"""Commands for SPARK's real output: ``import spark``, ``data export-images`` and ``run-spark``.

``export-images`` joins the ``data`` group, which ``spark_bench.data.commands`` registers before this
module (``cli.COMMAND_MODULES`` lists them in that order); it is reached through the group parser's
:attr:`spark_bench.cli.CommandParser.subcommands`, argparse's public sub-command action.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from spark_bench.errors import SparkBenchError


def data_group(subparsers):
    """The sub-command action of the ``data`` group registered on ``subparsers``.

    :param subparsers: the top-level sub-command action of ``spark-bench``
    :raises SparkBenchError: when there is no ``data`` group with sub-commands (``spark_bench.data.commands``
        must come before this module in ``cli.COMMAND_MODULES``)
    """
    data = subparsers.choices.get("data")
    group = getattr(data, "subcommands", None)
    if group is None:
        raise SparkBenchError("`spark-bench data` must be registered before spark_bench.spark_output.commands "
                              "(see cli.COMMAND_MODULES)")
    return group


def add_export_images(sub) -> argparse.ArgumentParser:
    """Register ``export-images`` on a sub-command action (the ``data`` group's).

    :param sub: the sub-command action to add it to
    """
    p = sub.add_parser("export-images", help="write each case's input image as DIR/<case id>.png (SPARK's image/)",
                       description="Copy every case's input image to DIR/<case id>.png, ready to be SPARK's "
                                   "image/ folder: run.py names each run <case id>_<timestamp>, which "
                                   "`spark-bench import spark` maps back to the case.")
    p.add_argument("bench", type=Path, help="the benchmark folder")
    p.add_argument("--out", type=Path, required=True, help="the folder to write (e.g. SPARK/image)")
    p.add_argument("--cases", help="comma-separated case ids (default: every case)")
    p.set_defaults(func=run_export_images)
    return p


def add_commands(subparsers) -> None:
    """Register ``import spark``, ``data export-images`` (see the module docstring) and ``run-spark``."""
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

    add_export_images(data_group(subparsers))

    r = subparsers.add_parser("run-spark", help="run SPARK's stage scripts per case (on a machine with SPARK)",
                              description="Run SPARK's stages (its own scripts and flags, SPARK's folder as working "
                                          "directory) for each case of --bench, or for one --image, into "
                                          "OUTPUT/<case id or --name>_<timestamp>/; a stage whose output is "
                                          "missing is reported as failed. Then import the runs of a benchmark "
                                          "with `spark-bench import spark` (a single --image run is what the "
                                          "`spark` geometry backend of `ours` reads). Exit 0 when every run "
                                          "finished every stage, 1 otherwise.")
    r.add_argument("--spark", type=Path, required=True, help="SPARK's checkout (holding run.py)")
    what = r.add_mutually_exclusive_group(required=True)
    what.add_argument("--bench", type=Path, help="the benchmark folder: one run per case")
    what.add_argument("--image", type=Path, help="one image: one run (e.g. {image} of a geometry.spark_command)")
    r.add_argument("--name", default=None, help="with --image: the run's name (default: the image's file stem)")
    r.add_argument("--cases", help="with --bench: comma-separated case ids (default: every case)")
    r.add_argument("--skip", nargs="+", default=[], metavar="STAGE", help="stages to leave out (e.g. texture)")
    r.add_argument("--add", nargs="+", default=[], metavar="STAGE", help="stages to add (optimize)")
    r.add_argument("--python", default="python", help="SPARK's Python interpreter (default: python)")
    r.add_argument("--timeout", type=float, default=7200.0, help="seconds per program (default 7200)")
    r.add_argument("--inference-seed", type=int, default=0, help="PartCrafter seed (run.py: 0, tag FT5_G1_0)")
    r.add_argument("--output", type=Path, default=None, help="where run folders go (default SPARK/output)")
    r.set_defaults(func=run_spark_stages)


def _cases(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text else None


def run_import_spark(args) -> int:
    from spark_bench.spark_output.importer import import_runs

    report = import_runs(args.runs, args.bench, args.out, tag=args.tag, alignment=args.align, cases=_cases(args.cases))
    if args.json:
        print(json.dumps(report.to_dict(), indent=1))
    else:
        print("\n".join(report.lines()))
    if not report.imported:
        print("spark-bench: no SPARK run could be imported", file=sys.stderr)
    return report.exit_code


def run_export_images(args) -> int:
    from spark_bench.spark_output.export import export_images

    written, missing = export_images(args.bench, args.out, _cases(args.cases))
    print(f"wrote {len(written)} images into {args.out}")
    for line in missing:
        print(f"  skipped {line}")
    return 0 if written else 1


def run_spark_stages(args) -> int:
    from spark_bench.spark_output.driver import DriverConfig, SparkDriver

    config = DriverConfig.with_stages(skip=args.skip, add=args.add, python=args.python, timeout_s=args.timeout,
                                      inference_seed=args.inference_seed)
    driver = SparkDriver(args.spark, config, args.output)

    def report(run) -> None:
        failed = f"failed at {run.failed_stage}" if run.failed_stage else "every stage done"
        print(f"{run.case_id}: {run.run_dir.name}: {failed}", flush=True)

    if args.image is not None:
        runs = [driver.run_case(args.name or args.image.stem, args.image)]
        report(runs[0])
        print(f"label {config.label()}; run folder {runs[0].run_dir}")
    else:
        runs = driver.run_benchmark(args.bench, _cases(args.cases), progress=report)
        print(f"label {config.label()}; next: spark-bench import spark --runs {driver.output_dir} "
              f"--bench {args.bench} --out PRED")
    return 0 if runs and all(r.failed_stage is None for r in runs) else 1
