"""Cache of a link's final collision shapes, keyed by its geometry and the options that shape them.

CoACD results are cached per mesh (:mod:`spark_bench.sim.decompose`); this second layer skips the
whole per-link pipeline (welding, convexity tests, hull budget, erosion) on a repeated conversion, so a
cached conversion costs reading the meshes and building the model. Files live in
``<cache>/links/<key[:2]>/<key>.npz`` and are written atomically.

Both layers, and the contact resolution (:func:`object_key`), are keyed and stored in units of the
object's size: every tolerance of the conversion is relative to it (thickness, clearance, convexity,
overlaps, relief depths), so an object scaled as a whole gets the same decisions, scaled. A benchmark
case's ground truth is converted in the benchmark frame by the sim checks and in metres by the opener:
the second conversion reads what the first computed.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.sim.file_cache import atomic_savez, atomic_write_text, entry_path, load_npz
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.shapes import CollisionShape

#: Bumped whenever the same link and options would give other shapes.
SHAPES_VERSION = "link-shapes-7"
KINDS = ("box", "cylinder", "sphere", "mesh")


def link_key(meshes: Sequence[trimesh.Trimesh], ready: Sequence[CollisionShape], options: ConvertOptions,
             size: float) -> str:
    """Key of a link's shapes: its element meshes and given convex shapes in units of the object's
    ``size`` (thicknesses and clearances are relative to it), and the geometry options."""
    digest = hashlib.sha256(SHAPES_VERSION.encode())
    geometry = {k: v for k, v in asdict(options).items()
                if k in ("coacd", "convex_tolerance", "min_thickness", "clearance", "hull_budget",
                         "max_hull_vertices", "decompose_visuals", "max_part_faces", "exact_boxes")}
    digest.update(json.dumps(geometry, sort_keys=True).encode())
    for mesh in meshes:
        _hash_values(digest, np.asarray(mesh.vertices, np.float64) / size)
        digest.update(np.asarray(mesh.faces, np.int64).tobytes())
    for shape in ready:
        _hash_shape(digest, scaled(shape, 1.0 / size))
    return digest.hexdigest()


def scaled(shape: CollisionShape, factor: float) -> CollisionShape:
    """``shape`` scaled by ``factor`` about its link's origin (lengths only: rotations stay)."""
    origin = np.array(shape.origin, np.float64, copy=True)
    origin[:3, 3] *= factor
    return CollisionShape(shape.kind, shape.method, origin=origin,
                          size=np.asarray(shape.size, np.float64) * factor,
                          vertices=None if shape.vertices is None else np.asarray(shape.vertices, np.float64) * factor,
                          faces=shape.faces)


def as_cached(shapes: Sequence[CollisionShape], size: float) -> list[CollisionShape]:
    """``shapes`` exactly as the cache gives them back: stored in units of ``size``, read and scaled back
    (``x / size * size`` is not ``x`` to the last bit). Freshly computed shapes are passed through this
    before they are used, so a first run (cache filled) and a later one (cache read), or a run without the
    cache, simulate bit for bit the same model: contact-rich episodes diverge from a 1e-18 difference.

    :param shapes: the shapes, in lengths of the object
    :param size: the object's size
    """
    return [scaled(scaled(s, 1.0 / size), size) for s in shapes]


def as_cached_length(value: float, size: float) -> float:
    """A length exactly as the contact cache gives it back (stored in units of ``size``)."""
    return float(value) / size * size


def _hash_values(digest, array) -> None:
    """Hash float values rounded to 1e-9 (lengths are in units of the object's size: 1e-9 of it), so
    float noise does not change a key."""
    digest.update(np.round(np.asarray(array, np.float64) * 1e9).astype(np.int64).tobytes())


def _hash_shape(digest, shape: CollisionShape) -> None:
    digest.update(shape.kind.encode())
    for array in (shape.origin, shape.size, shape.vertices):
        if array is not None:
            _hash_values(digest, array)


def _path(cache: Path, key: str) -> Path:
    return entry_path(Path(cache) / "links", key)


def store_shapes(cache: Path, key: str, shapes: Sequence[CollisionShape], size: float) -> None:
    """Write ``shapes`` under ``key`` (atomically), in units of ``size`` (the object's)."""
    arrays: dict[str, np.ndarray] = {"methods": np.array(json.dumps([s.method for s in shapes]))}
    for k, shape in enumerate(scaled(s, 1.0 / size) for s in shapes):
        arrays[f"{k}_kind"] = np.array(KINDS.index(shape.kind))
        arrays[f"{k}_origin"] = np.asarray(shape.origin, np.float64)
        arrays[f"{k}_size"] = np.asarray(shape.size, np.float64)
        if shape.kind == "mesh":
            arrays[f"{k}_vertices"] = np.asarray(shape.vertices, np.float64)
            arrays[f"{k}_faces"] = np.asarray(shape.faces, np.int64)
    atomic_savez(_path(cache, key), arrays)


def load_shapes(cache: Path, key: str, size: float) -> list[CollisionShape] | None:
    """Shapes stored under ``key`` (scaled back by ``size``, the object's), or None when absent or unreadable."""
    shapes = load_npz(_path(cache, key), _unpack_shapes)
    return None if shapes is None else [scaled(s, size) for s in shapes]


