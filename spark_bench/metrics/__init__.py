"""Accuracy metrics: shape (Chamfer distance, F-Score) and articulation (AxisErr, PivotErr, TypeErr)
with Hungarian part matching, in the benchmark frame (docs/conventions.md).

The public names are loaded on first use, so that ``spark-bench --help`` (which imports
:mod:`spark_bench.metrics.commands`) does not pay for SciPy.
"""

from __future__ import annotations

from spark_bench.lazy import lazy_exports

_EXPORTS = {
    "compute_metrics": "spark_bench.metrics.evaluate",
    "ALIGN_MODES": "spark_bench.metrics.evaluate",
    "MetricsResult": "spark_bench.metrics.report",
    "JointMatch": "spark_bench.metrics.report",
    "mean_over_objects": "spark_bench.metrics.report",
    "mean_over_joints": "spark_bench.metrics.report",
    "joint_errors": "spark_bench.metrics.report",
    "mean_by_part_class": "spark_bench.metrics.report",
    "part_class": "spark_bench.metrics.geometry",
    "format_table": "spark_bench.metrics.report",
    "ShapeScores": "spark_bench.metrics.shape",
    "shape_scores": "spark_bench.metrics.shape",
    "scores_from_distances": "spark_bench.metrics.shape",
    "mutual_nearest_distances": "spark_bench.metrics.shape",
    "chamfer_distance": "spark_bench.metrics.shape",
    "FSCORE_THRESHOLDS": "spark_bench.metrics.shape",
    "axis_error": "spark_bench.metrics.articulation",
    "line_distance": "spark_bench.metrics.articulation",
    "same_type": "spark_bench.metrics.articulation",
    "compare_joints": "spark_bench.metrics.articulation",
    "JointAxis": "spark_bench.metrics.articulation",
    "match_parts": "spark_bench.metrics.matching",
    "align_points": "spark_bench.metrics.align",
    "Alignment": "spark_bench.metrics.align",
    "sample_triangles": "spark_bench.metrics.sampling",
}

__all__, __getattr__ = lazy_exports(__name__, _EXPORTS)
