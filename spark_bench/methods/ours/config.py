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
from spark_bench.methods.ours.config_parse import build_dataclass
from spark_bench.methods.ours.prior import NoiseModel
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


@dataclass
class VLMConfig:
    """An OpenAI-compatible chat-completions endpoint with image input.

    :param base_url: API root; requests go to ``{base_url}/chat/completions``
    :param model: model name sent in the request
    :param api_key_env: environment variable holding the API key (sent as a Bearer token if set)
    :param timeout_s: per-request timeout
    :param max_retries: attempts after the first, on HTTP 429/5xx, network errors and invalid answers
    :param backoff_s: first retry delay, doubled each time
    :param temperature: sampling temperature
    :param max_tokens: answer length cap
    :param json_schema: send ``response_format: json_schema`` (False: ``json_object``, for servers
        that lack structured outputs)
    """

    base_url: str = "http://127.0.0.1:8000/v1"
    model: str = "gpt-4o"
    api_key_env: str = "OPENAI_API_KEY"
    timeout_s: float = 120.0
    max_retries: int = 3
    backoff_s: float = 1.0
    temperature: float = 0.0
    max_tokens: int = 2000
    json_schema: bool = True


@dataclass
class PriorConfig:
    """Stage 1. :param backend: ``annotation`` | ``vlm`` | ``file`` | ``retrieval`` (the retrieved gallery
    object's parts, types, axes, pivots and limits, :mod:`spark_bench.methods.ours.retrieved`); :param file_dir:
    folder of ``<case id>.json`` answers for ``file``; :param noise: the ``annotation`` noise model."""

    backend: str = "annotation"
    file_dir: str = ""
    noise: NoiseModel = field(default_factory=NoiseModel)


@dataclass
class GeometryConfig:
    """Stage 2. :param backend: ``annotation`` | ``predictions`` | ``spark`` | ``retrieval`` (the retrieved
    gallery object's part meshes, :mod:`spark_bench.methods.ours.retrieved`); :param predictions_dir:
    folder of ``<case id>/`` object folders; :param spark_command: command template (see
    :func:`spark_bench.methods.ours.geometry.spark_geometry`); :param timeout_s: its time limit."""

    backend: str = "annotation"
    predictions_dir: str = ""
    spark_command: str = ""
    timeout_s: float = 3600.0


@dataclass
class RetrievalConfig:
    """The gallery of the ``retrieval`` prior and geometry backends (one retrieval per case serves both;
    the search is :func:`spark_bench.methods.retrieval.search.retrieve`, as ``--method retrieval``).

    :param gallery: a folder of PartNet-Mobility-format objects, or ``""`` (or ``synth-gallery-v1``) for
        the default procedural gallery, built on first use
    """

    gallery: str = ""

    @property
    def is_default(self) -> bool:
        """Whether this is the default gallery (``""`` or its name)."""
        from spark_bench.methods.retrieval.gallery import DEFAULT_GALLERY

        return self.gallery in ("", DEFAULT_GALLERY.name)

    @property
    def gallery_name(self) -> str:
        """The gallery's name: ``synth-gallery-v1`` for the default, else the folder's name."""
        from spark_bench.methods.retrieval.gallery import DEFAULT_GALLERY

        return DEFAULT_GALLERY.name if self.is_default else Path(self.gallery).expanduser().name


@dataclass
class OpenStateConfig:
    """Stage 3. :param backend: ``dataset`` | ``http``; :param url: image-generation endpoint for
    ``http``; :param model: model name sent; :param api_key_env: key variable; :param timeout_s: limit
    per attempt; :param max_retries: attempts after the first on HTTP 429/5xx, network errors and
    timeouts; :param backoff_s: first retry delay, doubled each time."""

    backend: str = "dataset"
    url: str = ""
    model: str = ""
    api_key_env: str = "OPENAI_API_KEY"
    timeout_s: float = 300.0
    max_retries: int = 2
    backoff_s: float = 2.0


@dataclass
class SparkFitConfig:
    """SPARK's own joint optimizer (``optimize.method = "spark"``, :mod:`spark_bench.methods.ours.spark_fit`):
    the settings of ``URDFoptimizer/optimize_urdf_joint_v4.py`` (YumengHe/PartCrafter) run with
    ``--learn-angle --init-random``; the defaults are the script's.

    :param iters: Adam iterations per revolute joint (its ``--iters``)
    :param lr_pivot: Adam step of the pivot shift (``--lr``)
    :param lr_angle: Adam step of the opening angle (``--lr-angle``)
    :param angle_bounds: bounds of the learned angle, degrees (``--angle-bounds``)
    :param closed_weight: weight of the closed-image term (``--closed-weight``)
    :param reg_pivot: weight of ``|t|^2`` (``--regularization``)
    :param reg_angle: weight of ``|delta theta|^2`` (``--angle-regularization``)
    :param threshold: a pixel whose mean RGB (0-1) is below this is object (``--threshold``)
    :param seed: seed of the random pivot starts (``--random-seed``), combined with the case and joint
    :param size: render size (px) of the window around the object (the script renders 1024 px of the
        whole frame; see :mod:`~spark_bench.methods.ours.spark_fit` for what lower sizes were measured to give)
    :param tau: edge softness (px) of the soft silhouette at that size
    :param max_faces: per-link face budget of the rendered meshes
    """

    iters: int = 200
    lr_pivot: float = 5e-3
    lr_angle: float = 1e-2
    angle_bounds: list[float] = field(default_factory=lambda: [35.0, 180.0])
    closed_weight: float = 0.2
    reg_pivot: float = 1e-3
    reg_angle: float = 1e-4
    threshold: float = 0.9
    seed: int = 42
    size: int = 128
    tau: float = 0.5
    max_faces: int = 600


