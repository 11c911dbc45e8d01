"""What every foreign format shares: an object read from another method's output, brought into the benchmark
frame, and written as an object folder with its ``import.json``.

A format's reader (one module of :mod:`spark_bench.formats`) applies what the format says of its frame and
units (Y up to Z up, degrees to radians, a pivot written as a point...) and returns a :class:`ForeignObject`:
the object in PartNet-Mobility's world convention (Z up), at the format's own scale, with a record of every
file read and every fact applied. What the format leaves open stays open and is recorded
(:data:`OPEN_QUESTIONS`): :func:`to_benchmark` squares the footprint to the axes (a turn about the up axis
that depends on the view is then a quarter turn) and normalizes into the benchmark frame; the quarter turn
and the scale are left to ``eval --align icp``, whose alignment (scale included) every results row keeps.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError

#: The record each imported object folder holds.
IMPORT_RECORD = "import.json"
#: Our frame: what every reader converts to.
OUR_FRAME = "PartNet-Mobility world: Z up, front -X"
#: What a format may leave open, recorded in ``frame.open`` and resolved by the metrics' alignment.
OPEN_QUESTIONS = {
    "yaw": "the turn about the up axis (view-dependent): the footprint is squared to the axes, the quarter "
           "turn left goes to `eval --align icp`",
    "scale": "the object's size (a unit box or normalized coordinates): normalized into the benchmark frame; "
             "the scale `eval --align icp` finds is in each row's metrics (`alignment`)",
    "front": "which side is the front: left to `eval --align icp`'s quarter turns",
}


@dataclass
class ForeignObject:
    """One run of another method, read.

    :param asset: the object in PartNet-Mobility's world convention (Z up), at the format's own scale
    :param record: what was read and applied: ``format`` (the format's name), ``files`` (every file read,
        relative to the run folder), ``facts`` (each conversion applied, with the file of the method's code
        it comes from), anything else the format wants kept (not under ``frame``, which :func:`to_benchmark`
        writes: a reader's own frame facts go under ``format_frame``)
    :param articulated: False for a shape-only format (part meshes, no joints): the articulation metrics of
        its rows are n/a, not zero
    :param open_questions: keys of :data:`OPEN_QUESTIONS` the format leaves open
    """

    asset: ArticulatedAsset
    record: dict
    articulated: bool = True
    open_questions: tuple[str, ...] = ("yaw", "scale")


def selected_case_ids(benchmark, cases: list[str] | None) -> list[str]:
    """The benchmark's case ids an import covers: all of them, or ``cases`` in the benchmark's order.

    :param benchmark: a :class:`~spark_bench.data.case.Benchmark`
    :param cases: the case ids asked for (None: every case)
    :raises InputError: naming the benchmark's manifest for a case id it does not hold
    """
    case_ids = benchmark.case_ids()
    if cases:
        unknown_ids = [c for c in cases if c not in case_ids]
        if unknown_ids:
            raise InputError(benchmark.manifest_path, f"no case {unknown_ids[0]!r} in this benchmark")
        case_ids = [c for c in case_ids if c in set(cases)]
    return case_ids


def axis_line(axis, path: Path, what: str) -> tuple[np.ndarray, np.ndarray]:
    """``(a point on the axis, its unit direction)`` of an ``{"origin": [...], "direction": [...]}`` object, as
    SINGAPO / DIPO / CAGE, FreeArt3D and Articulate AnyMesh write a joint's axis.

    :param axis: what the file holds
    :param path: the file, for the error
    :param what: whose axis, for the error (``node 3: prismatic joint``)
    :raises InputError: naming the file when it is no such object, a value is not 3 finite numbers, or the
        direction is zero
    """
    if not isinstance(axis, dict):
        raise InputError(path, f"{what} without an axis object")
    origin = finite_vector(axis.get("origin"), path, f"{what} axis origin")
    direction = finite_vector(axis.get("direction"), path, f"{what} axis direction")
    norm = float(np.linalg.norm(direction))
    if norm < 1e-9:
        raise InputError(path, f"{what} axis direction {direction.tolist()} is zero")
    return origin, direction / norm


def finite_vector(value, path: Path, what: str) -> np.ndarray:
    """``value`` (a JSON list) as 3 finite floats.

    :param value: what the file holds
    :param path: the file, for the error
    :param what: what the value is, for the error (``joint 2: axis direction``)
    :raises InputError: naming the file when it is not 3 finite numbers (NaN: Python's json reads it)
    """
    try:
        out = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(path, f"{what} is not 3 numbers: {value!r}") from None
    if out.shape != (3,) or not np.all(np.isfinite(out)):
        raise InputError(path, f"{what} is not 3 finite numbers: {value!r}")
    return out


def rotation_z(angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` radians about Z."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def flat_rotate(points: np.ndarray, angle: float) -> np.ndarray:
    """(N, 2) points turned by ``angle`` radians."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def footprint_yaw(asset: ArticulatedAsset, rotation: np.ndarray | None = None) -> float:
    """The turn about Z (radians, in ``(-pi/4, pi/4]``) that squares the object's footprint to the axes:
    the rest-pose vertices, turned by ``rotation`` into our frame and projected on the ground plane, get
    the bounding rectangle of least area (rotating calipers on their convex hull), and the turn brings its
    sides onto X and Y.

    Datasets keep objects axis-aligned, and the benchmark frame is scaled by the box: an object turned
    by an odd angle has a larger box, hence a smaller scale after normalization, which a rigid alignment
    cannot undo. Squared, what is left of a view-dependent turn is a multiple of a quarter turn, which
    ``eval --align icp``'s grid of starts holds exactly.

    :param asset: the object
    :param rotation: 3x3 rotation into our frame first (default: none)
    """
    from scipy.spatial import ConvexHull, QhullError

    meshes = asset.link_meshes()
    if not meshes:
        return 0.0
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    points = np.concatenate([m.vertices for m in meshes.values()]) @ rotation.T
    flat = points[:, :2]
    try:
        hull = flat[ConvexHull(flat).vertices]
    except (QhullError, ValueError):  # a flat or degenerate footprint: nothing to square
        return 0.0
    best, best_area = 0.0, math.inf
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        edge = b - a
        angle = math.atan2(edge[1], edge[0])
        turned = flat_rotate(hull, -angle)
        area = float(np.prod(np.ptp(turned, axis=0)))
        quarter = -((angle + math.pi / 4) % (math.pi / 2) - math.pi / 4)  # the smallest turn squaring it
        if area < best_area * (1 - 1e-9) or (area <= best_area * (1 + 1e-9) and abs(quarter) < abs(best)):
            best, best_area = quarter, area
    return best


def to_benchmark(found: ForeignObject, name: str) -> tuple[ArticulatedAsset, dict]:
    """The object in its benchmark frame, and the record to write beside it.

    When the format leaves the turn about the up axis open (``yaw``), the footprint is squared to the axes
    first (:func:`footprint_yaw`); then the object is centred and scaled into [-1, 1]^3
    (:func:`spark_bench.data.case.to_benchmark_frame`). The record gains ``frame``: the turn and where it
    came from, the benchmark centre and scale, the 4x4 from the format's world (after the reader's
    conversion) to the benchmark frame, and what is left open.

    :param found: what the reader returned
    :param name: the object's name (the case id)
    :raises InputError: when the object has no geometry
    """
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.data.case import to_benchmark_frame

    asset = found.asset
    if not any(link.has_geometry for link in asset.links.values()):
        raise InputError(found.record.get("run"), "the object has no part with a surface")
    yaw = footprint_yaw(asset) if "yaw" in found.open_questions else 0.0
    turn = np.eye(4)
    turn[:3, :3] = rotation_z(yaw)
    turned = similarity_asset(asset, turn)
    turned.name = name
    normalized, center, scale = to_benchmark_frame(turned)
    to_bench = np.eye(4) * scale
    to_bench[3, 3] = 1.0
    to_bench[:3, 3] = -scale * np.asarray(center)
    normalized.meta = {"model_cat": normalized.category}
    record = {**found.record, "articulated": bool(found.articulated), "frame": {
        "ours": OUR_FRAME, "yaw_deg": math.degrees(yaw), "yaw_from": "footprint" if "yaw" in found.open_questions
        else "format", "benchmark_center": np.asarray(center).tolist(), "benchmark_scale": float(scale),
        "format_world_to_benchmark": (to_bench @ turn).tolist(),
        "open": {key: OPEN_QUESTIONS[key] for key in found.open_questions}}}
    return normalized, record


def write_import(asset: ArticulatedAsset, record: dict, folder: str | Path) -> Path:
    """Write ``asset`` as the object folder ``folder`` (replacing it) with ``import.json`` inside.

    Written beside as ``.<name>.partial`` and renamed, so a reader never sees half a folder.

    :param asset: the object (benchmark frame)
    :param record: what ``import.json`` records
    :param folder: the object folder to write
    """
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.jsonio import to_json_text

    folder = Path(folder)
    partial = folder.parent / f".{folder.name}.partial"
    if partial.exists():
        shutil.rmtree(partial)
    write_object_folder(asset, partial)
    (partial / IMPORT_RECORD).write_text(to_json_text(record, indent=1) + "\n")
    if folder.exists():
        shutil.rmtree(folder)
    partial.rename(folder)
    return folder


def remove_stale_import(folder: Path) -> bool:
    """Remove a previous import of a case (only a folder an importer wrote: it holds ``import.json``)."""
    if (folder / IMPORT_RECORD).is_file():
        shutil.rmtree(folder)
        return True
    return False


def read_import_record(folder: str | Path) -> dict | None:
    """``import.json`` of an imported object folder, or None when there is none (not imported).

    :raises InputError: naming the file when it is there but not a JSON object
    """
    from spark_bench.data.readers import read_json

    path = Path(folder) / IMPORT_RECORD
    data = read_json(path, default=None)
    if data is None:
        return None
    if not isinstance(data, dict):
        raise InputError(path, "import record is not a JSON object")
    return data


def row_fields(record: dict | None) -> dict:
    """What a results row carries about an imported prediction (empty when it was not imported): the
    format and the run folder read; for SPARK's runs also the URDF, its kind and the alignment mode."""
    if not record:
        return {}
    if str(record.get("format", "")).startswith("spark-bench spark import"):
        return {"spark_urdf": record.get("urdf"), "spark_urdf_kind": record.get("urdf_kind"),
                "spark_alignment": record.get("alignment"), "spark_run": record.get("run")}
    return {"import_format": record.get("format"), "import_run": record.get("run"),
            "articulated": record.get("articulated", True)}


class ImportOutcome:
    """What every import report says of its cases (``self.cases``: items with an ``imported`` flag): which
    were imported, which skipped, and the command's exit code (0 when at least one was imported, 1 when none
    could be)."""

    cases: list

    @property
    def imported(self) -> list:
        return [c for c in self.cases if c.imported]

    @property
    def skipped(self) -> list:
        return [c for c in self.cases if not c.imported]

    @property
    def exit_code(self) -> int:
        return 0 if self.imported else 1
