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
  without a shell and with a timeout;
- ``ours``: the SPARK pipeline (:mod:`spark_bench.spark`, imported only when used);
- third-party methods: the entry-point group ``spark_bench.methods``, each entry a callable
  ``factory(options: dict) -> Generator``.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import tomllib
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

    @property
    def image(self) -> Path:
        """The input RGB image (rest state)."""
        self._need("image")
        return self.case_dir / "input.png"

    @property
    def camera(self) -> dict:
        """``camera.json``: intrinsics and pose (OpenCV convention, benchmark frame)."""
        self._need("camera")
        path = self.case_dir / "camera.json"
        try:
            return json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise InputError(path, f"cannot read camera: {exc}") from None

    @property
    def masks(self) -> Path:
        """The 16-bit part-index image of the input view."""
        self._need("masks")
        return self.case_dir / "input_seg.png"

    @property
    def open_image(self) -> Path:
        """The RGB image with every movable joint open."""
        self._need("open_image")
        return self.case_dir / "open.png"

    @property
    def gt_dir(self) -> Path:
        """The ground-truth object folder."""
        self._need("gt")
        return self.case_dir / "gt"

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


# ----- built-in adapters ----------------------------------------------------------------------
def _case_dir_name(case_id: str) -> str:
    if not case_id or "/" in case_id or "\\" in case_id or case_id in (".", ".."):
        raise GenerationError(f"unsafe case id {case_id!r}")
    return case_id


class PredictionsFolder:
    """Predictions written beforehand by any method: ``DIR/<case id>/`` is the case's object folder.

    :param folder: the predictions folder
    :param label: display label (default ``predictions:<folder name>``)
    :param regime: the input regime the external method had (default ``image``)
    """

    name = "predictions"
    version = "1"
    inputs: tuple[str, ...] = ()

    def __init__(self, folder: str | Path, label: str | None = None, regime: str = "image"):
        self.folder = Path(folder).expanduser().resolve()
        if not self.folder.is_dir():
            raise InputError(self.folder, "predictions folder not found")
        self._label = label or f"predictions:{self.folder.name}"
        self.regime = regime

    def label(self) -> str:
        return self._label

    def config(self) -> dict:
        return {"predictions": str(self.folder)}

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        folder = self.folder / _case_dir_name(case.case_id)
        if not folder.is_dir():
            raise GenerationError(f"no prediction folder {folder}")
        return Generation(folder, {"source": str(folder)})


@dataclass
class CommandTemplate:
    """An external method run once per case.

    :param name: the entry name (the display label)
    :param argv: the program and its arguments; ``{image}``, ``{out}``, ``{camera}``, ``{case_dir}``,
        ``{case_id}``, ``{open_image}``, ``{masks}`` are replaced (each only if declared in ``inputs``,
        ``{out}``, ``{case_id}`` always)
    :param timeout: seconds before the program is killed and the case fails
    :param inputs: the input kinds the program receives
    :param version: the method's version, written into the rows
    :param cwd: working directory (relative to the methods file)
    :param env: extra environment variables
    :param regime: input regime shown on the leaderboard
    """

    name: str
    argv: list[str]
    timeout: float = 1800.0
    inputs: tuple[str, ...] = ("image", "camera")
    version: str = ""
    cwd: str | None = None
    env: dict[str, str] = field(default_factory=dict)
    regime: str = "image"


