"""The ``native`` joint optimization's type/axis refinements (``[optimize] refine``), one class each:
``render`` (the offline search), ``vlm`` (the paper's second query), ``none`` (the fit only).

A new refinement is one class registered with ``@REFINEMENTS.register``. The native fit
(:mod:`spark_bench.methods.ours.refine`) reads from here whether a refinement searches, so this module
knows nothing of the fit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from spark_bench.methods.ours.assemble import assemble_asset
from spark_bench.methods.ours.stages.base import (
    VLM_SETTINGS,
    CaseRun,
    PipelineConfig,
    Registry,
    Section,
    StageBackend,
)
from spark_bench.methods.ours.vlm import request_structure

if TYPE_CHECKING:
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.methods.ours.geometry import PartGeometry
    from spark_bench.methods.ours.structure import PriorStructure


class Refinement(StageBackend):
    """A type/axis refinement of the ``native`` method; its label is the ``opt=`` of the label.

    :attr searches: the native fit runs its offline type/axis search
        (:class:`~spark_bench.methods.ours.refine.RefineSettings` ``refine_discrete``)
    """

    searches: ClassVar[bool] = False

    def start(self, run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset,
              geometry: PartGeometry) -> ArticulatedAsset:
        """The object the fit starts from (default: the prior's).

        :param run: the case and the configuration
        :param prior: the structure prior
        :param prior_asset: the prior assembled with the part geometry
        :param geometry: the part geometry
        """
        return prior_asset


#: The ``native`` method's refinements by name.
REFINEMENTS: Registry[Refinement] = Registry("optimize.refine")


@REFINEMENTS.register
class RenderSearch(Refinement):
    """The offline search: every candidate of the canonical dictionary rendered and scored
    (:mod:`spark_bench.methods.ours.refine`), then the continuous fit."""

    name = "render"
    searches = True

    def label(self, config: PipelineConfig) -> str:
        return "native"


@REFINEMENTS.register
class VLMRefinement(Refinement):
    """The paper's second query: the VLM re-predicts type and axis given the coarse URDF, then the
    continuous fit."""

    name = "vlm"

    def label(self, config: PipelineConfig) -> str:
        return "native+vlm"

    def settings(self, config: PipelineConfig) -> list[Section]:
        return [VLM_SETTINGS]

    def start(self, run: CaseRun, prior: PriorStructure, prior_asset: ArticulatedAsset,
              geometry: PartGeometry) -> ArticulatedAsset:
        with run.timer("vlm_refine"):
            reprior, _ = request_structure(run.config.vlm, run.input_png(), geometry.names, geometry.labels,
                                           refine_from=prior)
            return assemble_asset(reprior, geometry, name=prior_asset.name, category=prior_asset.category)


@REFINEMENTS.register
class NoRefinement(Refinement):
    """No type/axis search: the continuous fit of the prior's joints only."""

    name = "none"

    def label(self, config: PipelineConfig) -> str:
        return "fit-only"
