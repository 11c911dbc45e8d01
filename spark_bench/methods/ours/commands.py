"""``spark-bench run-spark``: SPARK's own stage scripts run per case (:mod:`spark_bench.methods.ours.run_spark`),
on a machine that has SPARK; what they write is read back by ``spark-bench import spark``."""

from __future__ import annotations

from pathlib import Path


def add_commands(subparsers) -> None:
    """Register ``run-spark``."""
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


def run_spark_stages(args) -> int:
    from spark_bench.methods.ours.run_spark import DriverConfig, SparkDriver

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
