"""Joint errors against the ground truth matched by part name, and the noise-model calibration.

The official articulation metrics live in :mod:`spark_bench.metrics` (Hungarian matching of parts). When
the prior comes from the annotation, each predicted joint moves exactly one ground-truth part of the same
name, so matching by name is exact; these diagnostics use it to report before/after errors in
``spark_report.json`` and to calibrate :class:`~spark_bench.methods.ours.prior.NoiseModel` without the metrics
package's part matching. Per joint, the errors are the metrics' own (:mod:`spark_bench.metrics.articulation`):
AxisErr (radians, sign ignored), PivotErr (FreeArt3D's rule: for every ground-truth revolute or
continuous joint, the distance between its axis line and the predicted joint's line, whatever the
predicted type), TypeErr (continuous counts as revolute; a missing joint is an error).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.metrics.articulation import axis_error, line_distance, type_class


def joint_errors(predicted: Sequence[dict], truth: Sequence[dict]) -> dict:
    """Per-object errors of world-frame joints (case.json form, matched by ``child``).

    :returns: ``{"axis_err", "pivot_err", "type_err", "joints": [...]}``; ``pivot_err`` is None when no
        ground-truth joint rotates
    """
    by_child = {j["child"]: j for j in predicted}
    rows = []
    for gt in truth:
        if type_class(gt["type"]) == JointType.FIXED:
            continue
        pred = by_child.get(gt["child"])
        if pred is None:
            rows.append({"joint": gt["name"], "axis_err": None, "pivot_err": None, "type_err": 1.0})
            continue
        rotational = type_class(gt["type"]) == JointType.REVOLUTE
        rows.append({
            "joint": gt["name"],
            "axis_err": axis_error(pred["axis"], gt["axis"]),
            "pivot_err": line_distance(pred["origin"], pred["axis"], gt["origin"], gt["axis"])
            if rotational else None,
            "type_err": float(type_class(pred["type"]) != type_class(gt["type"])),
        })

    def mean(key):
        values = [r[key] for r in rows if r[key] is not None]
        return float(np.mean(values)) if values else None

    return {"axis_err": mean("axis_err"), "pivot_err": mean("pivot_err"), "type_err": mean("type_err"),
            "joints": rows}


def mean_errors(per_object: Sequence[dict]) -> dict:
    """Benchmark means over objects of AxisErr, PivotErr, TypeErr (objects without a value skipped)."""
    out = {}
    for key in ("axis_err", "pivot_err", "type_err"):
        values = [o[key] for o in per_object if o.get(key) is not None]
        out[key] = float(np.mean(values)) if values else None
    return out


#: Where :func:`calibrate_noise` restarts a parameter that is 0 while its error is below the target.
RESTART = {"p_axis": 0.05, "p_type": 0.05, "sigma_origin": 0.05}
#: The paper's "w/o joint optimization" row (Table 4).
PAPER_PRIOR_ERRORS = {"axis_err": 0.3148, "pivot_err": 0.2388, "type_err": 0.20}


def calibrate_noise(ground_truths: Sequence[tuple], noise, target: dict | None = None,
                    iterations: int = 6, seeds: Sequence[int] = (0, 1, 2),
                    progress: Callable[[str], None] | None = None):
    """Fit ``p_axis``, ``p_type`` and ``sigma_origin`` of a noise model to target prior errors.

    Each iteration scales each parameter by ``target / measured`` of its own error (AxisErr for
    ``p_axis``, TypeErr for ``p_type``, PivotErr for ``sigma_origin``; a parameter at 0 whose error is
    below its target restarts at :data:`RESTART`; one whose error stays above it with no noise at all,
    such as AxisErr from the view alone, goes to 0), measured as the mean over
    ``seeds`` of the annotation prior's errors on ``ground_truths``. Run it on ``synth-v1`` once the
    benchmark exists: ``calibrate_noise([(case.id, case.load_gt()) for case in Benchmark(folder).cases()], NoiseModel())``.

    :param ground_truths: ``(case id, ground-truth ArticulatedAsset)`` pairs, or ``(case id, asset,
        axis frame)`` triples (:func:`~spark_bench.methods.ours.prior.camera_axis_frame` of the case's camera:
        the prior's axes snapped in the camera's frame, as :func:`~spark_bench.methods.ours.pipeline.run_ours`
        does)
    :param noise: the starting :class:`~spark_bench.methods.ours.prior.NoiseModel`
    :param target: errors to reach (default :data:`PAPER_PRIOR_ERRORS`)
    :returns: ``(calibrated noise model, measured errors)``
    """
    from spark_bench.methods.ours.assemble import joint_summary
    from spark_bench.methods.ours.geometry import annotation_geometry
    from spark_bench.methods.ours.prior import annotation_prior, assemble_prior

    target = target or PAPER_PRIOR_ERRORS
    prepared = [(item[0], item[1], item[2] if len(item) > 2 else None, annotation_geometry(item[1]),
                 joint_summary(item[1], [j.name for j in item[1].movable_joints()])) for item in ground_truths]
    measured: dict = {}
    for it in range(iterations):
        per_object = []
        for seed in seeds:
            trial = replace(noise, seed=seed)
            for cid, gt, frame, geometry, truth in prepared:
                prior = assemble_prior(annotation_prior(gt, cid, trial, axis_frame=frame), geometry, frame)
                per_object.append(joint_errors(joint_summary(prior), truth))
        measured = mean_errors(per_object)
        if progress:
            progress(f"calibration {it}: {noise} -> {measured}")
        updates = {}
        for key, param in (("axis_err", "p_axis"), ("type_err", "p_type"), ("pivot_err", "sigma_origin")):
            value = getattr(noise, param)
            if value == 0 and measured.get(key) is not None and measured[key] < target[key]:
                updates[param] = RESTART[param]  # a scale cannot leave 0: restart where it can
            elif measured.get(key):
                scaled = value * target[key] / measured[key]
                updates[param] = float(min(scaled, 1.0) if param != "sigma_origin" else scaled)
        noise = replace(noise, **updates)
    return noise, measured
