"""What every stage backend of ``ours`` declares, the registry of a stage, and what a backend's ``run``
is handed.

A stage has one :class:`Registry` of backends by name, the string its configuration section names
(``[prior] backend = "vlm"``). A backend is one small class registered with its stage's decorator; it
declares what the configuration, the method's inputs and regime, and the report say about it, and its
``run`` does the stage. :class:`~spark_bench.methods.ours.config.SparkConfig` asks the backends of its
stages for its label, case inputs and checks; :func:`~spark_bench.methods.ours.pipeline.run_ours` runs them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, Generic, Protocol, TypeVar

from spark_bench.errors import InputError
from spark_bench.timing import StageTimer

if TYPE_CHECKING:
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.methods.base import CaseInput
    from spark_bench.methods.ours.sections import (
        GeometryConfig,
        OpenStateConfig,
        OptimizeConfig,
        PriorConfig,
        RetrievalConfig,
        VLMConfig,
    )
    from spark_bench.methods.retrieval.search import Retrieval

#: A section of the configuration whose settings change a backend's results: its dotted path
#: (``"prior.noise"``) and the keys of it that do not (names of other backends, endpoints, timeouts).
Section = tuple[str, tuple[str, ...]]
#: The ``[vlm]`` settings that change results: not the endpoint, key, timeout or retries.
VLM_SETTINGS: Section = ("vlm", ("base_url", "model", "api_key_env", "timeout_s", "max_retries", "backoff_s"))



class PipelineConfig(Protocol):
    """What a backend reads of the pipeline's configuration: its sections
    (:mod:`spark_bench.methods.ours.sections`) and whether the joint optimization fits per-part masks.
    :class:`~spark_bench.methods.ours.config.SparkConfig` is the one; it asks the stages' registries about
    its names, so the stages name this interface, not it.
    """

    prior: PriorConfig
    geometry: GeometryConfig
    open_state: OpenStateConfig
    optimize: OptimizeConfig
    vlm: VLMConfig
    retrieval: RetrievalConfig
    write_prior: bool

    def uses_part_masks(self) -> bool:
        """Whether the joint optimization reads the open state's per-part masks."""
        ...


class StageBackend:
    """One backend of one stage; subclasses set the class attributes and override what differs.

    :attr name: the configuration's string for it (``[prior] backend = "vlm"``)
    :attr reads: the case inputs it reads (:data:`spark_bench.methods.base.INPUT_KINDS`) besides the
        input image, which the pipeline always reads; ``gt`` when it simulates the stage from the ground truth
    :attr simulated_as: how the method's regime names the stage when it reads ``gt``
    :attr uses_gt_object: its ``run`` reads the ground-truth object (:attr:`CaseRun.gt`, loaded once per case)
    :attr retrieves: its ``run`` reads the case's retrieval from the gallery (:attr:`CaseRun.found`, one
        retrieval per case serves every stage)
    """

    name: ClassVar[str] = ""
    reads: ClassVar[frozenset[str]] = frozenset()
    simulated_as: ClassVar[str] = ""
    uses_gt_object: ClassVar[bool] = False
    retrieves: ClassVar[bool] = False

    def case_inputs(self, config: PipelineConfig) -> frozenset[str]:
        """The case inputs it reads with ``config`` (default: :attr:`reads`).

        :param config: the whole configuration
        """
        return self.reads

    def simulated_stage(self, config: PipelineConfig) -> str | None:
        """The regime's name of the stage when, with ``config``, it is simulated from the ground truth
        (the backend reads ``gt``), else None.

        :param config: the whole configuration
        """
        return self.simulated_as if "gt" in self.case_inputs(config) else None

    def label(self, config: PipelineConfig) -> str:
        """Its part of the configuration's label (default: its name).

        :param config: the whole configuration
        """
        return self.name

    def settings(self, config: PipelineConfig) -> list[Section]:
        """The sections of ``config`` whose settings change its results (default: none).

        :param config: the whole configuration
        """
        return []

    def validate(self, config: PipelineConfig, source) -> None:
        """Raise :class:`~spark_bench.errors.InputError` naming ``source`` when ``config`` lacks a setting
        it requires (default: it requires none).

        :param config: the whole configuration
        :param source: where the configuration came from (a file, ``"command line"``, None)
        """


B = TypeVar("B", bound=StageBackend)


class Registry(Generic[B]):
    """The backends of one stage by name, in registration order (the order a configuration error lists).

    :param key: the setting that names the stage's backend (``"prior.backend"``)
    """

    def __init__(self, key: str):
        self.key = key
        self._backends: dict[str, B] = {}

    def register(self, cls: type[B]) -> type[B]:
        """Register a backend class (a decorator); it is used as one instance.

        :param cls: the class; its ``name`` is the configuration's string for it
        :raises ValueError: when a backend of that name is registered already
        """
        if not cls.name or cls.name in self._backends:
            raise ValueError(f"{self.key}: a backend named {cls.name!r} is registered already (or unnamed)")
        self._backends[cls.name] = cls()
        return cls

    def unregister(self, name: str) -> None:
        """Remove the backend called ``name`` (a test's throw-away backend).

        :param name: the backend's name
        """
        del self._backends[name]

    def names(self) -> list[str]:
        """The registered names, in registration order."""
        return list(self._backends)

    def __getitem__(self, name: str) -> B:
        return self._backends[name]

    def check(self, name: str, source) -> None:
        """Raise :class:`~spark_bench.errors.InputError` naming ``source`` when no backend is called ``name``.

        :param name: the configured string
        :param source: where the configuration came from
        """
        if name not in self._backends:
            raise InputError(source, f"{self.key} = {name!r} is not one of {self.names()}")


@dataclass
class CaseRun:
    """What a stage backend's ``run`` is handed: the configuration, the case, and what the pipeline holds
    of the case for every stage.

    :param config: the configuration
    :param case: the case as ``ours`` sees it (it refuses the inputs the configuration did not declare)
    :param out_dir: the case's output folder (a backend may keep work files there)
    :param timer: the pipeline's timer; a backend times its own steps on it (``with run.timer(name)``)
    :param gt: the ground-truth object, loaded when a backend :attr:`~StageBackend.uses_gt_object`
    :param found: the case's retrieval, when a backend :attr:`~StageBackend.retrieves`
    """

    config: PipelineConfig
    case: CaseInput
    out_dir: Path
    timer: StageTimer = field(default_factory=StageTimer)
    gt: ArticulatedAsset | None = None
    found: Retrieval | None = None

    def input_png(self) -> bytes:
        """The input image's bytes (sent to remote models).

        :raises InputError: when the image file is missing
        """
        image = self.case.image
        if not image.is_file():
            raise InputError(image, "input image not found")
        return image.read_bytes()
