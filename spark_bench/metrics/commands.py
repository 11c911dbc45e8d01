"""``spark-bench metrics``: shape and articulation metrics of one prediction against its ground truth."""

from __future__ import annotations

import argparse


def add_commands(subparsers) -> None:
    """Register ``metrics`` on the ``spark-bench`` sub-command parser."""
    parser = subparsers.add_parser(
        "metrics", help="shape and articulation metrics of a predicted object against the ground truth",
        description="Chamfer distance and F-Score (rest, open, per part), AxisErr, PivotErr and TypeErr "
                    "with Hungarian part matching. PRED and GT are object folders or URDF files; each is "
                    "normalized into its own benchmark frame.")
    parser.add_argument("--pred", required=True, help="predicted object folder or URDF file")
    parser.add_argument("--gt", required=True, help="ground-truth object folder or URDF file")
    parser.add_argument("--align", choices=("none", "icp"), default="none",
                        help="align the prediction first: yaw/scale grid then ICP (default: none)")
    parser.add_argument("--samples", type=_positive_int, default=100_000,
                        help="surface samples per shape (default: 100000)")
    parser.add_argument("--match-samples", type=_positive_int, default=10_000,
                        help="surface samples per part for the part matching (default: 10000)")
    parser.add_argument("--seed", type=int, default=0, help="sampling seed (default: 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.set_defaults(func=run_metrics)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text}")
    return value


def run_metrics(args: argparse.Namespace) -> int:
    """Load both objects, compute the metrics, print them; returns the exit code."""
    import json

    from spark_bench.data import load_object
    from spark_bench.metrics.evaluate import compute_metrics
    from spark_bench.metrics.report import format_table

    pred = load_object(args.pred)
    gt = load_object(args.gt)
    pred.source = pred.source or str(args.pred)
    gt.source = gt.source or str(args.gt)
    result = compute_metrics(pred, gt, n_samples=args.samples, seed=args.seed, align=args.align,
                             n_match_samples=args.match_samples)
    if args.json:
        print(json.dumps(result.to_dict(), allow_nan=False))
    else:
        print(format_table(result))
    return 0
