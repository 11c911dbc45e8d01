"""Methods under test: the :class:`Generator` protocol and the registry behind ``--method NAME``.

A generator turns one benchmark case into an object folder in PartNet-Mobility conventions
(``mobility.urdf`` + meshes, benchmark frame). It declares which parts of the case it may see
(:data:`INPUT_KINDS`); the runner hands it a :class:`CaseInput` that refuses everything else, so the
input regime printed on the leaderboard is the one the method really had.

Built in:

- ``oracle``: the ground truth itself (every articulation error is zero: a sanity check);
- ``geometry``: a geometry-only articulation estimator in the spirit of Articulate AnyMesh, from the
  case's part meshes at rest (:mod:`spark_bench.baselines.geometry`);
- ``predictions``: one folder per case id under ``--predictions DIR``, as any external method can write;
- ``command``: an external program per case, from a template in a methods file (TOML or JSON), run
  without a shell and with a timeout (both in :mod:`spark_bench.external_methods`);
- ``ours``: the SPARK pipeline (:mod:`spark_bench.spark`, imported only when used);
- third-party methods: the entry-point group ``spark_bench.methods``, each entry a callable
  ``factory(options: dict) -> Generator``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from spark_bench.errors import InputError, SparkBenchError

#: What a method may see of a case: the input image, the camera, the part masks of the input image,
#: the open-state image, the ground truth's part meshes at rest with its kinematic tree (no joint
#: parameters), and the ground-truth object itself (the oracle only).
INPUT_KINDS = ("image", "camera", "masks", "open_image", "part_meshes", "gt")
ENTRY_POINT_GROUP = "spark_bench.methods"
#: File the runner writes beside a finished generation; its presence makes the generation cached.
GENERATION_MARKER = ".spark_bench_generation.json"
#: The case file or folder behind each input kind that is one (docs/formats.md).
CASE_FILES = {"image": "input.png", "camera": "camera.json", "masks": "input_seg.png", "open_image": "open.png",
              "gt": "gt"}


class GenerationError(SparkBenchError):
    """A method failed on one case (the case is recorded as failed with this message)."""


# ----- what a method sees ---------------------------------------------------------------------
@dataclass
class PartMeshes:
    """The ground truth's parts at rest, without joint parameters (the geometry baseline's input).

    :param meshes: world-frame (benchmark frame) rest mesh of each link that has geometry
    :param parents: parent link of each non-root link
    :param joint_names: name of the joint above each non-root link
    :param movable: whether that joint moves (its type, axis, pivot and limits are hidden)
    :param root: the root link
    :param category: object category
    :param colors: display colour of each link (for renders)
    :param object_rotation: 3x3 world orientation of the object frame (the PartNet-Mobility root joint's
        rotation: meshes Y-up, front +Z), a dataset convention, not a joint parameter
    """

    meshes: dict
    parents: dict[str, str]
    joint_names: dict[str, str]
    movable: dict[str, bool]
    root: str
    category: str = ""
    colors: dict = field(default_factory=dict)
    object_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def subtree(self, link: str) -> list[str]:
        """``link`` and every link below it."""
        out, stack = [], [link]
        while stack:
            current = stack.pop()
            out.append(current)
            stack.extend(c for c, p in self.parents.items() if p == current)
        return out


@dataclass
class CaseInput:
    """One benchmark case as a method sees it; accessors for inputs outside ``allowed`` raise.

    :param case_id: the case id
    :param case_dir: the case folder (for methods that read it themselves, like ``ours``)
    :param category: object category
    :param allowed: the input kinds this method declared
    """

    case_id: str
    case_dir: Path
    category: str
    allowed: frozenset[str]

    def _need(self, kind: str) -> None:
        if kind not in self.allowed:
            raise PermissionError(f"case {self.case_id}: this method did not declare input {kind!r}")

    def path(self, kind: str) -> Path:
        """The case file behind input ``kind`` (a key of :data:`CASE_FILES`).

        :raises PermissionError: when the method did not declare ``kind``
        """
        self._need(kind)
        return self.case_dir / CASE_FILES[kind]

    @property
    def image(self) -> Path:
        """The input RGB image (rest state)."""
        return self.path("image")

    @property
    def camera(self) -> dict:
        """``camera.json``: intrinsics and pose (OpenCV convention, benchmark frame)."""
        from spark_bench.data.readers import read_json

        path = self.path("camera")
        camera = read_json(path, missing="camera file not found")
        if not isinstance(camera, dict):
            raise InputError(path, "expected a JSON object")
        return camera

    @property
    def masks(self) -> Path:
        """The 16-bit part-index image of the input view."""
        return self.path("masks")

    @property
    def open_image(self) -> Path:
        """The RGB image with every movable joint open."""
        return self.path("open_image")

    @property
    def gt_dir(self) -> Path:
        """The ground-truth object folder."""
        return self.path("gt")

    def part_meshes(self) -> PartMeshes:
        """The ground truth's part meshes at rest and its tree; joint types and parameters stripped."""
        self._need("part_meshes")
        from spark_bench.data import load_object

        gt = load_object(self.case_dir / "gt")
        parents = {j.child: j.parent for j in gt.joints.values()}
        root_fixed = [j for j in gt.joints.values() if j.parent == gt.root and j.type == "fixed"]
        rotation = root_fixed[0].origin[:3, :3].copy() if root_fixed else np.eye(3)
        return PartMeshes(
            meshes=gt.link_meshes(), parents=parents,
            joint_names={j.child: j.name for j in gt.joints.values()},
            movable={j.child: j.is_movable for j in gt.joints.values()},
            root=gt.root, category=gt.category,
            colors={n: link.visuals[0].rgba for n, link in gt.links.items() if link.visuals},
            object_rotation=rotation)


