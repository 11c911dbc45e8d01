"""Readers for object folders: PartNet-Mobility and GAPartNet's extra files.

Both share one layout (a ``mobility.urdf`` beside its meshes, any mesh format trimesh reads, GLB
included); what differs is the side files: ``semantics.txt`` and ``meta.json`` (PartNet-Mobility),
``link_annotation_gapartnet.json`` and ``semantics_gapartnet.txt`` (GAPartNet). SPARK's run folders are
not object folders (their URDF points where no mesh is, their frame is SPARK's):
:mod:`spark_bench.formats.spark.reader` converts them.

A model file named directly (:func:`load_model_file`) is read as it lies: a URDF anywhere (mesh paths as ROS
resolves them), an MJCF file through MuJoCo, a USD file through ``usd-core``.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.ops import scale_asset
from spark_bench.asset.urdf import load_urdf
from spark_bench.data.real_size import source_scale
from spark_bench.errors import InputError

logger = logging.getLogger(__name__)
#: ``(urdf, joint)`` pairs already warned about in this process: an object is read once per episode.
_WARNED: set[tuple[str, str]] = set()

URDF_NAMES = {"mobility": "mobility.urdf", "gapartnet": "mobility_annotation_gapartnet.urdf"}


def find_urdf(path: str | Path, variant: str = "mobility") -> Path:
    """The URDF of an object folder (or ``path`` itself when it is a file).

    :param variant: ``mobility`` (``mobility.urdf``) or ``gapartnet`` (GAPartNet's annotated URDF,
        whose handles are links of their own)
    """
    path = Path(path)
    if path.is_file():
        return path
    if not path.is_dir():
        raise InputError(path, "no such object folder or URDF file")
    if variant not in URDF_NAMES:
        raise InputError(path, f"unknown URDF variant {variant!r} (choose from {sorted(URDF_NAMES)})")
    candidate = path / URDF_NAMES[variant]
    if candidate.is_file():
        return candidate
    urdfs = sorted(path.glob("*.urdf"))
    if variant == "mobility" and len(urdfs) == 1:
        return urdfs[0]
    raise InputError(path, f"object folder has no {URDF_NAMES[variant]}")


def read_semantics(path: Path) -> dict[str, tuple[str, str]]:
    """``semantics.txt``: link name -> (joint word, label). Missing file: empty."""
    out: dict[str, tuple[str, str]] = {}
    if not path.is_file():
        return out
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        words = line.split()
        if not words:
            continue
        if len(words) < 2:
            raise InputError(path, f"line {number}: expected 'link_name joint_kind [label]', got {line!r}")
        out[words[0]] = (words[1], " ".join(words[2:]))
    return out


REQUIRED = object()


def read_json(path: Path, default=REQUIRED, missing: str = "file not found"):
    """A JSON file; when absent, ``default`` if one is given, else an input error saying ``missing``.
    Malformed JSON is always an input error naming the file."""
    path = Path(path)
    if not path.is_file():
        if default is REQUIRED:
            raise InputError(path, missing)
        return default
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"malformed JSON: {exc}") from None


#: Suffixes of the model files :func:`load_object` reads besides URDF: MJCF (through MuJoCo) and USD.
MJCF_SUFFIXES = (".xml", ".mjcf")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


def load_model_file(path: Path) -> ArticulatedAsset | None:
    """A model file the user named directly, read as it lies: an MJCF (:mod:`spark_bench.asset.mjcf_model`: its
    visuals, its own collision geoms as MuJoCo simulates them and its joints' damping and friction loss) or a
    USD file (:mod:`spark_bench.asset.usd_model`); None for anything else (a URDF: :func:`load_object` reads
    it with its side files, its mesh paths as ROS resolves them, :mod:`spark_bench.asset.mesh_paths`).

    :param path: the file
    """
    suffix = path.suffix.lower()
    if suffix in MJCF_SUFFIXES:
        from spark_bench.asset.mjcf_model import build_asset, collision_shapes, compile_model, visual_geometry

        compiled = compile_model(path)
        geometry, collisions = visual_geometry(compiled, path.resolve().parent), collision_shapes(compiled)
        for body, shapes in collisions.items():  # a body drawn by its collision geoms only
            if body not in geometry.meshes:
                geometry.meshes[body] = [(s.to_trimesh(), (0.7, 0.7, 0.7, 1.0), s.source) for s in shapes]
        asset, _ = build_asset(compiled, geometry, path.stem, collisions=collisions)
        asset.source = str(path)
        return asset
    if suffix in USD_SUFFIXES:
        from spark_bench.asset.usd_model import read_usd

        return read_usd(path)
    return None


def load_object(path: str | Path, variant: str = "mobility", load_meshes: bool = True,
                package_paths: Sequence[str | Path] | None = None) -> ArticulatedAsset:
    """Read an object folder (or a model file) into an :class:`ArticulatedAsset`.

    :param path: PartNet-Mobility / GAPartNet / SPARK object folder, or a URDF, MJCF (``.xml``) or USD
        (``.usd``, ``.usda``, ``.usdc``) file
    :param variant: which URDF of a GAPartNet folder to read, see :func:`find_urdf`
    :param load_meshes: read the mesh files (False reads the kinematic structure only)
    :param package_paths: folders searched for a URDF's ``package://NAME/`` paths (then ``ROS_PACKAGE_PATH``)

    A folder's URDF must keep its mesh paths inside the folder (a benchmark case, an import); a file named
    directly is read as it lies (:func:`load_model_file`). A PartNet-Mobility object comes back at its real
    size (:mod:`spark_bench.data.real_size`: its lengths times
    :func:`~spark_bench.data.real_size.source_scale`); every other object as its files give it.
    """
    as_it_lies = Path(path).is_file()
    if as_it_lies:
        model = load_model_file(Path(path))
        if model is not None:
            return model
    urdf = find_urdf(path, variant)
    folder = urdf.parent
    asset = load_urdf(urdf, folder=folder, load_meshes=load_meshes, as_it_lies=as_it_lies,
                      package_paths=package_paths)
    asset.name = folder.name if Path(path).is_dir() else asset.name
    meta = read_json(folder / "meta.json", {})
    if not isinstance(meta, dict):
        raise InputError(folder / "meta.json", "expected a JSON object")
    asset.meta = meta
    asset.category = str(meta.get("model_cat", ""))
    semantics_file = "semantics_gapartnet.txt" if variant == "gapartnet" else "semantics.txt"
    for link_name, (word, label) in read_semantics(folder / semantics_file).items():
        if link_name in asset.links:
            asset.links[link_name].semantic_joint = word
            asset.links[link_name].label = label
    annotations = read_json(folder / "link_annotation_gapartnet.json", [])
    if not isinstance(annotations, list):
        raise InputError(folder / "link_annotation_gapartnet.json", "expected a JSON list")
    for item in annotations:
        if isinstance(item, dict) and item.get("link_name") in asset.links:
            asset.links[item["link_name"]].annotations.update(
                {k: v for k, v in item.items() if k != "link_name"})
    fill_unwritten_joints(asset, urdf, folder / "mobility_v2.json")
    size = source_scale(folder, asset.category)
    if size.factor != 1.0:  # PartNet-Mobility's units are not metres (spark_bench.data.real_size)
        scale_asset(asset, size.factor, copy=False)
    return asset


def annotated_joint(entry: dict, joint_type: str) -> tuple[np.ndarray, float, float] | None:
    """``(direction, lower, upper)`` of one ``mobility_v2.json`` entry in the joint's units (radians or
    the object's length), or None when it has no axis or no bounded range.

    The annotation gives a direction and a range ``[a, b]`` (degrees for a hinge) that may run backwards
    (``a > b``); PartNet-Mobility's own URDFs write such a joint about the opposite direction with the range
    ``[-a, -b]``, in the same frame. Checked on the 201 joints of partnet_dev and real_objects that write
    both: 192 read back identical, the other 9 are symmetric ranges the URDF writes about the opposite
    direction (the same motion).
    """
    data = entry.get("jointData") or {}
    direction = np.asarray((data.get("axis") or {}).get("direction", []), dtype=float)
    limit = data.get("limit") or {}
    if direction.shape != (3,) or not np.all(np.isfinite(direction)) or np.linalg.norm(direction) < 1e-9:
        return None
    if limit.get("noLimit") or not all(isinstance(limit.get(k), (int, float)) for k in ("a", "b")):
        return None
    a, b = float(limit["a"]), float(limit["b"])
    if joint_type == JointType.REVOLUTE:
        a, b = np.radians(a), np.radians(b)
    direction = direction / np.linalg.norm(direction)
    return (direction, a, b) if a <= b else (-direction, -a, -b)


def fill_unwritten_joints(asset: ArticulatedAsset, urdf: Path, annotation: Path) -> list[str]:
    """Give the revolute and prismatic joints that ``urdf`` writes without ``<axis>`` or ``<limit>`` those of
    PartNet-Mobility's own annotation (``mobility_v2.json``, entry ``id`` N for ``joint_N``), with a warning.

    The URDF's defaults would put such a joint about the x axis over [0, pi] (or a slider of no travel):
    7 of the 232 movable joints of ``partnet_dev`` and ``real_objects`` (a safe door 101612 that then swung
    into its safe; two suitcase lids that rested wide open; two bucket handles; two toaster levers). Where
    no annotation gives the joint, the URDF's defaults stay, with a warning (each once per process). What the
    URDF wrote is :attr:`~spark_bench.asset.model.Joint.has_axis` / ``has_limits``, as the reader found it.
    Returns the names of the joints filled.
    """
    unwritten = {joint.name: {tag for tag, given in (("axis", joint.has_axis), ("limit", joint.has_limits))
                              if not given}
                 for joint in asset.joints.values()
                 if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC) and not (joint.has_axis and joint.has_limits)}
    if not unwritten:
        return []
    entries = read_json(annotation, None) if annotation.is_file() else None
    by_id = {str(e.get("id")): e for e in entries if isinstance(e, dict)} if isinstance(entries, list) else {}
    filled = []
    for name, missing in sorted(unwritten.items()):
        joint = asset.joints[name]
        entry = by_id.get(name.removeprefix("joint_"))
        found = annotated_joint(entry, joint.type) if entry is not None else None
        first = (str(urdf), name) not in _WARNED
        _WARNED.add((str(urdf), name))
        if found is None:
            if first:
                logger.warning("%s: joint %r has no <%s> and %s gives none: the URDF's defaults are used",
                               urdf, name, "> or <".join(sorted(missing)), annotation.name)
            continue
        # the annotation is in the frame of the object's parts, as the URDF's axes are (its part joints carry
        # no rotation; only its root joint turns the object z-up)
        axis, lower, upper = found
        if "axis" in missing:
            joint.axis, joint.has_axis = axis, True
        elif "limit" in missing and float(np.dot(joint.axis, axis)) < 0:  # written about the other way
            lower, upper = -upper, -lower
        if "limit" in missing:
            joint.lower, joint.upper, joint.has_limits = lower, upper, True
        filled.append(name)
        if first:
            logger.warning("%s: joint %r has no <%s>: taken from %s (axis %s, range [%.4g, %.4g])", urdf, name,
                           "> or <".join(sorted(missing)), annotation.name, np.round(joint.axis, 4).tolist(),
                           joint.lower, joint.upper)
    return filled
