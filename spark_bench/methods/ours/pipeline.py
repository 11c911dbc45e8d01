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
import time
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from spark_bench.data.images import image_rgb
from spark_bench.errors import InputError
from spark_bench.jsonio import to_json_text
from spark_bench.methods.ours.assemble import assemble_asset, joint_summary
from spark_bench.methods.ours.camera import load_camera
from spark_bench.methods.ours.config import SparkConfig
from spark_bench.methods.ours.diagnostics import joint_errors
from spark_bench.methods.ours.geometry import (
    PartGeometry,
    annotation_geometry,
    predictions_geometry,
    spark_geometry,
)
from spark_bench.methods.ours.open_state import (
    RENDER_TOLERANCE,
    OpenState,
    dataset_open_state,
    http_open_state,
)
from spark_bench.methods.ours.optimize import OpenStateScene
from spark_bench.methods.ours.prior import (
    annotation_prior,
    assemble_prior,
    camera_axis_frame,
    file_prior_with_frame,
    prior_document,
)
from spark_bench.methods.ours.refine import RefineSettings, refine
from spark_bench.methods.ours.retrieved import (
    retrieval_geometry,
    retrieval_prior,
    retrieval_summary,
    retrieve_case,
)
from spark_bench.methods.ours.spark_fit import spark_fit, spark_mask
from spark_bench.methods.ours.structure import PriorStructure
from spark_bench.methods.ours.vlm import request_structure

if TYPE_CHECKING:
    from spark_bench.methods.base import CaseInput


@contextmanager
def torch_threads(n: int):
    """Run with ``n`` torch CPU threads, then restore the previous count."""
    before = torch.get_num_threads()
    torch.set_num_threads(max(1, int(n)))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _geometry(config: SparkConfig, case: CaseInput, gt, prior_json: Path | None, work: Path,
              found=None) -> PartGeometry:
    backend = config.geometry.backend
    if backend == "annotation":
        return annotation_geometry(gt)
    if backend == "retrieval":
        return retrieval_geometry(found)
    if backend == "predictions":
        return predictions_geometry(config.geometry.predictions_dir, case.case_id)
    return spark_geometry(config.geometry.spark_command, case, prior_json, work, config.geometry.timeout_s)


def _prior(config: SparkConfig, case: CaseInput, gt, geometry: PartGeometry | None, found=None):
    """``(prior, raw answer or None, axis frame or None)``: the axis frame is the one the prior's axis
    names mean (the camera's for ``annotation``, see :mod:`spark_bench.methods.ours.prior`; the retrieved
    object's own for ``retrieval``; None: the object's)."""
    backend = config.prior.backend
    if backend == "retrieval":
        prior, frame = retrieval_prior(found)
        return prior, None, frame
    known = geometry.names if geometry is not None else None
    if backend == "annotation":
        frame = camera_axis_frame(load_camera_pose(case.path("camera")))
        return annotation_prior(gt, case.case_id, config.prior.noise, axis_frame=frame), None, frame
    if backend == "file":
        prior, frame = file_prior_with_frame(config.prior.file_dir, case.case_id, known)
        return prior, None, frame
    prior, raw = request_structure(config.vlm, _input_image(case), known, geometry.labels if geometry else None)
    return prior, raw, None


def load_camera_pose(path: Path) -> np.ndarray:
    """The 4x4 camera-to-world pose of a case's ``camera.json``."""
    camera = load_camera(path)
    return np.linalg.inv(camera.world_to_camera)


def _input_image(case: CaseInput) -> bytes:
    image = case.image
    if not image.is_file():
        raise InputError(image, "input image not found")
    return image.read_bytes()


def _open_state(config: SparkConfig, case: CaseInput) -> OpenState:
    if config.open_state.backend == "dataset":
        return dataset_open_state(case, config.uses_part_masks())
    return http_open_state(config.open_state, _input_image(case))