@dataclass
class Generation:
    """What a method produced for one case.

    :param folder: the predicted object folder
    :param info: anything the method reports (stage timings, the prior used...), stored with the row
    :param variants: further predicted object folders evaluated as rows of their own, by variant name
        (``{"w/o joint opt.": folder}``)
    :param shape_metrics_valid: False when the geometry is the ground truth's (an annotation backend):
        the shape metrics are then shown as n/a, never as zeros
    """

    folder: Path
    info: dict = field(default_factory=dict)
    variants: dict[str, Path] = field(default_factory=dict)
    shape_metrics_valid: bool = True

    def to_json(self) -> dict:
        return {"folder": str(self.folder), "info": self.info, "shape_metrics_valid": self.shape_metrics_valid,
                "variants": {k: str(v) for k, v in self.variants.items()}}

    @classmethod
    def from_json(cls, data) -> Generation:
        """The inverse of :meth:`to_json`.

        :raises ValueError: when ``data`` is not such an object
        """
        try:
            return cls(Path(data["folder"]), dict(data.get("info", {})),
                       {k: Path(v) for k, v in data.get("variants", {}).items()},
                       bool(data.get("shape_metrics_valid", True)))
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"not a generation record: {exc!r}") from None

    @classmethod
    def from_result(cls, result, out_dir: Path) -> Generation:
        """Normalize what ``generate`` returned: None (the folder is ``out_dir``), a dict with optional
        keys ``folder``, ``variants``, ``shape_metrics_valid`` (the rest is ``info``), or a Generation."""
        if isinstance(result, Generation):
            return result
        if result is None:
            return cls(Path(out_dir))
        if not isinstance(result, dict):
            raise GenerationError(f"generate() returned {type(result).__name__}, expected a dict or None")
        info = dict(result)
        folder = Path(info.pop("folder", out_dir))
        variants = {str(k): Path(v) for k, v in (info.pop("variants", None) or {}).items()}
        valid = bool(info.pop("shape_metrics_valid", True))
        return cls(folder, info, variants, valid)


@runtime_checkable
class Generator(Protocol):
    """A reconstruction method under test.

    Attributes: ``name`` (registry name), ``version`` (written into every row), ``inputs`` (a subset of
    :data:`INPUT_KINDS`) and ``regime`` (the input regime shown on the leaderboard).
    """

    name: str
    version: str
    inputs: tuple[str, ...]
    regime: str

    def label(self) -> str:
        """The display label of this method and configuration (a leaderboard row name)."""

    def config(self) -> dict:
        """The JSON-serializable configuration; its hash keys the cache and the results."""

    def generate(self, case: CaseInput, out_dir: Path) -> Generation | dict | None:
        """Write the predicted object folder for ``case`` (into ``out_dir``, created and empty)."""


@dataclass(frozen=True)
class MethodSpec:
    """A method as plain data (picklable, for process pools and Ray tasks).

    :param name: registry name (``oracle``, ``geometry``, ``predictions``, ``command``, ``ours``, an
        entry point, or an entry of ``methods_file``)
    :param options: method options: ``predictions`` (folder), ``methods_file``, ``config`` (file),
        ``label`` (display label override), ``regime``
    """

    name: str
    options: tuple[tuple[str, object], ...] = ()

    @classmethod
    def create(cls, name: str, **options) -> MethodSpec:
        return cls(name, tuple(sorted((k, v) for k, v in options.items() if v is not None)))

    @property
    def option_dict(self) -> dict:
        return dict(self.options)


# ----- registry -------------------------------------------------------------------------------
Factory = Callable[[dict], Generator]
_REGISTRY: dict[str, Factory] = {}


def register(name: str, factory: Factory, overwrite: bool = False) -> None:
    """Make ``factory(options) -> Generator`` available as ``--method name``."""
    if name in _REGISTRY and not overwrite:
        raise ValueError(f"method {name!r} is already registered")
    _REGISTRY[name] = factory


def _oracle(options: dict) -> Generator:
    from spark_bench.baselines.oracle import Oracle

    return Oracle()


