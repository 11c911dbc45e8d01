"""What every method is and sees: the input kinds, :class:`CaseInput`, :class:`Generation`, the
:class:`Method` protocol and :class:`MethodSpec`.

A method turns one benchmark case into an object folder in PartNet-Mobility conventions
(``mobility.urdf`` + meshes). It declares which inputs of the case it may see (:data:`INPUT_KINDS`); the
runner hands it a :class:`CaseInput` that refuses everything else, so the input regime printed on the
leaderboard is the one the method really had.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.data.case import BenchmarkCase
from spark_bench.errors import SparkBenchError

#: What a method may see of a case:
#:
#: - ``image``: the input RGB image (rest state);
#: - ``camera``: the camera of both images (intrinsics and pose, benchmark frame);
#: - ``masks``: the per-link label image of the *input* view;
#: - ``open_image``: the RGB image of the open state;
#: - ``open_masks``: the per-link label image of the *open* state (ground-truth part masks);
#: - ``part_meshes``: the ground truth's part meshes at rest with its kinematic tree, no joint parameters;
#: - ``gt``: the ground-truth object itself (the oracle, and simulated stages that corrupt it).
INPUT_KINDS = ("image", "camera", "masks", "open_image", "open_masks", "part_meshes", "gt")
#: How each input kind is named in a regime (what the leaderboard prints); ground-truth-derived kinds say so.
REGIME_NAMES = {"image": "image", "camera": "gt camera", "masks": "gt masks", "open_image": "gt open image",
                "open_masks": "gt open part masks", "part_meshes": "gt part meshes", "gt": "gt"}
#: File the runner writes beside a finished generation; its presence makes the generation cached.
GENERATION_MARKER = ".spark_bench_generation.json"


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
    """One benchmark case as a method sees it; every accessor of an input outside ``allowed`` raises.

    :param case: the benchmark case
    :param allowed: the input kinds this method declared
    """

    case: BenchmarkCase
    allowed: frozenset[str]

    @property
    def case_id(self) -> str:
        return self.case.id

    @property
    def category(self) -> str:
        """The object category (part of every case's identity, not an input)."""
        return self.case.category

    def _need(self, kind: str) -> None:
        if kind not in self.allowed:
            raise PermissionError(f"case {self.case_id}: this method did not declare input {kind!r}")

    def path(self, kind: str) -> Path:
        """The case file or folder behind input ``kind`` (for external programs).

        :raises PermissionError: when the method did not declare ``kind``
        """
        self._need(kind)
        paths = {"image": self.case.input_image, "camera": self.case.camera_path, "masks": self.case.input_seg,
                 "open_image": self.case.open_image, "open_masks": self.case.open_seg, "gt": self.case.gt_dir}
        if kind not in paths:
            raise ValueError(f"input {kind!r} is not a file of the case")
        return paths[kind]

    @property
    def image(self) -> Path:
        """The input RGB image (rest state)."""
        return self.path("image")

    @property
    def camera(self) -> dict:
        """``camera.json``: intrinsics and pose (OpenCV convention, benchmark frame)."""
        self._need("camera")
        return self.case.read_camera()

    @property
    def masks(self) -> Path:
        """The 16-bit link-label image of the input view."""
        return self.path("masks")

    @property
    def open_image(self) -> Path:
        """The RGB image with every movable joint open."""
        return self.path("open_image")

    def open_part_masks(self) -> dict[str, np.ndarray]:
        """The open state's visible mask of each ground-truth link, by link name."""
        self._need("open_masks")
        return self.case.part_masks("open")

    def open_labels(self) -> np.ndarray:
        """The open state's link-label image (0 background, k + 1 = link k of :attr:`link_names`)."""
        self._need("open_masks")
        return self.case.read_segmentation("open")

    @property
    def link_names(self) -> list[str]:
        """The ground truth's link names, which the label images index."""
        if not self.allowed & {"masks", "open_masks", "gt"}:
            self._need("open_masks")
        return self.case.links

    @property
    def gt_dir(self) -> Path:
        """The ground-truth object folder (benchmark frame)."""
        return self.path("gt")

    @property
    def folder(self) -> Path:
        """The whole case folder, for external programs that read it themselves: it holds the ground
        truth, so only a method that declared ``gt`` gets it."""
        self._need("gt")
        return self.case.folder

    def load_gt(self):
        """The ground-truth object (benchmark frame)."""
        self._need("gt")
        return self.case.load_gt()

    def part_meshes(self) -> PartMeshes:
        """The ground truth's part meshes at rest and its tree; joint types and parameters stripped."""
        self._need("part_meshes")
        gt = self.case.load_gt()
        parents = {j.child: j.parent for j in gt.joints.values()}
        root_fixed = [j for j in gt.joints.values() if j.parent == gt.root and j.type == JointType.FIXED]
        rotation = root_fixed[0].origin[:3, :3].copy() if root_fixed else np.eye(3)
        return PartMeshes(
            meshes=gt.link_meshes(), parents=parents,
            joint_names={j.child: j.name for j in gt.joints.values()},
            movable={j.child: j.is_movable for j in gt.joints.values()},
            root=gt.root, category=gt.category,
            colors={n: link.visuals[0].rgba for n, link in gt.links.items() if link.visuals},
            object_rotation=rotation)


def regime_of(inputs) -> str:
    """The regime string of a set of input kinds, in :data:`INPUT_KINDS` order (``image + gt camera...``)."""
    return " + ".join(REGIME_NAMES[k] for k in INPUT_KINDS if k in set(inputs))


@dataclass
class Generation:
    """What a method produced for one case.

    :param folder: the predicted object folder
    :param info: anything the method reports (stage timings, the prior used...), stored with the row
    :param variants: further predicted object folders evaluated as rows of their own, by variant name
        (``{"w/o joint opt.": folder}``)
    :param shape_metrics_valid: False when the geometry is the ground truth's (an annotation backend):
        the shape metrics are then shown as n/a, never as zeros
    :param articulation_metrics_valid: False when the method predicts no joints at all (a shape-only
        method: part meshes): the articulation metrics are then shown as n/a, never as errors
    """

    folder: Path
    info: dict = field(default_factory=dict)
    variants: dict[str, Path] = field(default_factory=dict)
    shape_metrics_valid: bool = True
    articulation_metrics_valid: bool = True

    def to_json(self) -> dict:
        return {"folder": str(self.folder), "info": self.info, "shape_metrics_valid": self.shape_metrics_valid,
                "articulation_metrics_valid": self.articulation_metrics_valid,
                "variants": {k: str(v) for k, v in self.variants.items()}}

    @classmethod
    def from_json(cls, data) -> Generation:
        """The inverse of :meth:`to_json`.

        :raises ValueError: when ``data`` is not such an object
        """
        try:
            return cls(Path(data["folder"]), dict(data.get("info", {})),
                       {k: Path(v) for k, v in data.get("variants", {}).items()},
                       bool(data.get("shape_metrics_valid", True)),
                       bool(data.get("articulation_metrics_valid", True)))
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"not a generation record: {exc!r}") from None

    @classmethod
    def from_result(cls, result, out_dir: Path) -> Generation:
        """Normalize what ``generate`` returned: None (the folder is ``out_dir``), a dict with optional
        keys ``folder``, ``variants``, ``shape_metrics_valid``, ``articulation_metrics_valid`` (the rest is
        ``info``), or a Generation."""
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
        articulated = bool(info.pop("articulation_metrics_valid", True))
        return cls(folder, info, variants, valid, articulated)


