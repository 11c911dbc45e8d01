"""Stage 2, the part geometry: its backends (``[geometry] backend``), one class each.

A new backend is one more class here, registered with ``@GEOMETRY_BACKENDS.register``.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from spark_bench.errors import InputError
from spark_bench.methods.ours.geometry import (
    PartGeometry,
    annotation_geometry,
    command_fields,
    predictions_geometry,
    spark_geometry,
)
from spark_bench.methods.ours.retrieved import retrieval_geometry
from spark_bench.methods.ours.stages.base import CaseRun, PipelineConfig, Registry, Section, StageBackend


class GeometryBackend(StageBackend):
    """A part-geometry backend.

    :attr ground_truth_parts: its parts are the case's own ground-truth links: the report says the
        geometry is the ground truth (shape metrics then measure nothing), and the open state's per-link
        masks are its parts' masks
    :attr after_prior: it is handed the prior's answer (``prior.json``), so it runs after the prior
        stage; the others run before it, and the prior is told their parts
    """

    ground_truth_parts: ClassVar[bool] = False
    after_prior: ClassVar[bool] = False

    def settings(self, config: PipelineConfig) -> list[Section]:
        """The whole ``[geometry]`` section but the backend's name and its time limit, whichever backend."""
        return [("geometry", ("backend", "timeout_s"))]

    def run(self, run: CaseRun, prior_json: Path | None) -> PartGeometry:
        """The case's part meshes at rest, benchmark frame.

        :param run: the case and the configuration
        :param prior_json: the prior's answer file for an :attr:`after_prior` backend, else None
        """
        raise NotImplementedError


#: The part-geometry backends by name.
GEOMETRY_BACKENDS: Registry[GeometryBackend] = Registry("geometry.backend")


@GEOMETRY_BACKENDS.register
class AnnotationGeometry(GeometryBackend):
    """The ground truth's part meshes at rest
    (:func:`~spark_bench.methods.ours.geometry.annotation_geometry`)."""

    name = "annotation"
    reads = frozenset({"gt"})
    simulated_as = "gt geometry"
    uses_gt_object = True
    ground_truth_parts = True

    def run(self, run: CaseRun, prior_json: Path | None) -> PartGeometry:
        return annotation_geometry(run.gt)


@GEOMETRY_BACKENDS.register
class PredictionsGeometry(GeometryBackend):
    """An object folder per case, ``<geometry.predictions_dir>/<case id>/``
    (:func:`~spark_bench.methods.ours.geometry.predictions_geometry`)."""

    name = "predictions"

    def validate(self, config: PipelineConfig, source) -> None:
        if not config.geometry.predictions_dir:
            raise InputError(source, "geometry.backend = 'predictions' needs geometry.predictions_dir")

    def run(self, run: CaseRun, prior_json: Path | None) -> PartGeometry:
        return predictions_geometry(run.config.geometry.predictions_dir, run.case.case_id)


@GEOMETRY_BACKENDS.register
class SparkGeometry(GeometryBackend):
    """SPARK run per case by ``geometry.spark_command``
    (:func:`~spark_bench.methods.ours.geometry.spark_geometry`); a command handed the case folder
    (``{case}``) reads the ground truth. It reads the case camera always (SPARK's parts are turned by the
    view: the camera brings them into the prior's frame), also when nothing is optimized."""

    name = "spark"
    simulated_as = "gt case folder (SPARK command)"
    after_prior = True
    reads = frozenset({"camera"})

    def case_inputs(self, config: PipelineConfig) -> frozenset[str]:
        return self.reads | ({"gt"} if self.gets_case_folder(config) else set())

    @staticmethod
    def gets_case_folder(config: PipelineConfig) -> bool:
        """Whether the command is handed the whole case folder (``{case}``), which holds the ground truth.

        :param config: the whole configuration
        :raises InputError: when the command template does not split like a shell command line
        """
        return "case" in command_fields(config.geometry.spark_command)

    def validate(self, config: PipelineConfig, source) -> None:
        if not config.geometry.spark_command:
            raise InputError(source, "geometry.backend = 'spark' needs geometry.spark_command")

    def run(self, run: CaseRun, prior_json: Path | None) -> PartGeometry:
        settings = run.config.geometry
        return spark_geometry(settings.spark_command, run.case, prior_json, run.out_dir, settings.timeout_s)


@GEOMETRY_BACKENDS.register
class RetrievalGeometry(GeometryBackend):
    """The retrieved gallery object's part meshes
    (:func:`~spark_bench.methods.ours.retrieved.retrieval_geometry`); the search reads the camera."""

    name = "retrieval"
    reads = frozenset({"camera"})
    retrieves = True

    def run(self, run: CaseRun, prior_json: Path | None) -> PartGeometry:
        return retrieval_geometry(run.found)
