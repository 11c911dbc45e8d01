"""``ours``: the SPARK pipeline on one benchmark case, stage by stage (see the package docstring).

:func:`run_ours` writes into ``out_dir``:

- the refined asset as a PartNet-Mobility object folder (``mobility.urdf``, ``textured_objs/``...);
- ``prior/``: the same object with the prior's joints, before any optimization (the "w/o joint
  optimization" variant of the ablation; with ``optimize.enabled = False`` both are the prior);
- ``retrieval.json``: with a ``retrieval`` backend, what the one retrieval of the case found (gallery,
  object, category, hashes, pose, score, the gallery check);
- ``prior.json``: the coarse URDF answer (reusable by the ``file`` prior backend; for the ``annotation``
  prior with its ``axis_frame``, the camera frame its axes are named in);
- ``spark_report.json``: config label, backends, prior and refined joints (world frame), the loss
  curve, candidate losses, timings and, when the ground truth is at hand, name-matched joint errors
  before and after (diagnostics; the official scores come from ``spark_bench.metrics``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

# the optimizers' modules (torch) load with the pipeline, so that no stage's time includes loading them
import spark_bench.methods.ours.refine  # noqa: F401
import spark_bench.methods.ours.spark_fit  # noqa: F401
from spark_bench.asset.joint_type import JointType
from spark_bench.errors import InputError
from spark_bench.jsonio import to_json_text
from spark_bench.methods.ours.assemble import joint_summary
from spark_bench.methods.ours.camera import load_camera
from spark_bench.methods.ours.config import SparkConfig
from spark_bench.methods.ours.diagnostics import joint_errors
from spark_bench.methods.ours.prior import assemble_prior, prior_document
from spark_bench.methods.ours.retrieved import retrieval_summary, retrieve_case
from spark_bench.methods.ours.stages import CaseRun, OptimizeOutcome
from spark_bench.timing import StageTimer

if TYPE_CHECKING:
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.methods.base import CaseInput
    from spark_bench.methods.ours.geometry import PartGeometry
    from spark_bench.methods.ours.structure import PriorStructure


def run_ours(case: CaseInput, out_dir: Path, config: SparkConfig | None = None) -> dict:
    """Run the SPARK pipeline on one case and write the refined and prior-only objects.

    Everything it reads of the case goes through ``case``, which refuses the inputs the method did not
    declare (:meth:`SparkConfig.case_inputs` are the ones ``config`` needs). Each stage is the backend
    ``config`` names (:mod:`spark_bench.methods.ours.stages`); the report's ``timings`` are the wall
    seconds of each stage and, as ``<stage>_cpu``, this process's CPU seconds (``optimize_cpu``: all of
    stage 4), with the optimizer's own phases as ``opt_*``.

    :param case: the case as the ``ours`` method sees it (:class:`~spark_bench.methods.base.CaseInput`)
    :param out_dir: where the object folder, ``prior/``, ``prior.json`` and ``spark_report.json`` go
    :param config: the pipeline configuration (default: everything offline)
    :returns: the report (also written to ``spark_report.json``)
    """
    from spark_bench.asset.urdf import write_object_folder

    config = config or SparkConfig()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    prior_stage, geometry_stage = config.prior_backend(), config.geometry_backend()
    run = CaseRun(config, case, out_dir, StageTimer())
    with run.timer("load"):
        run.gt = case.load_gt() if prior_stage.uses_gt_object or geometry_stage.uses_gt_object else None
    if config.uses_retrieval():  # one retrieval serves both stages
        with run.timer("retrieval"):
            run.found = retrieve_case(case, config.retrieval.gallery)
            (out_dir / "retrieval.json").write_text(to_json_text(run.found.record, indent=1) + "\n")

    with run.timer("prior"):
        # a geometry that does not need the prior's answer runs first: the prior is told its parts
        geometry = None if geometry_stage.after_prior else geometry_stage.run(run, None)
        prior, raw_answer, axis_frame = prior_stage.run(run, geometry)
        prior_json = out_dir / "prior.json"
        document = raw_answer if raw_answer is not None else prior_document(prior, axis_frame)
        prior_json.write_text(json.dumps(document, indent=1) + "\n")
    if geometry is None:
        with run.timer("geometry"):
            geometry = geometry_stage.run(run, prior_json)

    prior_asset = assemble_prior(prior, geometry, axis_frame, name=case.case_id, category=case.category)
    movable = [j.name for j in prior.joints if j.type != JointType.FIXED]
    report = {
        "case": case.case_id, "label": config.label(), "config": config.to_dict(),
        "backends": {"prior": config.prior.backend, "geometry": config.geometry.backend,
                     "open_state": config.open_state.backend,
                     "optimize": config.opt_name()},
        "geometry_is_ground_truth": geometry_stage.ground_truth_parts,
        **({"retrieval": retrieval_summary(run.found)} if run.found is not None else {}),
        "prior_joints": joint_summary(prior_asset, [j.name for j in prior.joints]),
    }
    if config.write_prior:
        write_object_folder(prior_asset, out_dir / "prior")

    refined_asset, phases = prior_asset, {}
    if config.optimize.enabled:
        with run.timer("optimize"):
            outcome = _optimize(run, prior, prior_asset, geometry)
        refined_asset, phases = outcome.asset, outcome.phases
        report.update(outcome.report)
    with run.timer("export"):
        write_object_folder(refined_asset, out_dir)
    report["refined_joints"] = joint_summary(refined_asset, [j.name for j in prior.joints])
    if run.gt is not None:
        truth = joint_summary(run.gt, [j.name for j in run.gt.movable_joints()])
        report["diagnostics"] = {"matched_by": "part name",
                                 "prior": joint_errors(report["prior_joints"], truth),
                                 "refined": joint_errors(report["refined_joints"], truth)}
    report["movable_joints"] = movable
    timings = {**run.timer.as_dict(), **{f"opt_{k}": v for k, v in phases.items()}}
    report["timings"] = {k: round(v, 4) for k, v in timings.items()}
    (out_dir / "spark_report.json").write_text(to_json_text(report, indent=1) + "\n")
    return report


def _optimize(run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset,
              geometry: PartGeometry) -> OptimizeOutcome:
    """Stage 4: the open state (the configured backend's), checked against the case camera, then the
    configured optimizer."""
    with run.timer("open_state"):
        open_state = run.config.open_state_backend().run(run)
        camera_path = run.case.path("camera")
        camera = load_camera(camera_path)
        if open_state.mask.shape != (camera.height, camera.width):
            # the optimizer compares renders from this camera with the mask pixel for pixel
            raise InputError(open_state.source, f"open-state mask is {open_state.mask.shape[1]} x "
                                                f"{open_state.mask.shape[0]} px, {camera_path.name} says "
                                                f"{camera.width} x {camera.height}")
    return run.config.optimizer().run(run, prior, prior_asset, geometry, open_state, camera)