def _geometry(options: dict) -> Generator:
    from spark_bench.baselines.geometry import GeometryBaseline

    return GeometryBaseline.from_options(options)


def _predictions(options: dict) -> Generator:
    from spark_bench.external_methods import PredictionsFolder

    if not options.get("predictions"):
        raise SparkBenchError("--method predictions needs --predictions DIR")
    return PredictionsFolder(options["predictions"], options.get("label"), options.get("regime") or "image")


def _command(options: dict) -> Generator:
    from spark_bench.external_methods import CommandMethod, read_methods_file

    if not options.get("methods_file"):
        raise SparkBenchError("--method command needs --methods-file FILE (and --entry NAME if it has several)")
    templates = read_methods_file(options["methods_file"])
    entry = options.get("entry")
    if entry is None and len(templates) == 1:
        entry = next(iter(templates))
    if entry not in templates:
        raise InputError(options["methods_file"], f"no method {entry!r} (has {sorted(templates)})")
    return CommandMethod(templates[entry])


class OursMethod:
    """SPARK (:func:`spark_bench.spark.run_ours`), imported only when used.

    Stages run on simulated priors (an ``annotation`` backend reads the ground truth, the ``dataset``
    open-state backend reads the rendered open image) are named in the regime, and the label is the
    configuration's (``ours (prior=annotation,...)``). When the geometry is the ground truth's, the
    shape metrics are marked invalid (n/a). The prior before joint optimization is a variant of its own
    (``w/o joint opt.``, paper Table 4).

    :param config: a ``SparkConfig``
    """

    name = "ours"

    def __init__(self, config):
        from spark_bench import __version__

        self.spark_config = config
        self.version = __version__
        simulated = [f"gt {stage}" for stage, backend in (("prior", config.prior.backend),
                                                           ("geometry", config.geometry.backend))
                     if backend == "annotation"]
        if config.optimize.enabled and config.open_state.backend == "dataset":
            simulated.append("gt open image")
        self.regime = " + ".join(["image", *simulated])
        self.inputs = ("image", "camera", "open_image", *(("gt",) if simulated else ()))

    @classmethod
    def from_options(cls, options: dict) -> OursMethod:
        from spark_bench.spark import SparkConfig  # the registry works before SPARK is installed

        path = options.get("config")
        return cls(SparkConfig.from_file(path) if path else SparkConfig())

    def label(self) -> str:
        return f"ours ({self.spark_config.label()})"

    def config(self) -> dict:
        return self.spark_config.to_dict()

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        from spark_bench.spark import run_ours

        report = run_ours(case.case_dir, out_dir, self.spark_config)
        variants = {}
        if self.spark_config.optimize.enabled and (Path(out_dir) / "prior" / "mobility.urdf").is_file():
            variants["w/o joint opt."] = Path(out_dir) / "prior"
        info = {k: report[k] for k in ("label", "backends", "timings", "movable_joints") if k in report}
        return Generation(Path(out_dir), info, variants,
                          shape_metrics_valid=not report.get("geometry_is_ground_truth", False))


def _ours(options: dict) -> Generator:
    return OursMethod.from_options(options)


register("oracle", _oracle)
register("geometry", _geometry)
register("predictions", _predictions)
register("command", _command)
register("ours", _ours)


def _entry_points() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_methods() -> list[str]:
    """Names usable with ``--method``: built-ins and installed entry points."""
    return sorted(set(_REGISTRY) | set(_entry_points()))


def make_generator(spec: MethodSpec | str, **options) -> Generator:
    """Build the generator for ``spec``.

    Look-up order: an entry of the methods file (``methods_file`` option) named ``spec.name``, the
    built-in registry, then the ``spark_bench.methods`` entry points.

    :param spec: a :class:`MethodSpec` or a method name
    :param options: further options when ``spec`` is a name
    """
    if isinstance(spec, str):
        spec = MethodSpec.create(spec, **options)
    opts = spec.option_dict
    if opts.get("methods_file") and spec.name not in _REGISTRY:
        from spark_bench.external_methods import CommandMethod, read_methods_file

        templates = read_methods_file(opts["methods_file"])
        if spec.name in templates:
            return CommandMethod(templates[spec.name])
    if spec.name in _REGISTRY:
        return _REGISTRY[spec.name](opts)
    eps = _entry_points()
    if spec.name in eps:
        factory = eps[spec.name].load()
        generator = factory(opts)
        missing = [a for a in ("name", "version", "inputs", "regime", "label", "config", "generate")
                   if not hasattr(generator, a)]
        if missing:
            raise SparkBenchError(f"entry point {spec.name!r} gave an object without {missing}")
        return generator
    raise SparkBenchError(f"unknown method {spec.name!r}; available: {', '.join(available_methods())}")


def json_default(value):
    """``json.dumps`` fallback for NumPy values and paths in method info."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
