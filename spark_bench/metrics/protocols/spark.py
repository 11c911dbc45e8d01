"""spark-bench's own protocol (the SPARK paper, ``/work/shared/paper/spark_paper.tex``), through the
protocol interface: exactly the numbers of ``spark-bench metrics`` (:func:`spark_bench.metrics.evaluate.compute_metrics`
with its defaults, no alignment), nothing recomputed.

- **Frame**: each asset in its own benchmark frame (rest-pose box centred, longest side 2;
  :func:`spark_bench.metrics.geometry.benchmark_transform`).
- **Shape**: Chamfer distance (unsquared, mean of the two one-sided means) and F-Score at 0.1 and 0.5, on
  100,000 seeded surface samples, at rest, at the open state and per matched part
  (:mod:`spark_bench.metrics.shape`).
- **Articulation**: parts matched by the Hungarian algorithm on part Chamfer distance
  (:mod:`spark_bench.metrics.matching`); AxisErr (radians, sign-free), PivotErr (axis-line distance,
  FreeArt3D's rule, :mod:`spark_bench.metrics.articulation`), TypeErr (unmatched or other type; continuous
  counts as revolute); per object, means over its joints.

spark-bench defines no joint success, so there is no ``joint_success_rate`` here.
"""

from __future__ import annotations

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.names import UNITS
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult

INFO = ProtocolInfo(
    name="spark",
    paper="SPARK (this benchmark)",
    source="spark_bench/metrics/evaluate.py (compute_metrics), articulation.py, shape.py, matching.py",
    units={"cd": UNITS["cd"], "fscore@0.1": UNITS["fscore"], "fscore@0.5": UNITS["fscore"],
           "cd_open": UNITS["cd"], "fscore_open@0.1": UNITS["fscore"], "fscore_open@0.5": UNITS["fscore"],
           "part_cd": UNITS["cd"], "part_fscore@0.1": UNITS["fscore"], "part_fscore@0.5": UNITS["fscore"],
           "axis_err": UNITS["axis_err"], "pivot_err": UNITS["pivot_err"], "type_err": UNITS["type_err"],
           "n_missing_joints": "count", "n_extra_joints": "count"},
    columns=(("cd", "CD"), ("fscore@0.1", "F@0.1"), ("cd_open", "CD open"), ("part_cd", "Part CD"),
             ("axis_err", "AxisErr"), ("pivot_err", "PivotErr"), ("type_err", "TypeErr")),
    differs="spark-bench's own convention (benchmark frame, longest side 2, unsquared CD, radians).")


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """``spark-bench metrics``'s numbers of ``pred`` against ``gt``, unchanged.

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed
    """
    from spark_bench.metrics.evaluate import compute_metrics

    result = compute_metrics(pred, gt, seed=seed).to_dict()
    metrics = {key: (None if result.get(key) is None else float(result[key])) for key in INFO.units}
    notes = []
    if result["missing_joints"]:
        notes.append(f"ground-truth joints without a match: {', '.join(result['missing_joints'])}")
    return ProtocolResult(INFO.name, metrics, dict(INFO.units), notes)
