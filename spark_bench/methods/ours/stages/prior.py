"""Stage 1, the structure prior: its backends (``[prior] backend``), one class each.

A new backend is one more class here, registered with ``@PRIOR_BACKENDS.register``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from spark_bench.errors import InputError
from spark_bench.methods.ours.camera import load_camera_pose
from spark_bench.methods.ours.prior import annotation_prior, camera_axis_frame, file_prior_with_frame
from spark_bench.methods.ours.retrieved import retrieval_prior
from spark_bench.methods.ours.stages.base import (
    VLM_SETTINGS,
    CaseRun,
    PipelineConfig,
    Registry,
    Section,
    StageBackend,
)
from spark_bench.methods.ours.stages.geometry import GEOMETRY_BACKENDS
from spark_bench.methods.ours.structure import PriorStructure
from spark_bench.methods.ours.vlm import request_structure

if TYPE_CHECKING:
    from spark_bench.methods.ours.geometry import PartGeometry


class PriorAnswer(NamedTuple):
    """What a prior backend returns.

    :param prior: the coarse URDF
    :param raw: the answer as the backend received it (written as ``prior.json``), or None: the
        prior's own document is written
    :param axis_frame: the frame the prior's axis names mean (the camera's for ``annotation``, see
        :mod:`spark_bench.methods.ours.prior`; the retrieved object's own for ``retrieval``; None: the
        object's)
    """

    prior: PriorStructure
    raw: dict | None
    axis_frame: np.ndarray | None


class PriorBackend(StageBackend):
    """A structure-prior backend."""

    def run(self, run: CaseRun, geometry: PartGeometry | None) -> PriorAnswer:
        """The case's coarse URDF.

        :param run: the case and the configuration
        :param geometry: the part geometry when it is known before the prior (its part names and labels
            are offered to the prior), else None
        """
        raise NotImplementedError


#: The structure-prior backends by name.
PRIOR_BACKENDS: Registry[PriorBackend] = Registry("prior.backend")


@PRIOR_BACKENDS.register
class AnnotationPrior(PriorBackend):
    """The ground truth's coarse URDF corrupted by the seeded noise model, its axes named in the case
    camera's frame (:func:`~spark_bench.methods.ours.prior.annotation_prior`): a simulated VLM."""

    name = "annotation"
    reads = frozenset({"camera", "gt"})
    simulated_as = "gt structure (simulated prior)"
    uses_gt_object = True

    def settings(self, config: PipelineConfig) -> list[Section]:
        return [("prior.noise", ())]

    def run(self, run: CaseRun, geometry: PartGeometry | None) -> PriorAnswer:
        frame = camera_axis_frame(load_camera_pose(run.case.path("camera")))
        prior = annotation_prior(run.gt, run.case.case_id, run.config.prior.noise, axis_frame=frame)
        return PriorAnswer(prior, None, frame)


@PRIOR_BACKENDS.register
class VLMPrior(PriorBackend):
    """The ``[vlm]`` endpoint's answer about the input image
    (:func:`~spark_bench.methods.ours.vlm.request_structure`); the label names the model."""

    name = "vlm"

    def label(self, config: PipelineConfig) -> str:
        return f"vlm:{config.vlm.model}"

    def settings(self, config: PipelineConfig) -> list[Section]:
        return [VLM_SETTINGS]

    def run(self, run: CaseRun, geometry: PartGeometry | None) -> PriorAnswer:
        known = geometry.names if geometry is not None else None
        labels = geometry.labels if geometry is not None else None
        prior, raw = request_structure(run.config.vlm, run.input_png(), known, labels)
        return PriorAnswer(prior, raw, None)


@PRIOR_BACKENDS.register
class FilePrior(PriorBackend):
    """A recorded answer, ``<prior.file_dir>/<case id>.json``
    (:func:`~spark_bench.methods.ours.prior.file_prior_with_frame`)."""

    name = "file"

    def settings(self, config: PipelineConfig) -> list[Section]:
        return [("prior", ("backend", "noise"))]

    def validate(self, config: PipelineConfig, source) -> None:
        if not config.prior.file_dir:
            raise InputError(source, "prior.backend = 'file' needs prior.file_dir")

    def run(self, run: CaseRun, geometry: PartGeometry | None) -> PriorAnswer:
        known = geometry.names if geometry is not None else None
        prior, frame = file_prior_with_frame(run.config.prior.file_dir, run.case.case_id, known)
        return PriorAnswer(prior, None, frame)


@PRIOR_BACKENDS.register
class RetrievalPrior(PriorBackend):
    """The retrieved gallery object's parts, types, axes, pivots and limits
    (:func:`~spark_bench.methods.ours.retrieved.retrieval_prior`); the search reads the camera."""

    name = "retrieval"
    reads = frozenset({"camera"})
    retrieves = True

    def validate(self, config: PipelineConfig, source) -> None:
        if GEOMETRY_BACKENDS[config.geometry.backend].ground_truth_parts:
            names = GEOMETRY_BACKENDS.names()
            fitting = [n for n in names if GEOMETRY_BACKENDS[n].retrieves]
            others = [n for n in names if n not in fitting and not GEOMETRY_BACKENDS[n].ground_truth_parts]
            raise InputError(source, f"prior.backend = {self.name!r} names the retrieved object's parts, not "
                                     f"the ground truth's: use it with geometry.backend "
                                     f"{' or '.join(map(repr, fitting))} (or {', '.join(map(repr, others))})")

    def run(self, run: CaseRun, geometry: PartGeometry | None) -> PriorAnswer:
        prior, frame = retrieval_prior(run.found)
        return PriorAnswer(prior, None, frame)
