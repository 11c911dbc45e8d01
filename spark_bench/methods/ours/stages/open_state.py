"""Stage 3, the open-state image (the joint optimization's supervision): its backends
(``[open_state] backend``), one class each.

A new backend is one more class here, registered with ``@OPEN_STATE_BACKENDS.register``.
"""

from __future__ import annotations

from typing import ClassVar

from spark_bench.errors import InputError
from spark_bench.methods.ours.open_state import OpenState, dataset_open_state, http_open_state
from spark_bench.methods.ours.stages.base import CaseRun, PipelineConfig, Registry, StageBackend


class OpenStateBackend(StageBackend):
    """An open-state backend (run only when the joint optimization is).

    :attr part_masks: it can give the case's per-link masks of the open state
        (:meth:`~spark_bench.methods.ours.config.SparkConfig.uses_part_masks`)
    """

    part_masks: ClassVar[bool] = False

    def run(self, run: CaseRun) -> OpenState:
        """The open state of the case.

        :param run: the case and the configuration
        """
        raise NotImplementedError


#: The open-state backends by name.
OPEN_STATE_BACKENDS: Registry[OpenStateBackend] = Registry("open_state.backend")


@OPEN_STATE_BACKENDS.register
class DatasetOpenState(OpenStateBackend):
    """The case's rendered open state (:func:`~spark_bench.methods.ours.open_state.dataset_open_state`): its
    image, and its link labels when the fit reads the part masks."""

    name = "dataset"
    part_masks = True

    def case_inputs(self, config: PipelineConfig) -> frozenset[str]:
        return frozenset({"open_image", "open_masks"} if config.uses_part_masks() else {"open_image"})

    def run(self, run: CaseRun) -> OpenState:
        return dataset_open_state(run.case, run.config.uses_part_masks())


@OPEN_STATE_BACKENDS.register
class HttpOpenState(OpenStateBackend):
    """An image-generation endpoint's open state of the input image
    (:func:`~spark_bench.methods.ours.open_state.http_open_state`); the label names its model."""

    name = "http"

    def label(self, config: PipelineConfig) -> str:
        return f"http:{config.open_state.model}" if config.open_state.model else self.name

    def validate(self, config: PipelineConfig, source) -> None:
        if not config.open_state.url:
            raise InputError(source, "open_state.backend = 'http' needs open_state.url")

    def run(self, run: CaseRun) -> OpenState:
        return http_open_state(run.config.open_state, run.input_png())