def _unpack_shapes(data) -> list[CollisionShape]:
    out = []
    for k, method in enumerate(json.loads(str(data["methods"]))):
        kind = KINDS[int(data[f"{k}_kind"])]
        out.append(CollisionShape(
            kind, method, origin=data[f"{k}_origin"].copy(), size=data[f"{k}_size"].copy(),
            vertices=data[f"{k}_vertices"].copy() if kind == "mesh" else None,
            faces=data[f"{k}_faces"].copy() if kind == "mesh" else None))
    return out


# ----- whole-object contact resolution (exclusions and hinge relief) -------------------------------
def object_key(prepared) -> str:
    """Key of an object's contact resolution: every link's shapes before relief, the joints (lengths in
    units of the object's size: the decisions are relative to it), and the options that decide
    exclusions and relief. The ``contacts-N`` tag is bumped whenever the rules (rest overlaps, hinge
    relief, phantom blockings) or what is stored change (12: the shapes stored are those used, as the link
    cache gives them back, :func:`as_cached`; 17: conv-9: a pair excluded only where the part's own path is free of its parent's surface, the hulls of the others cut apart at rest; ``contacts-conv-10``: the depth judged over the part of
    the range the sweep asks for, the cuts kept only where a pair collides; ``contacts-conv-11d``: a closed part's depth counted
    only inside its closed surface (``contacts-conv-11``, ``-11b`` and ``-11c`` were its drafts). Numbered tags past 17 were taken by
    drafts whose entries may still lie in a cache: a tag is never used twice)."""
    digest = hashlib.sha256(f"{SHAPES_VERSION}/contacts-conv-11d".encode())
    options = prepared.options
    size = prepared.size
    digest.update(json.dumps([options.trim_overlap, options.clearance, list(options.base_quat)]).encode())
    for joint in prepared.asset.joints.values():
        digest.update(json.dumps([joint.name, joint.type, joint.parent, joint.child]).encode())
        origin = np.array(joint.origin, np.float64, copy=True)
        origin[:3, 3] /= size
        limits = np.array([joint.lower, joint.upper], np.float64) / (1.0 if joint.is_rotational else size)
        for array in (origin, joint.axis, limits):
            _hash_values(digest, array)
    for name in sorted(prepared.shapes):
        digest.update(name.encode())
        for shape in prepared.shapes[name]:
            _hash_shape(digest, scaled(shape, 1.0 / size))
    return digest.hexdigest()


def contacts_as_cached(prepared) -> None:
    """Round every length the contact cache stores of ``prepared`` (its shapes, exclusion depths, relief and
    phantom depths) as the cache gives them back (:func:`as_cached`), in place."""
    size = prepared.size
    prepared.shapes = {name: as_cached(shapes, size) for name, shapes in prepared.shapes.items()}
    prepared.excluded = {pair: as_cached_length(d, size) for pair, d in prepared.excluded.items()}
    for cut in prepared.relief + prepared.trim:
        cut.depth = as_cached_length(cut.depth, size)
    for block in prepared.phantom:
        block.depth = as_cached_length(block.depth, size)
        block.surface_depth = as_cached_length(block.surface_depth, size)


def store_contacts(cache: Path, key: str, prepared) -> None:
    """Store the resolved shapes, exclusions, rest-trimming and relief cuts of ``prepared`` under ``key`` (lengths in
    units of the object's size)."""
    size = prepared.size
    entry = {"excluded": [[a, b, d / size] for (a, b), d in prepared.excluded.items()],
             "relief": [{**c.__dict__, "depth": c.depth / size} for c in prepared.relief],
             "trim": [{**c.__dict__, "depth": c.depth / size} for c in prepared.trim],
             "phantom": [{**b.__dict__, "depth": b.depth / size, "surface_depth": b.surface_depth / size}
                         for b in prepared.phantom],
             "links": {}}
    for name, shapes in prepared.shapes.items():
        sub = hashlib.sha256(f"{key}/{name}".encode()).hexdigest()
        store_shapes(cache, sub, shapes, size)
        entry["links"][name] = sub
    atomic_write_text(entry_path(Path(cache) / "objects", key, ".json"), json.dumps(entry))


def load_contacts(cache: Path, key: str, size: float):
    """``(shapes, excluded, trim, relief, phantom)`` stored under ``key``, scaled back by ``size`` (the
    object's), or None."""
    from spark_bench.sim.phantom import PhantomBlock
    from spark_bench.sim.relief import ReliefCut
    from spark_bench.sim.rest_trim import TrimCut

    path = entry_path(Path(cache) / "objects", key, ".json")
    if not path.is_file():
        return None
    try:
        entry = json.loads(path.read_text())
        shapes = {}
        for name, sub in entry["links"].items():
            loaded = load_shapes(cache, sub, size)
            if loaded is None:
                return None
            shapes[name] = loaded
        excluded = {(a, b): float(d) * size for a, b, d in entry["excluded"]}
        relief = [ReliefCut(**{**c, "depth": c["depth"] * size}) for c in entry["relief"]]
        trim = [TrimCut(**{**c, "depth": c["depth"] * size}) for c in entry["trim"]]
        phantom = [PhantomBlock(**{**b, "depth": b["depth"] * size, "surface_depth": b["surface_depth"] * size})
                   for b in entry["phantom"]]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return shapes, excluded, trim, relief, phantom
