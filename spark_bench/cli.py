"""The ``spark-bench`` command.

Each package contributes its sub-commands through a ``commands`` module with an
``add_commands(subparsers)`` function, so this file never grows with the features and
``spark-bench --help`` stays fast (heavy imports happen inside each command).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from spark_bench import __version__
from spark_bench.errors import SparkBenchError

#: The modules that add sub-commands, in the order ``spark-bench --help`` lists them.
COMMAND_MODULES = (
    "spark_bench.data.commands",
    "spark_bench.formats.commands",
    "spark_bench.methods.ours.commands",
    "spark_bench.metrics.commands",
    "spark_bench.sim.commands",
    "spark_bench.rl.commands",
    "spark_bench.evaluation.commands",
)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser, with every sub-command that is installed."""
    parser = argparse.ArgumentParser(
        prog="spark-bench",
        description="Benchmark single-image articulated-object reconstruction: accuracy and sim-readiness.",
    )
    parser.add_argument("--version", action="version", version=f"spark-bench {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:  # that feature is not part of this build
                continue
            raise
        module.add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: parse ``argv`` and run the chosen command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = args.func(args)
    except SparkBenchError as exc:
        print(f"spark-bench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("spark-bench: interrupted", file=sys.stderr)
        return 130
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