def read_methods_file(path: str | Path) -> dict[str, CommandTemplate]:
    """A methods file: TOML (``[methods.NAME]`` tables) or JSON (``{"methods": {NAME: {...}}}``).

    Each entry has ``command`` (a list of arguments, or one string split like a shell would, but never
    run through one), and optionally ``timeout``, ``inputs``, ``version``, ``cwd``, ``env``, ``regime``.
    """
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise InputError(path, "methods file not found")
    try:
        data = tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text())
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"malformed methods file: {exc}") from None
    methods = data.get("methods") if isinstance(data, dict) else None
    if not isinstance(methods, dict) or not methods:
        raise InputError(path, "expected a 'methods' table with one entry per method")
    out = {}
    for name, entry in methods.items():
        if not isinstance(entry, dict) or "command" not in entry:
            raise InputError(path, f"method {name!r} needs a 'command'")
        command = entry["command"]
        argv = shlex.split(command) if isinstance(command, str) else [str(a) for a in command]
        if not argv:
            raise InputError(path, f"method {name!r} has an empty command")
        inputs = tuple(entry.get("inputs", ("image", "camera")))
        bad = set(inputs) - set(INPUT_KINDS)
        if bad:
            raise InputError(path, f"method {name!r}: unknown inputs {sorted(bad)} (choose from {INPUT_KINDS})")
        cwd = entry.get("cwd")
        out[name] = CommandTemplate(
            name=name, argv=argv, timeout=float(entry.get("timeout", 1800.0)), inputs=inputs,
            version=str(entry.get("version", "")), cwd=str((path.parent / cwd).resolve()) if cwd else None,
            env={str(k): str(v) for k, v in (entry.get("env") or {}).items()},
            regime=str(entry.get("regime", "image")))
    return out


class CommandMethod:
    """Runs an external program per case (e.g. SPARK's public ``run.py``), never through a shell.

    :param template: the command template
    """

    name = "command"

    def __init__(self, template: CommandTemplate):
        self.template = template
        self.version = template.version
        self.inputs = template.inputs
        self.regime = template.regime

    def label(self) -> str:
        return self.template.name

    def config(self) -> dict:
        return {"argv": self.template.argv, "inputs": list(self.inputs), "cwd": self.template.cwd,
                "env": self.template.env}

    def arguments(self, case: CaseInput, out_dir: Path) -> list[str]:
        """The argument list for ``case``, placeholders filled."""
        values = {"out": str(out_dir), "case_id": case.case_id}
        getters = {"image": lambda: case.image, "camera": lambda: case.case_dir / "camera.json",
                   "case_dir": lambda: case.case_dir, "open_image": lambda: case.open_image,
                   "masks": lambda: case.masks}
        needs = {"camera": "camera", "case_dir": "gt", "image": "image", "open_image": "open_image",
                 "masks": "masks"}
        for key, getter in getters.items():
            if needs[key] in self.inputs:
                values[key] = str(getter())
        try:
            return [arg.format(**values) for arg in self.template.argv]
        except (KeyError, IndexError, ValueError) as exc:
            raise GenerationError(f"command template of {self.template.name!r}: placeholder {exc} "
                                  f"is unknown or not among its inputs {list(self.inputs)}") from None

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        argv = self.arguments(case, out_dir)
        env = {**os.environ, **self.template.env}
        try:
            proc = subprocess.run(argv, cwd=self.template.cwd, env=env, capture_output=True, text=True,
                                  timeout=self.template.timeout, shell=False, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise GenerationError(f"{self.template.name}: timed out after {self.template.timeout:g} s") from None
        except OSError as exc:
            raise GenerationError(f"{self.template.name}: cannot run {argv[0]!r}: {exc}") from None
        (out_dir / "method_stdout.txt").write_text(proc.stdout[-200_000:])
        (out_dir / "method_stderr.txt").write_text(proc.stderr[-200_000:])
        if proc.returncode != 0:
            tail = [line for line in proc.stderr.splitlines() if line.strip()][-1:] or ["(no stderr)"]
            raise GenerationError(f"{self.template.name}: exit status {proc.returncode}: {tail[0][:300]}")
        return Generation(find_object_folder(out_dir), {"returncode": proc.returncode})


def find_object_folder(out_dir: Path) -> Path:
    """The object folder a method wrote: ``out_dir`` itself, or its one sub-folder with a URDF."""
    out_dir = Path(out_dir)
    if any(out_dir.glob("*.urdf")):
        return out_dir
    found = sorted({p.parent for p in out_dir.rglob("*.urdf")})
    if len(found) == 1:
        return found[0]
    raise GenerationError(f"expected one object folder with a URDF under {out_dir}, found {len(found)}")


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
    if not options.get("predictions"):
        raise SparkBenchError("--method predictions needs --predictions DIR")
    return PredictionsFolder(options["predictions"], options.get("label"), options.get("regime") or "image")


def _command(options: dict) -> Generator:
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
