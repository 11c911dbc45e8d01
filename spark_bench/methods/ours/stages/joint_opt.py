"""Stage 4, the joint optimization: its methods (``[optimize] method``), one class each (the ``native``
method's type/axis refinements, ``[optimize] refine``, are :mod:`.refinements`'). ``[optimize] enabled =
false`` runs none (``opt=none``).

A new method is one more class here, registered with ``@OPTIMIZERS.register``. torch is imported when one
runs, so that reading a configuration does not import it.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from spark_bench.data.images import RENDER_TOLERANCE, image_rgb
from spark_bench.errors import InputError
from spark_bench.methods.ours.stages.base import CaseRun, PipelineConfig, Registry, Section, StageBackend
from spark_bench.methods.ours.stages.geometry import GEOMETRY_BACKENDS
from spark_bench.methods.ours.stages.refinements import REFINEMENTS

if TYPE_CHECKING:
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.methods.ours.camera import Camera
    from spark_bench.methods.ours.geometry import PartGeometry
    from spark_bench.methods.ours.hypothesis import Hypothesis
    from spark_bench.methods.ours.open_state import OpenState
    from spark_bench.methods.ours.structure import PriorStructure


class OptimizeOutcome(NamedTuple):
    """What a joint optimizer returns.

    :param asset: the refined object
    :param report: what the report says of the optimization (``open_state_source``, ``loss_curve``,
        ``hypotheses``...)
    :param phases: the optimizer's own seconds per phase, wall and ``*_cpu`` (the report's ``opt_*`` timings)
    """

    asset: ArticulatedAsset
    report: dict
    phases: dict[str, float]


class JointOptimizer(StageBackend):
    """A joint-optimization method; every one renders from the case camera."""

    reads = frozenset({"camera"})

    def fits_part_masks(self, config: PipelineConfig) -> bool:
        """Whether, with ``config``, it fits the open state's per-link masks where they are at hand
        (default: no, it fits the whole silhouette).

        :param config: the whole configuration
        """
        return False

    def run(self, run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset, geometry: PartGeometry,
            open_state: OpenState, camera: Camera) -> OptimizeOutcome:
        """Optimize the prior's joints against the open state.

        :param run: the case and the configuration
        :param prior: the structure prior
        :param prior_asset: the prior assembled with the part geometry
        :param geometry: the part geometry
        :param open_state: the open state, the camera's size
        :param camera: the case camera
        """
        raise NotImplementedError


#: The joint-optimization methods by name.
OPTIMIZERS: Registry[JointOptimizer] = Registry("optimize.method")


@OPTIMIZERS.register
class SparkRecipe(JointOptimizer):
    """SPARK's own recipe (:mod:`spark_bench.methods.ours.spark_fit`): its masks of the open and the closed
    (input) images, then each revolute joint's pivot and angle."""

    name = "spark"

    def settings(self, config: PipelineConfig) -> list[Section]:
        return [("optimize.spark", ())]

    def validate(self, config: PipelineConfig, source) -> None:
        if config.optimize.part_masks:
            raise InputError(source, "optimize.part_masks applies to method 'native' only (SPARK's recipe "
                                     "fits the whole silhouette)")

    def run(self, run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset, geometry: PartGeometry,
            open_state: OpenState, camera: Camera) -> OptimizeOutcome:
        from spark_bench.methods.ours.optimize import OpenStateScene
        from spark_bench.methods.ours.spark_fit import spark_fit, spark_mask

        settings = run.config.optimize.spark
        with run.timer("spark_masks"):
            if open_state.rgb is not None:
                open_mask, open_rule = spark_mask(open_state.rgb, settings.threshold, open_state.tolerance)
            else:
                open_mask, open_rule = open_state.mask, "open-state mask"
            closed_rgb = read_rgb(run.case.image)
            closed_mask, closed_rule = spark_mask(closed_rgb, settings.threshold, RENDER_TOLERANCE)
            if closed_mask.shape != (camera.height, camera.width):
                height, width = closed_mask.shape
                raise InputError(run.case.image, f"input image is {width} x {height} px, the camera says "
                                                 f"{camera.width} x {camera.height}")
        with run.timer("joint_optimization"), torch_threads(run.config.optimize.threads):
            scene = OpenStateScene(prior_asset, camera, open_mask, settings.max_faces)
            result = spark_fit(prior_asset, scene, closed_mask, settings)
        report = {"open_state_source": open_state.source,
                  "target_rule": {"open": open_rule, "closed": closed_rule}, "part_masks": [],
                  "loss_curve": [round(v, 6) for v in result.curve], "closed_loss": result.closed_loss,
                  "spark_joints": result.joints, "hypotheses": hypotheses_report(result.hypotheses)}
        return OptimizeOutcome(result.asset, report, result.timings)


