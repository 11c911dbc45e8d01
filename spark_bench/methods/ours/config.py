"""Configuration of the SPARK pipeline: one backend per stage, loadable from JSON or TOML.

Example (TOML)::

    [prior]
    backend = "vlm"          # vlm | annotation | file | retrieval
    [vlm]
    base_url = "https://api.openai.com/v1"
    model = "gpt-4o"
    api_key_env = "OPENAI_API_KEY"
    [geometry]
    backend = "annotation"   # annotation | predictions | spark | retrieval
    [retrieval]
    gallery = ""             # retrieval backends: a gallery folder ("": synth-gallery-v1)
    [open_state]
    backend = "dataset"      # dataset | http
    [optimize]
    enabled = true
    method = "spark"         # spark (SPARK's own recipe) | native (the type/axis search + fit)
    part_masks = false       # native only: also fit the open state's per-part masks (label sup=part-masks)
    screen_blur = 1.0        # any OptimizeConfig field, e.g. the native search's knobs
    [optimize.spark]
    iters = 200              # any SparkFitConfig field

Command-line style overrides (``section.key=value``, value parsed as JSON when it parses) go through
:meth:`SparkConfig.with_overrides`. :meth:`SparkConfig.label` is the string results rows carry.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.methods.base import INPUT_KINDS
from spark_bench.methods.options import METHOD_TABLE
from spark_bench.methods.ours.config_parse import build_dataclass
from spark_bench.methods.ours.sections import (
    GeometryConfig,
    OpenStateConfig,
    OptimizeConfig,
    PriorConfig,
    RetrievalConfig,
    SparkFitConfig,
    VLMConfig,
)
from spark_bench.methods.ours.stages import (
    GEOMETRY_BACKENDS,
    OPEN_STATE_BACKENDS,
    OPTIMIZERS,
    PRIOR_BACKENDS,
    REFINEMENTS,
    GeometryBackend,
    JointOptimizer,
    OpenStateBackend,
    PriorBackend,
    StageBackend,
)

#: The sections are defined in :mod:`spark_bench.methods.ours.sections` and importable from here too.
__all__ = ["GeometryConfig", "OpenStateConfig", "OptimizeConfig", "PriorConfig", "RetrievalConfig", "SparkConfig",
           "SparkFitConfig", "VLMConfig"]


@dataclass
class SparkConfig:
    """The whole pipeline's configuration.

    :param prior: stage 1, structure prior
    :param geometry: stage 2, part geometry
    :param open_state: stage 3, open-state image
    :param optimize: stage 4, joint optimization
    :param vlm: the VLM endpoint (prior ``vlm`` and refine ``vlm``)
    :param retrieval: the gallery of the ``retrieval`` backends
    :param write_prior: also write the prior-only asset to ``<out>/prior/`` (the "w/o joint
        optimization" row of the ablation)
    """

    prior: PriorConfig = field(default_factory=PriorConfig)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    open_state: OpenStateConfig = field(default_factory=OpenStateConfig)
    optimize: OptimizeConfig = field(default_factory=OptimizeConfig)
    vlm: VLMConfig = field(default_factory=VLMConfig)
    retrieval: RetrievalConfig = field(default_factory=RetrievalConfig)
    write_prior: bool = True

    def label(self) -> str:
        """What a results row made with this config says, e.g. ``prior=annotation,geometry=annotation,
        open=dataset,opt=spark``.

        A remote model is named (``prior=vlm:gpt-4o``, ``open=http:<model>``), and a retrieval gallery other
        than the default (``gallery=<folder name>``, after ``opt``); ``opt`` is ``spark``
        (SPARK's own recipe), ``native`` (continuous fit with the offline type/axis search),
        ``native+vlm`` (the VLM re-predicts type and axis), ``fit-only`` (no type/axis search) or
        ``none``; ``sup=part-masks`` follows when the fit reads the ground truth's per-part masks. When a
        setting that changes results differs from its default (the prior's noise, an optimization knob,
        the predictions folder, the SPARK command, the VLM's sampling), ``settings=<8 hex>`` names that
        set of changes, so two runs that differ only there never share a label (the leaderboard keeps
        one row per label). Each part is the backend's (:meth:`~.stages.base.StageBackend.label`).
        """
        label = (f"prior={self.prior_backend().label(self)},geometry={self.geometry_backend().label(self)},"
                 f"open={self.open_state_backend().label(self)},opt={self.opt_name()}")
        if self.uses_retrieval() and not self.retrieval.is_default:
            label += f",gallery={self.retrieval.gallery_name}"
        if self.uses_part_masks():
            label += ",sup=part-masks"
        changed = self.changed_settings()
        if changed:
            digest = hashlib.sha256(json.dumps(changed, sort_keys=True).encode()).hexdigest()[:8]
            label += f",settings={digest}"
        return label

    def prior_backend(self) -> PriorBackend:
        """The structure-prior backend ``[prior] backend`` names."""
        return PRIOR_BACKENDS[self.prior.backend]

    def geometry_backend(self) -> GeometryBackend:
        """The part-geometry backend ``[geometry] backend`` names."""
        return GEOMETRY_BACKENDS[self.geometry.backend]

    def open_state_backend(self) -> OpenStateBackend:
        """The open-state backend ``[open_state] backend`` names."""
        return OPEN_STATE_BACKENDS[self.open_state.backend]

    def optimizer(self) -> JointOptimizer:
        """The joint-optimization method ``[optimize] method`` names (run when ``enabled``)."""
        return OPTIMIZERS[self.optimize.method]

    def stage_backends(self) -> list[StageBackend]:
        """The backends that run: the prior's and the geometry's, and with the joint optimization enabled,
        the open state's and the optimizer."""
        backends = [self.prior_backend(), self.geometry_backend()]
        if self.optimize.enabled:
            backends += [self.open_state_backend(), self.optimizer()]
        return backends

    def opt_name(self) -> str:
        """The ``opt=`` of the label: ``none``, or the optimizer's (``spark``, or the native method's
        ``native`` | ``native+vlm`` | ``fit-only``)."""
        return self.optimizer().label(self) if self.optimize.enabled else "none"

    def changed_settings(self) -> dict:
        """The settings that change results and differ from their defaults, for the stages in use
        (``{"optimize.top_k": 5, ...}``): those of the sections each backend names
        (:meth:`~.stages.base.StageBackend.settings`; endpoints, keys, timeouts and retries are not among
        them), and a gallery other than the default."""
        default = SparkConfig()
        sections = [section for backend in self.stage_backends() for section in backend.settings(self)]
        if self.uses_retrieval() and not self.retrieval.is_default:
            sections.append(("retrieval", ()))
        out = {}
        for path, skip in dict.fromkeys(sections):  # a section two backends name (the VLM's) counts once
            ours, theirs = _section(self, path), _section(default, path)
            for f in fields(ours):
                value = getattr(ours, f.name)
                if f.name not in skip and value != getattr(theirs, f.name):
                    out[f"{path}.{f.name}"] = asdict(value) if is_dataclass(value) else value
        return out

    def uses_retrieval(self) -> bool:
        """Whether a stage retrieves the case's object from the gallery (a backend that
        :attr:`~.stages.base.StageBackend.retrieves`)."""
        return self.prior_backend().retrieves or self.geometry_backend().retrieves

    def uses_part_masks(self) -> bool:
        """Whether the joint optimization reads the open state's per-part masks: an optimizer that fits
        them (``native`` with ``optimize.part_masks``), a geometry whose parts are the case's own links
        (``annotation``) and an open state that has their masks (``dataset``)."""
        return (self.optimize.enabled and self.optimizer().fits_part_masks(self)
                and self.geometry_backend().ground_truth_parts and self.open_state_backend().part_masks)

    def case_inputs(self) -> tuple[str, ...]:
        """The input kinds (:data:`spark_bench.methods.base.INPUT_KINDS`) the pipeline reads of a case with
        this configuration: the input image always, and what each backend that runs reads
        (:meth:`~.stages.base.StageBackend.case_inputs`): the camera for the ``annotation`` prior (whose
        axes are snapped in the camera's frame), for the ``retrieval`` backends (the search renders the
        gallery from it) and for every optimizer, the open image with the ``dataset`` open state, the
        open state's part masks when :meth:`uses_part_masks`; the ground truth for an ``annotation``
        backend, and for a ``spark`` command that is handed the case folder (``{case}``)."""
        inputs = {"image"}.union(*(backend.case_inputs(self) for backend in self.stage_backends()))
        return tuple(k for k in INPUT_KINDS if k in inputs)

    def simulated_stages(self) -> list[str]:
        """The regime's names of the stages this configuration simulates from the ground truth, in stage
        order (:meth:`~.stages.base.StageBackend.simulated_stage`)."""
        return [name for backend in self.stage_backends() if (name := backend.simulated_stage(self))]

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict, source=None) -> SparkConfig:
        """Build from nested dicts; unknown keys and bad backend names are errors naming ``source``."""
        config = build_dataclass(cls, data, source)
        config.validate(source)
        return config

    @classmethod
    def from_file(cls, path: str | Path) -> SparkConfig:
        """Read a ``.json`` or ``.toml`` file; its ``[method]`` table, if any, holds the eval command's method
        options (:mod:`spark_bench.methods.options`), not SPARK's settings, and is skipped."""
        path = Path(path)
        try:
            text = path.read_text()
            data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
        except FileNotFoundError:
            raise InputError(path, "config file not found") from None
        except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise InputError(path, f"malformed config: {exc}") from None
        if isinstance(data, dict):
            data = {k: v for k, v in data.items() if k != METHOD_TABLE}
        return cls.from_dict(data, path)

    def with_overrides(self, overrides: list[str]) -> SparkConfig:
        """A copy with ``section.key=value`` overrides applied (e.g. ``prior.backend=vlm``)."""
        data = self.to_dict()
        for item in overrides:
            key, sep, raw = item.partition("=")
            if not sep:
                raise InputError(None, f"override {item!r} is not KEY=VALUE")
            try:
                value = json.loads(raw)
            except json.JSONDecodeError:
                value = raw
            node = data
            parts = key.strip().split(".")
            for part in parts[:-1]:
                if not isinstance(node.get(part), dict):
                    raise InputError(None, f"override {item!r}: no section {part!r}")
                node = node[part]
            if parts[-1] not in node:
                raise InputError(None, f"override {item!r}: no setting {parts[-1]!r}")
            node[parts[-1]] = value
        return SparkConfig.from_dict(data, "command line")

    def validate(self, source=None) -> None:
        """Raise :class:`~spark_bench.errors.InputError` naming ``source`` at the first problem: a backend
        name no stage has, a setting a configured backend requires
        (:meth:`~.stages.base.StageBackend.validate`, whether or not its stage runs), a malformed
        optimization setting.

        :param source: where the configuration came from (a file, ``"command line"``, None)
        """
        names = [(PRIOR_BACKENDS, self.prior.backend), (GEOMETRY_BACKENDS, self.geometry.backend),
                 (OPEN_STATE_BACKENDS, self.open_state.backend), (REFINEMENTS, self.optimize.refine),
                 (OPTIMIZERS, self.optimize.method)]
        for registry, name in names:
            registry.check(name, source)
        for backend in (self.prior_backend(), self.geometry_backend(), self.open_state_backend()):
            backend.validate(self, source)
        opt = self.optimize  # its settings are checked whichever method runs
        if not (len(opt.final_sizes) == len(opt.final_taus) == len(opt.final_steps)):
            raise InputError(source, "optimize.final_sizes, final_taus and final_steps must have equal lengths")
        self.optimizer().validate(self, source)
        bounds = opt.spark.angle_bounds
        if len(bounds) != 2 or not 0 <= bounds[0] <= bounds[1]:
            raise InputError(source, f"optimize.spark.angle_bounds must be [low, high] degrees with "
                                     f"0 <= low <= high, got {bounds}")
        if opt.spark.iters < 0 or opt.spark.size < 8 or opt.spark.tau <= 0:
            raise InputError(source, "optimize.spark needs iters >= 0, size >= 8 and tau > 0")


def _section(config: SparkConfig, path: str):
    """The settings object at a dotted ``path`` of ``config`` (``"optimize.spark"``).

    :param config: the configuration
    :param path: attribute names joined by dots
    """
    node = config
    for name in path.split("."):
        node = getattr(node, name)
    return node