def run_ours(case: CaseInput, out_dir: Path, config: SparkConfig | None = None) -> dict:
    """Run the SPARK pipeline on one case and write the refined and prior-only objects.

    Everything it reads of the case goes through ``case``, which refuses the inputs the method did not
    declare (:meth:`SparkConfig.case_inputs` are the ones ``config`` needs).

    :param case: the case as the ``ours`` method sees it (:class:`~spark_bench.methods.base.CaseInput`)
    :param out_dir: where the object folder, ``prior/``, ``prior.json`` and ``spark_report.json`` go
    :param config: the pipeline configuration (default: everything offline)
    :returns: the report (also written to ``spark_report.json``)
    """
    from spark_bench.asset.urdf import write_object_folder

    config = config or SparkConfig()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    timings: dict[str, float] = {}
    tick = time.perf_counter()
    case_id = case.case_id
    needs_gt = "annotation" in (config.prior.backend, config.geometry.backend)
    gt = case.load_gt() if needs_gt else None
    timings["load"] = time.perf_counter() - tick
    found = None
    if config.uses_retrieval():  # one retrieval serves both stages
        tick = time.perf_counter()
        found = retrieve_case(case, config.retrieval.gallery)
        (out_dir / "retrieval.json").write_text(to_json_text(found.record, indent=1) + "\n")
        timings["retrieval"] = time.perf_counter() - tick

    tick = time.perf_counter()
    geometry = None
    if config.geometry.backend != "spark":  # these know the parts before the prior
        geometry = _geometry(config, case, gt, None, out_dir, found)
    prior, raw_answer, axis_frame = _prior(config, case, gt, geometry, found)
    prior_json = out_dir / "prior.json"
    document = raw_answer if raw_answer is not None else prior_document(prior, axis_frame)
    prior_json.write_text(json.dumps(document, indent=1) + "\n")
    timings["prior"] = time.perf_counter() - tick
    if geometry is None:
        tick = time.perf_counter()
        geometry = _geometry(config, case, gt, prior_json, out_dir)
        timings["geometry"] = time.perf_counter() - tick

    prior_asset = assemble_prior(prior, geometry, axis_frame, name=case_id, category=case.category)
    movable = [j.name for j in prior.joints if j.type != "fixed"]
    report = {
        "case": case_id, "label": config.label(), "config": config.to_dict(),
        "backends": {"prior": config.prior.backend, "geometry": config.geometry.backend,
                     "open_state": config.open_state.backend,
                     "optimize": config.opt_name()},
        "geometry_is_ground_truth": config.geometry.backend == "annotation",
        **({"retrieval": retrieval_summary(found)} if found is not None else {}),
        "prior_joints": joint_summary(prior_asset, [j.name for j in prior.joints]),
    }
    if config.write_prior:
        write_object_folder(prior_asset, out_dir / "prior")

    refined_asset = prior_asset
    if config.optimize.enabled:
        cpu = time.process_time()
        refined_asset, opt_report = _optimize(config, case, prior, prior_asset, geometry, timings)
        timings["optimize_cpu"] = time.process_time() - cpu  # this process's CPU seconds, all of stage 4
        report.update(opt_report)
    tick = time.perf_counter()
    write_object_folder(refined_asset, out_dir)
    timings["export"] = time.perf_counter() - tick
    report["refined_joints"] = joint_summary(refined_asset, [j.name for j in prior.joints])
    if gt is not None:
        truth = joint_summary(gt, [j.name for j in gt.movable_joints()])
        report["diagnostics"] = {"matched_by": "part name",
                                 "prior": joint_errors(report["prior_joints"], truth),
                                 "refined": joint_errors(report["refined_joints"], truth)}
    report["movable_joints"] = movable
    report["timings"] = {k: round(v, 4) for k, v in timings.items()}
    (out_dir / "spark_report.json").write_text(to_json_text(report, indent=1) + "\n")
    return report