@dataclass
class OptimizeConfig:
    """Stage 4: the joint optimization. ``method = "spark"`` (the default) is SPARK's own recipe
    (:mod:`spark_bench.methods.ours.spark_fit`, its settings in ``spark``); ``native`` is this project's
    type/axis search and fit (:func:`spark_bench.methods.ours.refine.refine`; the module docstring of
    :mod:`spark_bench.methods.ours.refine` describes the search the other settings drive).

    :param enabled: run the joint optimization (False: export the prior as is)
    :param method: ``spark`` or ``native``
    :param spark: SPARK's recipe's settings (:class:`SparkFitConfig`)
    :param refine: ``native`` only: discrete type/axis refinement: ``render`` (offline), ``vlm`` (ask the
        VLM again with the coarse URDF, then fit continuously) or ``none``
    :param part_masks: ``native`` only: also fit and score against the open state's per-part masks
        (ground-truth part masks: the label says ``sup=part-masks``) when the parts are the case's own
        links (``annotation`` geometry with the ``dataset`` open state); default off, as the paper
        fits the whole silhouette
    :param screen_size: image size (px) of the first level of each candidate's short fit
    :param screen_tau: edge softness (px) at that level
    :param short_steps: Adam steps of a short fit at that level
    :param short_fine_size: image size of the short fit's second level (its steps: ``short_fine_steps``,
        0 for none)
    :param short_fine_tau: edge softness at that level
    :param short_fine_steps: Adam steps at that level
    :param top_k: candidates per joint that get a short fit (besides the best of the prior's family)
    :param score_size: image size of the exact segmentation score that picks among the finalists
    :param screen_score_size: image size of the blurred segmentation score that screens the candidates
    :param screen_blur: Gaussian blur (px) of that score: a part within about this many pixels of its
        place scores nearly as well as in place, so a coarse grid of open values finds it
    :param screen_values_revolute: open values (rad) each revolute candidate is screened at (besides
        the prior's)
    :param screen_values_prismatic: open values (benchmark units) each prismatic candidate is screened
        at (up to 1.3: a lid lifted off a pot travels more than a drawer)
    :param screen_local: steps of the local search of the best screened candidates' open values, in
        order (radians; for prismatic joints, fractions of the value)
    :param small_part: a part whose rest box is smaller than this fraction of the object's gets only the
        prior's and the centre-line pivot starts (0: off)
    :param skip_without_evidence: a joint none of whose finalists (before their short fits) draws the
        open state better than its part left at rest by the margin (a button pressed a millimetre, a
        knob turned in place) keeps the prior's hypothesis, its hinge moved into its part's box, without
        short fits, later sweeps or the final fit
        (PartNet-Mobility 101599, a door carrying 12 buttons and a knob: 48 CPU s of native
        optimization before, and the rendered meshes' face budget by part size, 10 s after)
    :param margin_rel: a candidate of another type or axis must beat the prior's score by this fraction
        of it (and by ``margin_abs`` at least) to replace it
    :param margin_abs: the smallest such margin
    :param final_sizes: image sizes of the final joint fit's levels, coarse to fine
    :param final_taus: edge softness of each level
    :param final_steps: Adam steps of each level
    :param w_edge: weight of the edge term of the loss
    :param w_part: weight of the per-part coverage term (with part masks)
    :param lambda_t: regularizer weight of the pivot offsets
    :param lambda_theta: regularizer weight of the open values
    :param lr_pivot: Adam step for pivot offsets
    :param lr_value: Adam step for open values
    :param include_fixed: also try ``fixed`` for every joint
    :param sweeps: most passes of the discrete search over the joints
    :param max_faces: per-link face budget of the rendered meshes
    :param threads: torch CPU threads during the optimization
    """

    enabled: bool = True
    method: str = "spark"
    spark: SparkFitConfig = field(default_factory=SparkFitConfig)
    refine: str = "render"
    part_masks: bool = False
    screen_size: int = 32
    screen_tau: float = 1.0
    short_steps: int = 12
    short_fine_size: int = 64
    short_fine_tau: float = 0.7
    short_fine_steps: int = 12
    top_k: int = 3
    score_size: int = 128
    screen_score_size: int = 64
    screen_blur: float = 1.0
    screen_values_revolute: list[float] = field(default_factory=lambda: [0.3, 0.5, 0.7, 0.9, 1.1, 1.3, 1.5, 1.7, 1.9])
    screen_values_prismatic: list[float] = field(default_factory=lambda: [0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.3])
    screen_local: list[float] = field(default_factory=lambda: [0.06, 0.03])
    small_part: float = 0.0
    skip_without_evidence: bool = True
    margin_rel: float = 0.1
    margin_abs: float = 0.01
    final_sizes: list[int] = field(default_factory=lambda: [64, 128])
    final_taus: list[float] = field(default_factory=lambda: [0.7, 0.6])
    final_steps: list[int] = field(default_factory=lambda: [40, 30])
    w_edge: float = 0.2
    w_part: float = 0.5
    lambda_t: float = 0.01
    lambda_theta: float = 0.001
    lr_pivot: float = 0.01
    lr_value: float = 0.03
    include_fixed: bool = False
    sweeps: int = 2
    max_faces: int = 600
    threads: int = 1


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
        """Read a ``.json`` or ``.toml`` file."""
        path = Path(path)
        try:
            text = path.read_text()
            data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
        except FileNotFoundError:
            raise InputError(path, "config file not found") from None
        except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise InputError(path, f"malformed config: {exc}") from None
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
