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
from spark_bench.methods.ours.geometry import command_fields
from spark_bench.methods.ours.prior import NoiseModel

PRIOR_BACKENDS = ("annotation", "vlm", "file", "retrieval")
GEOMETRY_BACKENDS = ("annotation", "predictions", "spark", "retrieval")
OPEN_STATE_BACKENDS = ("dataset", "http")
REFINE_BACKENDS = ("render", "vlm", "none")
OPTIMIZE_METHODS = ("spark", "native")


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
        one row per label).
        """
        prior = f"vlm:{self.vlm.model}" if self.prior.backend == "vlm" else self.prior.backend
        open_state = self.open_state.backend
        if open_state == "http" and self.open_state.model:
            open_state = f"http:{self.open_state.model}"
        label = f"prior={prior},geometry={self.geometry.backend},open={open_state},opt={self.opt_name()}"
        if self.uses_retrieval() and not self.retrieval.is_default:
            label += f",gallery={self.retrieval.gallery_name}"
        if self.uses_part_masks():
            label += ",sup=part-masks"
        changed = self.changed_settings()
        if changed:
            digest = hashlib.sha256(json.dumps(changed, sort_keys=True).encode()).hexdigest()[:8]
            label += f",settings={digest}"
        return label

    def opt_name(self) -> str:
        """The ``opt=`` of the label: ``none``, ``spark``, or the native method's ``native`` |
        ``native+vlm`` | ``fit-only``."""
        if not self.optimize.enabled:
            return "none"
        if self.optimize.method == "spark":
            return "spark"
        return {"render": "native", "vlm": "native+vlm", "none": "fit-only"}[self.optimize.refine]

    def changed_settings(self) -> dict:
        """The settings that change results and differ from their defaults, for the stages in use
        (``{"optimize.top_k": 5, ...}``); endpoints, keys, timeouts and retries are not among them."""
        default = SparkConfig()
        sections = []
        if self.prior.backend == "annotation":
            sections.append(("prior.noise", self.prior.noise, default.prior.noise, ()))
        if self.prior.backend == "file":
            sections.append(("prior", self.prior, default.prior, ("backend", "noise")))
        native = self.optimize.enabled and self.optimize.method == "native"
        if self.prior.backend == "vlm" or (native and self.optimize.refine == "vlm"):
            sections.append(("vlm", self.vlm, default.vlm, ("base_url", "model", "api_key_env", "timeout_s",
                                                             "max_retries", "backoff_s")))
        sections.append(("geometry", self.geometry, default.geometry, ("backend", "timeout_s")))
        if self.uses_retrieval() and not self.retrieval.is_default:
            sections.append(("retrieval", self.retrieval, default.retrieval, ()))
        if native:  # the label names the method, the refinement and the part masks
            sections.append(("optimize", self.optimize, default.optimize,
                             ("enabled", "method", "spark", "refine", "part_masks", "threads")))
        elif self.optimize.enabled:
            sections.append(("optimize.spark", self.optimize.spark, default.optimize.spark, ()))
        out = {}
        for prefix, ours, theirs, skip in sections:
            for f in fields(ours):
                value = getattr(ours, f.name)
                if f.name not in skip and value != getattr(theirs, f.name):
                    out[f"{prefix}.{f.name}"] = asdict(value) if is_dataclass(value) else value
        return out

    def uses_retrieval(self) -> bool:
        """Whether a stage retrieves the case's object from the gallery (a ``retrieval`` backend)."""
        return "retrieval" in (self.prior.backend, self.geometry.backend)

    def uses_part_masks(self) -> bool:
        """Whether the joint optimization reads the open state's per-part masks: the ``native`` method
        with ``optimize.part_masks``, ``annotation`` geometry (whose parts are the case's own links) and
        the ``dataset`` open state."""
        return (self.optimize.enabled and self.optimize.method == "native" and self.optimize.part_masks
                and self.geometry.backend == "annotation" and self.open_state.backend == "dataset")

    def case_inputs(self) -> tuple[str, ...]:
        """The input kinds (:data:`spark_bench.methods.base.INPUT_KINDS`) the pipeline reads of a case with
        this configuration: the input image always; the camera when optimizing, for the ``annotation``
        prior (whose axes are snapped in the camera's frame) and for the ``retrieval`` backends (the search
        renders the gallery from it), the open image with the ``dataset`` open
        state, the open state's part masks when :meth:`uses_part_masks`; the ground truth for an
        ``annotation`` backend, and for a ``spark`` command that is handed the case folder (``{case}``)."""
        inputs = {"image"}
        if self.prior.backend == "annotation" or self.uses_retrieval():
            inputs.add("camera")
        if self.optimize.enabled:
            inputs.add("camera")
            if self.open_state.backend == "dataset":
                inputs.add("open_image")
            if self.uses_part_masks():
                inputs.add("open_masks")
        if "annotation" in (self.prior.backend, self.geometry.backend) or self.command_gets_case_folder():
            inputs.add("gt")
        return tuple(k for k in INPUT_KINDS if k in inputs)

    def command_gets_case_folder(self) -> bool:
        """Whether the ``spark`` geometry command is handed the whole case folder (``{case}``), which holds
        the ground truth."""
        return self.geometry.backend == "spark" and "case" in command_fields(self.geometry.spark_command)

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
        checks = [("prior.backend", self.prior.backend, PRIOR_BACKENDS),
                  ("geometry.backend", self.geometry.backend, GEOMETRY_BACKENDS),
                  ("open_state.backend", self.open_state.backend, OPEN_STATE_BACKENDS),
                  ("optimize.refine", self.optimize.refine, REFINE_BACKENDS),
                  ("optimize.method", self.optimize.method, OPTIMIZE_METHODS)]
        for key, value, allowed in checks:
            if value not in allowed:
                raise InputError(source, f"{key} = {value!r} is not one of {list(allowed)}")
        if self.prior.backend == "file" and not self.prior.file_dir:
            raise InputError(source, "prior.backend = 'file' needs prior.file_dir")
        if self.geometry.backend == "predictions" and not self.geometry.predictions_dir:
            raise InputError(source, "geometry.backend = 'predictions' needs geometry.predictions_dir")
        if self.geometry.backend == "spark" and not self.geometry.spark_command:
            raise InputError(source, "geometry.backend = 'spark' needs geometry.spark_command")
        if self.prior.backend == "retrieval" and self.geometry.backend == "annotation":
            raise InputError(source, "prior.backend = 'retrieval' names the retrieved object's parts, not the "
                                     "ground truth's: use it with geometry.backend 'retrieval' (or "
                                     "'predictions', 'spark')")
        if self.open_state.backend == "http" and not self.open_state.url:
            raise InputError(source, "open_state.backend = 'http' needs open_state.url")
        opt = self.optimize
        if not (len(opt.final_sizes) == len(opt.final_taus) == len(opt.final_steps)):
            raise InputError(source, "optimize.final_sizes, final_taus and final_steps must have equal lengths")
        if opt.method == "spark" and opt.part_masks:
            raise InputError(source, "optimize.part_masks applies to method 'native' only (SPARK's recipe fits "
                                     "the whole silhouette)")
        bounds = opt.spark.angle_bounds
        if len(bounds) != 2 or not 0 <= bounds[0] <= bounds[1]:
            raise InputError(source, f"optimize.spark.angle_bounds must be [low, high] degrees with "
                                     f"0 <= low <= high, got {bounds}")
        if opt.spark.iters < 0 or opt.spark.size < 8 or opt.spark.tau <= 0:
            raise InputError(source, "optimize.spark needs iters >= 0, size >= 8 and tau > 0")