@OPTIMIZERS.register
class NativeFit(JointOptimizer):
    """This project's type/axis search and fit (:func:`spark_bench.methods.ours.refine.refine`), after the
    refinement ``[optimize] refine`` names; with ``part_masks``, also against the open state's per-part
    masks."""

    name = "native"

    def case_inputs(self, config: PipelineConfig) -> frozenset[str]:
        return self.reads | REFINEMENTS[config.optimize.refine].case_inputs(config)

    def label(self, config: PipelineConfig) -> str:
        return REFINEMENTS[config.optimize.refine].label(config)

    def fits_part_masks(self, config: PipelineConfig) -> bool:
        return config.optimize.part_masks

    def validate(self, config: PipelineConfig, source) -> None:
        REFINEMENTS[config.optimize.refine].validate(config, source)

    def settings(self, config: PipelineConfig) -> list[Section]:
        # the label names the method, the refinement and the part masks; threads change only the time
        return [("optimize", ("enabled", "method", "spark", "refine", "part_masks", "threads")),
                *REFINEMENTS[config.optimize.refine].settings(config)]

    def run(self, run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset, geometry: PartGeometry,
            open_state: OpenState, camera: Camera) -> OptimizeOutcome:
        from spark_bench.methods.ours.optimize import OpenStateScene
        from spark_bench.methods.ours.refine import RefineSettings, refine

        settings = run.config.optimize
        start_asset = REFINEMENTS[settings.refine].start(run, prior, prior_asset, geometry)
        with run.timer("joint_optimization"), torch_threads(settings.threads):
            part_masks = fitted_part_masks(run.config, open_state, geometry, start_asset)
            scene = OpenStateScene(start_asset, camera, open_state.mask, settings.max_faces, part_masks)
            result = refine(start_asset, scene, RefineSettings.from_config(settings))
        report = {"open_state_source": open_state.source, "part_masks": sorted(scene.part_masks_full),
                  "loss_curve": [round(v, 6) for v in result.curve], "loss_prior": result.loss_prior,
                  "loss_refined": result.loss_final, "candidates": result.candidates,
                  "hypotheses": hypotheses_report(result.hypotheses)}
        return OptimizeOutcome(result.asset, report, result.timings)


@contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run with ``n`` torch CPU threads, then restore the previous count.

    :param n: the thread count (at least 1 is used)
    """
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(max(1, int(n)))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def hypotheses_report(hypotheses: dict[str, Hypothesis]) -> dict:
    """The report's form of the final hypothesis per joint (type, axis, pivot offset, value, origin tag).

    :param hypotheses: by joint name
    """
    return {n: {"type": h.type, "axis": np.round(h.axis, 10).tolist(),
                "pivot_offset": np.round(h.pivot_offset, 10).tolist(), "value": h.value, "from": h.tag}
            for n, h in hypotheses.items()}


def fitted_part_masks(config: PipelineConfig, open_state: OpenState, geometry: PartGeometry,
                      asset: ArticulatedAsset) -> dict | None:
    """The open state's per-link masks as masks of the asset's parts, where the parts are the case's own
    links (a part is a group of ground-truth links, its mask the union of theirs); None otherwise or when
    ``optimize.part_masks`` is off.

    :param config: the whole configuration
    :param open_state: the open state (its ``part_masks`` by link name)
    :param geometry: the part geometry (its parts' member links)
    :param asset: the object the fit starts from
    """
    ground_truth_parts = GEOMETRY_BACKENDS[config.geometry.backend].ground_truth_parts
    if not (config.optimize.part_masks and open_state.part_masks and ground_truth_parts):
        return None
    out = {}
    for part, links in geometry.members.items():
        masks = [open_state.part_masks[n] for n in links if n in open_state.part_masks]
        if part in asset.links and masks:
            out[part] = np.clip(np.sum(masks, axis=0), 0.0, 1.0)
    return out or None


def read_rgb(path: Path) -> np.ndarray:
    """(H, W, 3) floats in [0, 1] of an image file (:func:`~spark_bench.data.images.image_rgb`).

    :param path: the file
    :raises InputError: naming the file when it is missing or unreadable
    """
    from PIL import Image

    if not path.is_file():
        raise InputError(path, "input image not found")
    try:
        with Image.open(path) as image:
            return image_rgb(image)
    except OSError as exc:
        raise InputError(path, f"unreadable image: {exc}") from None