@runtime_checkable
class Method(Protocol):
    """A reconstruction method under test.

    Attributes: ``name`` (registry name), ``version`` (written into every row), ``inputs`` (a subset of
    :data:`INPUT_KINDS`) and ``regime`` (the input regime shown on the leaderboard).

    A method class is registered with ``@register_method("name")``
    (:func:`spark_bench.methods.registry.register_method`): its classmethod ``from_options(options: dict)``
    builds it, and its mapping ``accepts`` (key -> :class:`~spark_bench.methods.options.MethodOption`) lists
    the options it takes.
    """

    name: str
    version: str
    inputs: tuple[str, ...]
    regime: str

    def label(self) -> str:
        """The display label of this method and configuration (a leaderboard row name)."""

    def prepare(self) -> None:
        """Do the heavy one-time work before any case (build a gallery and its index, load weights); the
        runner calls it once, in its own process, before :meth:`config`. Optional for third-party methods
        (:func:`prepare_method`); calling it again does nothing."""

    def config(self) -> dict:
        """The JSON-serializable configuration; its hash keys the cache and the results. Only returns data:
        what needs work to know (a gallery's content hash) is known after :meth:`prepare`."""

    def generate(self, case: CaseInput, out_dir: Path) -> Generation | dict | None:
        """Write the predicted object folder for ``case`` (into ``out_dir``, created and empty)."""


#: The attributes :func:`spark_bench.methods.registry.make_method` checks on a third-party method
#: (``prepare`` is optional: :func:`prepare_method`).
METHOD_ATTRIBUTES = ("name", "version", "inputs", "regime", "label", "config", "generate")


def prepare_method(method) -> None:
    """Call ``method.prepare()`` where the method has one (a third-party method may not)."""
    prepare = getattr(method, "prepare", None)
    if callable(prepare):
        prepare()


class NotPreparedError(SparkBenchError):
    """``config()`` was asked for what only :meth:`Method.prepare` establishes."""


@dataclass(frozen=True)
class MethodSpec:
    """A method as plain data (picklable, for process pools and Ray tasks).

    :param name: registry name (``oracle``, ``geometry``, ``predictions``, ``command``, ``ours``,
        ``retrieval``, an entry point, or an entry of ``methods_file``)
    :param options: the options handed to the method's factory, sorted ``(key, value)`` pairs: what
        ``eval --method-args`` and a config file's ``[method]`` table give, checked and typed by
        :func:`spark_bench.methods.registry.method_spec` (``predictions``, ``gallery``, ``config``...)
    """

    name: str
    options: tuple[tuple[str, object], ...] = ()

    @classmethod
    def create(cls, name: str, /, **options) -> MethodSpec:
        return cls(name, tuple(sorted((k, v) for k, v in options.items() if v is not None)))

    @property
    def option_dict(self) -> dict:
        return dict(self.options)
