"""Readers for object folders: PartNet-Mobility and GAPartNet's extra files.

Both share one layout (a ``mobility.urdf`` beside its meshes, any mesh format trimesh reads, GLB
included); what differs is the side files: ``semantics.txt`` and ``meta.json`` (PartNet-Mobility),
``link_annotation_gapartnet.json`` and ``semantics_gapartnet.txt`` (GAPartNet). SPARK's run folders are
not object folders (their URDF points where no mesh is, their frame is SPARK's):
:mod:`spark_bench.formats.spark.reader` converts them.
"""

from __future__ import annotations

import json
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.urdf import load_urdf
from spark_bench.errors import InputError

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


def load_object(path: str | Path, variant: str = "mobility", load_meshes: bool = True) -> ArticulatedAsset:
    """Read an object folder (or a URDF file) into an :class:`ArticulatedAsset`.

    :param path: PartNet-Mobility / GAPartNet / SPARK object folder, or a URDF file
    :param variant: which URDF of a GAPartNet folder to read, see :func:`find_urdf`
    :param load_meshes: read the mesh files (False reads the kinematic structure only)
    """
    urdf = find_urdf(path, variant)
    folder = urdf.parent
    asset = load_urdf(urdf, folder=folder, load_meshes=load_meshes)
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
    return asset
