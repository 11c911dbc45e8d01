"""The sections of the SPARK pipeline's configuration, one dataclass per ``[section]``
(:class:`~spark_bench.methods.ours.config.SparkConfig` holds one of each).

They know nothing of the stages' backends, so the stages can read them and the whole configuration can
ask the stages' registries about their names without a cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.methods.ours.prior import NoiseModel


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
