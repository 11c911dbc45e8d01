"""``spark-bench metrics``: shape and articulation metrics of one prediction against its ground truth."""

from __future__ import annotations

import argparse


def add_commands(subparsers) -> None:
    """Register ``metrics`` on the ``spark-bench`` sub-command parser."""
    parser = subparsers.add_parser(
        "metrics", help="shape and articulation metrics of a predicted object against the ground truth",
        description="Chamfer distance and F-Score (rest, open, per part), AxisErr, PivotErr and TypeErr "
                    "with Hungarian part matching. PRED and GT are object folders, URDF, MJCF or USD files; each is "
                    "normalized into its own benchmark frame.")
    parser.add_argument("--pred", required=True, help="predicted object folder, URDF, MJCF (.xml) or USD file")
    parser.add_argument("--gt", required=True, help="ground-truth object folder, URDF, MJCF (.xml) or USD file")
    parser.add_argument("--package-path", action="append", default=[], metavar="DIR",
                        help="a folder holding ROS packages, for a URDF's package://NAME/ mesh paths "
                             "(repeatable; then $ROS_PACKAGE_PATH)")
    parser.add_argument("--align", choices=("none", "icp"), default="none",
                        help="align the prediction first: yaw/scale grid then ICP (default: none)")
    parser.add_argument("--samples", type=_positive_int, default=100_000,
                        help="surface samples per shape (default: 100000)")
    parser.add_argument("--match-samples", type=_positive_int, default=10_000,
                        help="surface samples per part for the part matching (default: 10000)")
    parser.add_argument("--seed", type=int, default=0, help="sampling seed (default: 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument("--protocol", action="append", metavar="NAME",
                        help="score as a paper's own evaluation code does instead (repeatable, or 'all'): "
                             "spark, articulate-anything, urdf-anything, real2code, freeart3d, partcrafter, "
                             "singapo, cage; each protocol uses its paper's frame and sample counts "
                             "(--align, --samples and --match-samples do not apply; see docs/protocols.md)")
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

    protocols = None
    if args.protocol:
        from spark_bench.metrics.protocols import protocol_names

        protocols = protocol_names(args.protocol)  # an unknown name fails before any loading
    pred = load_object(args.pred, package_paths=args.package_path)
    gt = load_object(args.gt, package_paths=args.package_path)
    pred.source = pred.source or str(args.pred)
    gt.source = gt.source or str(args.gt)
    if protocols is not None:
        return _print_protocols(protocols, pred, gt, args.seed, args.json)
    result = compute_metrics(pred, gt, n_samples=args.samples, seed=args.seed, align=args.align,
                             n_match_samples=args.match_samples)
    warnings = read_warnings(pred, gt)
    if args.json:
        print(json.dumps({**result.to_dict(), **({"warnings": warnings} if warnings else {})}, allow_nan=False))
    else:  # the readers log each warning on stderr as they read
        print(format_table(result))
    return 0


def read_warnings(pred, gt) -> dict[str, list[str]]:
    """What reading each object left out (``ArticulatedAsset.warnings``: a material's shader file not found, a
    sublayer not composed), by side; empty when there is nothing to say."""
    return {side: list(asset.warnings) for side, asset in (("pred", pred), ("gt", gt)) if asset.warnings}


def _print_protocols(names: list[str], pred, gt, seed: int, as_json: bool) -> int:
    """Score under each protocol and print: one JSON object per protocol (a list when several), or a
    table per protocol."""
    import json

    from spark_bench.metrics.protocols import score

    results = [score(name, pred, gt, seed) for name in names]
    if as_json:
        payload = [r.to_dict() for r in results]
        print(json.dumps(payload[0] if len(payload) == 1 else payload, allow_nan=False))
        return 0
    for result in results:
        print(f"protocol {result.protocol}")
        for key, value in result.metrics.items():
            shown = "-" if value is None else f"{value:.6g}"
            print(f"  {key:<32} {shown:>12}  {result.units.get(key, '')}")
        for note in result.notes:
            print(f"  note: {note}")
    return 0