def _optimize(config: SparkConfig, case: CaseInput, prior: PriorStructure, prior_asset, geometry, timings):
    tick = time.perf_counter()
    open_state = _open_state(config, case)
    camera_path = case.path("camera")
    camera = load_camera(camera_path)
    if open_state.mask.shape != (camera.height, camera.width):
        # the optimizer compares renders from this camera with the mask pixel for pixel
        raise InputError(open_state.source, f"open-state mask is {open_state.mask.shape[1]} x "
                                            f"{open_state.mask.shape[0]} px, {camera_path.name} says "
                                            f"{camera.width} x {camera.height}")
    timings["open_state"] = time.perf_counter() - tick
    if config.optimize.method == "spark":
        return _optimize_spark(config, case, prior_asset, open_state, camera, timings)
    start_asset = prior_asset
    if config.optimize.refine == "vlm":  # the paper's re-prediction of type and axis, then the fit
        tick = time.perf_counter()
        reprior, _ = request_structure(config.vlm, _input_image(case), geometry.names, geometry.labels,
                                       refine_from=prior)
        start_asset = assemble_asset(reprior, geometry, name=prior_asset.name, category=prior_asset.category)
        timings["vlm_refine"] = time.perf_counter() - tick
    tick = time.perf_counter()
    with torch_threads(config.optimize.threads):
        part_masks = _part_masks(config, open_state, geometry, start_asset)
        scene = OpenStateScene(start_asset, camera, open_state.mask, config.optimize.max_faces, part_masks)
        result = refine(start_asset, scene, RefineSettings.from_config(config.optimize))
    timings["joint_optimization"] = time.perf_counter() - tick
    timings.update({f"opt_{k}": v for k, v in result.timings.items()})
    return result.asset, {
        "open_state_source": open_state.source,
        "part_masks": sorted(scene.part_masks_full),
        "loss_curve": [round(v, 6) for v in result.curve],
        "loss_prior": result.loss_prior, "loss_refined": result.loss_final,
        "candidates": result.candidates,
        "hypotheses": {n: {"type": h.type, "axis": np.round(h.axis, 10).tolist(),
                           "pivot_offset": np.round(h.pivot_offset, 10).tolist(), "value": h.value, "from": h.tag}
                       for n, h in result.hypotheses.items()},
    }


def _optimize_spark(config: SparkConfig, case: CaseInput, prior_asset, open_state: OpenState, camera, timings):
    """SPARK's own recipe (:mod:`spark_bench.methods.ours.spark_fit`): its masks of the open and the closed
    (input) images, then each revolute joint's pivot and angle."""
    settings = config.optimize.spark
    tick = time.perf_counter()
    if open_state.rgb is not None:
        open_mask, open_rule = spark_mask(open_state.rgb, settings.threshold, open_state.tolerance)
    else:
        open_mask, open_rule = open_state.mask, "open-state mask"
    closed_mask, closed_rule = spark_mask(_read_rgb(case.image), settings.threshold, RENDER_TOLERANCE)
    if closed_mask.shape != (camera.height, camera.width):
        raise InputError(case.image, f"input image is {closed_mask.shape[1]} x {closed_mask.shape[0]} px, the "
                                     f"camera says {camera.width} x {camera.height}")
    timings["spark_masks"] = time.perf_counter() - tick
    tick = time.perf_counter()
    with torch_threads(config.optimize.threads):
        scene = OpenStateScene(prior_asset, camera, open_mask, settings.max_faces)
        result = spark_fit(prior_asset, scene, closed_mask, settings)
    timings["joint_optimization"] = time.perf_counter() - tick
    timings.update({f"opt_{k}": v for k, v in result.timings.items()})
    return result.asset, {
        "open_state_source": open_state.source, "target_rule": {"open": open_rule, "closed": closed_rule},
        "part_masks": [], "loss_curve": [round(v, 6) for v in result.curve], "closed_loss": result.closed_loss,
        "spark_joints": result.joints,
        "hypotheses": {n: {"type": h.type, "axis": np.round(h.axis, 10).tolist(),
                           "pivot_offset": np.round(h.pivot_offset, 10).tolist(), "value": h.value, "from": h.tag}
                       for n, h in result.hypotheses.items()},
    }


def _read_rgb(path: Path) -> np.ndarray:
    from PIL import Image

    if not path.is_file():
        raise InputError(path, "input image not found")
    try:
        with Image.open(path) as image:
            return image_rgb(image)
    except OSError as exc:
        raise InputError(path, f"unreadable image: {exc}") from None


def _part_masks(config: SparkConfig, open_state: OpenState, geometry: PartGeometry, asset) -> dict | None:
    """The open state's per-link masks as masks of the asset's parts, where the parts are known to be
    the case's own links (``annotation`` geometry: a part is a group of ground-truth links, its mask the
    union of theirs); None otherwise or when ``optimize.part_masks`` is off."""
    if not (config.optimize.part_masks and open_state.part_masks and config.geometry.backend == "annotation"):
        return None
    out = {}
    for part, links in geometry.members.items():
        masks = [open_state.part_masks[n] for n in links if n in open_state.part_masks]
        if part in asset.links and masks:
            out[part] = np.clip(np.sum(masks, axis=0), 0.0, 1.0)
    return out or None
