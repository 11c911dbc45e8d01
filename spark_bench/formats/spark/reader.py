"""One SPARK output folder -> one object folder in the benchmark frame (PartNet-Mobility layout).

What SPARK writes is described, with the files of SPARK's code it comes from, in
:mod:`spark_bench.formats.spark.layout`. The reader:

1. **takes the URDF** ``*_optimized.urdf`` when present (the joint optimizer's output,
   ``URDFoptimizer/optimize_urdf_joint_v4.py``: ``mobility_optimized.urdf`` first), else
   ``mobility_refined.urdf`` (``run_articulation.py``), else ``mobility.urdf`` (``generate_urdf.py``);
   which one was read is recorded (``urdf``, ``urdf_kind``);
2. **keeps SPARK's joints** (types, origins, axes, limits) as the URDF gives them, read by
   :func:`spark_bench.asset.urdf.load_urdf` without meshes (names are never needed to match anything:
   the metrics match parts by geometry);
3. **resolves each visual's mesh**, since ``generate_urdf.py`` points at ``part_NN.glb`` beside the URDF
   while PartCrafter writes ``inference/<TAG>/part_NN*.glb``: first where the URDF points, then in
   ``inference/<TAG>/``; in each place ``part_NN_cleaned_textured_aligned.glb``, then
   ``part_NN_cleaned.glb``, then ``part_NN.glb`` (then the file as written). A candidate that cannot be
   read or has no surface (PartCrafter's stand-in for a part it could not make is a one-vertex
   degenerate mesh) is passed over and noted. When nothing is usable: an :class:`InputError` listing
   every path looked at;
4. **maps SPARK's frame to ours**: SPARK's meshes and joint axes share one frame, Y up with the front
   towards +Z (the image frame +x right, +y up, +z towards the camera). The rotation applied to the
   URDF's world is ``SPARK_TO_PARTNET @ R_root^T``, where ``R_root`` is the rotation of the joint below
   the root link: identity for ``generate_urdf.py``'s URDFs (the full PartNet-Mobility rotation is
   applied), the PartNet-Mobility root joint itself for the fork's ``outputs/test*`` URDFs (nothing is
   applied). A turn about Z follows: with ``alignment="camera"``, the one that makes SPARK's +Z (towards
   the camera that took the input image) face the case camera; with ``alignment="icp"`` (default), the
   one that squares the object's footprint to the axes (:func:`footprint_yaw`), leaving a multiple of a
   quarter turn, and the scale, to ``eval --align icp``;
5. **normalizes** into the benchmark frame (:func:`spark_bench.data.case.to_benchmark_frame`) and writes
   the object folder (:func:`spark_bench.asset.urdf.write_object_folder`) plus ``import.json`` recording
   the run folder, the URDF read, every mesh file used (and those passed over), the frame mapping and
   the alignment mode.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError
from spark_bench.formats.foreign import OUR_FRAME, footprint_yaw, rotation_z
from spark_bench.formats.spark import layout

IMPORT_FORMAT = "spark-bench spark import 1"
ALIGNMENTS = ("icp", "camera")
SPARK_FRAME = "SPARK: Y up, front +Z (image frame: +x right, +y up, +z towards the camera)"


@dataclass
class MeshChoice:
    """The mesh file used for one URDF visual.

    :param path: the file
    :param variant: ``textured_aligned``, ``cleaned``, ``raw`` or ``as_written``
    :param looked_for: every path considered, in order
    :param passed_over: ``"path: why"`` for candidates that exist but were not usable
    """

    path: Path
    variant: str
    looked_for: list[Path]
    passed_over: list[str]


@dataclass
class SparkImport:
    """A SPARK run read into our frame.

    :param asset: the object in its benchmark frame
    :param record: what ``import.json`` records
    """

    asset: object
    record: dict


# ----- the URDF -------------------------------------------------------------------------------------------
def choose_urdf(run_dir: str | Path) -> tuple[Path, str]:
    """``(URDF path, kind)`` of a run: ``optimized``, ``refined`` or ``vlm`` (see the module docstring).

    :raises InputError: listing the names looked for when there is none
    """
    run_dir = Path(run_dir)
    optimized = sorted(run_dir.glob(f"*{layout.OPTIMIZED_SUFFIX}"))
    preferred = run_dir / (Path(layout.URDF).stem + layout.OPTIMIZED_SUFFIX)
    if preferred in optimized:
        return preferred, "optimized"
    if optimized:
        return optimized[0], "optimized"
    if (run_dir / layout.REFINED_URDF).is_file():
        return run_dir / layout.REFINED_URDF, "refined"
    if (run_dir / layout.URDF).is_file():
        return run_dir / layout.URDF, "vlm"
    raise InputError(run_dir, f"no SPARK URDF: looked for *{layout.OPTIMIZED_SUFFIX}, {layout.REFINED_URDF} "
                              f"and {layout.URDF} (the urdf stage did not run or failed)")


def _floats(text: str | None, n: int, default: float, where: Path, what: str) -> np.ndarray:
    if text is None or not text.strip():
        return np.full(n, default)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise InputError(where, f"{what} is not {n} numbers: {text!r}") from None
    if values.size == 1 and n == 3 and what.endswith("scale"):
        values = np.full(3, values[0])
    if values.size != n or not np.all(np.isfinite(values)):
        raise InputError(where, f"{what} is not {n} finite numbers: {text!r}")
    return values


def _visuals(urdf: Path) -> dict[str, list[tuple[str, np.ndarray, np.ndarray]]]:
    """link -> ``[(mesh filename, 4x4 visual origin, scale)]`` of its mesh visuals, in file order."""
    from lxml import etree

    from spark_bench.asset.transforms import origin_to_matrix
    from spark_bench.asset.urdf import read_urdf_xml

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    root = etree.fromstring(read_urdf_xml(urdf), parser=parser)
    out: dict[str, list] = {}
    for link in root.findall("link"):
        name = link.get("name")
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is None or not mesh.get("filename"):
                continue
            origin = visual.find("origin")
            xyz = _floats(None if origin is None else origin.get("xyz"), 3, 0.0, urdf, f"link {name!r} visual xyz")
            rpy = _floats(None if origin is None else origin.get("rpy"), 3, 0.0, urdf, f"link {name!r} visual rpy")
            scale = _floats(mesh.get("scale"), 3, 1.0, urdf, f"link {name!r} mesh scale")
            out.setdefault(name, []).append((mesh.get("filename"), origin_to_matrix(xyz, rpy), scale))
    return out


# ----- meshes ---------------------------------------------------------------------------------------------
def inference_dirs(run_dir: Path, tag: str | None) -> list[Path]:
    """The ``inference/<tag>/`` folders to search: the given tag's, else SPARK's default tag's, else
    every tag folder there is (sorted)."""
    base = Path(run_dir) / layout.INFERENCE_DIR
    if tag:
        return [base / tag]
    if (base / layout.DEFAULT_TAG).is_dir():
        return [base / layout.DEFAULT_TAG]
    return sorted(p for p in base.iterdir() if p.is_dir()) if base.is_dir() else []


def _strip_scheme(filename: str) -> str:
    for prefix in ("package://", "file://"):
        if filename.startswith(prefix):
            return filename[len(prefix):]
    return filename


def _usable(path: Path) -> str | None:
    """None when ``path`` is a mesh with a surface, else why not."""
    from spark_bench.asset.urdf import load_mesh_file

    try:
        mesh, _ = load_mesh_file(path)
    except InputError as exc:
        return exc.problem
    if not float(mesh.area) > 0.0:
        return "mesh has no surface (zero area)"
    return None


def resolve_mesh(run_dir: str | Path, urdf: Path, filename: str, tag: str | None = None) -> MeshChoice:
    """The mesh file for a visual that names ``filename`` (see the module docstring for the order).

    Only files inside the run folder are considered.

    :raises InputError: naming the URDF and listing every path looked at (and why any was passed over)
    """
    run_dir = Path(run_dir).resolve()
    written = Path(_strip_scheme(filename))
    where = (written if written.is_absolute() else Path(urdf).parent / written).resolve()
    stem = layout.base_stem(written.name)
    places = [where.parent] + [d.resolve() for d in inference_dirs(run_dir, tag)]
    looked, passed = [], []
    for place in dict.fromkeys(places):  # in order, without repeats
        candidates = [(variant, place / pattern.format(stem=stem)) for variant, pattern in layout.MESH_VARIANTS]
        if place == where.parent and where not in [c for _, c in candidates]:
            candidates.append(("as_written", where))
        for variant, path in candidates:
            if not path.is_relative_to(run_dir):
                continue
            looked.append(path)
            if not path.is_file():
                continue
            problem = _usable(path)
            if problem is None:
                return MeshChoice(path, variant, looked, passed)
            passed.append(f"{path}: {problem}")
    detail = f"; passed over: {'; '.join(passed)}" if passed else ""
    raise InputError(urdf, f"no usable mesh for {filename!r}: looked for {', '.join(map(str, looked))}{detail}")


# ----- frames -----------------------------------------------------------------------------------------------
def frame_rotation(asset) -> tuple[np.ndarray, str]:
    """``(3x3 rotation from the URDF's world to ours, root joint style)`` (module docstring, step 4).

    The style is ``identity`` (``generate_urdf.py``: no root rotation), ``partnet-mobility`` (the fork's
    URDFs: the PartNet-Mobility root joint) or ``other``.
    """
    root = asset.root
    root_rotation = np.eye(3)
    if not asset.links[root].has_geometry:
        below = [j for j in asset.topological_joints() if j.parent == root]
        if below:
            root_rotation = np.asarray(below[0].origin, dtype=float)[:3, :3]
    if np.allclose(root_rotation, np.eye(3), atol=1e-6):
        style = "identity"
    elif np.allclose(root_rotation, layout.SPARK_TO_PARTNET, atol=1e-5):
        style = "partnet-mobility"
    else:
        style = "other"
    return layout.SPARK_TO_PARTNET @ root_rotation.T, style


def camera_yaw(camera: dict, where: Path | None = None) -> float:
    """The turn about Z (radians) that makes SPARK's +Z (towards its camera), once in our frame (-X),
    face the case camera: the camera's azimuth minus pi.

    :param camera: ``camera.json`` (``position``, else ``camera_to_world``)
    :raises InputError: when the camera has no usable position or sits on the vertical axis
    """
    try:
        if camera.get("position") is not None:
            position = np.asarray(camera["position"], dtype=float)
        else:
            position = np.asarray(camera["camera_to_world"], dtype=float)[:3, 3]
    except (TypeError, KeyError, ValueError, IndexError):
        raise InputError(where, "camera has no position (needed for --align camera)") from None
    if position.shape != (3,) or not np.all(np.isfinite(position)) or math.hypot(*position[:2]) < 1e-9:
        raise InputError(where, f"camera position {position.tolist()} gives no direction about the up axis")
    return math.atan2(position[1], position[0]) - math.pi


# ----- the reader ---------------------------------------------------------------------------------------------
def read_spark_run(run_dir: str | Path, tag: str | None = None, alignment: str = "icp", camera: dict | None = None,
                   camera_source: Path | None = None, name: str | None = None) -> SparkImport:
    """Read one SPARK run folder into our frame (see the module docstring).

    :param run_dir: ``output/<name>_<timestamp>/``
    :param tag: the inference tag (default: SPARK's ``FT5_G1_0``, else the only tag folder)
    :param alignment: ``icp`` (leave the turn about Z to the metrics) or ``camera`` (needs ``camera``)
    :param camera: the case's ``camera.json``, for ``alignment="camera"``
    :param camera_source: where ``camera`` came from, for messages and the record
    :param name: the object's name (default: the run folder's image name)
    :raises InputError: for a bad run folder, URDF or mesh, naming the file
    """
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.asset.urdf import load_urdf
    from spark_bench.data.case import to_benchmark_frame

    run_dir = Path(run_dir).resolve()
    if alignment not in ALIGNMENTS:
        raise InputError(None, f"unknown alignment {alignment!r}; expected one of {', '.join(ALIGNMENTS)}")
    if not run_dir.is_dir():
        raise InputError(run_dir, "SPARK run folder not found")
    urdf, kind = choose_urdf(run_dir)
    asset = load_urdf(urdf, folder=run_dir, load_meshes=False)
    meshes = _attach_visuals(asset, urdf, run_dir, tag)
    metadata = layout.read_metadata(run_dir) or {}
    _label_links(asset, metadata)
    parsed = layout.parse_run_name(run_dir.name)
    asset.name = name or (parsed[0] if parsed else run_dir.name)
    asset.category = str(metadata.get("object_name", "") or "")

    rotation, root_style = frame_rotation(asset)
    if alignment == "camera":
        if camera is None:
            raise InputError(camera_source, "--align camera needs the case camera (camera.json)")
        yaw = camera_yaw(camera, camera_source)
    else:
        yaw = footprint_yaw(asset, rotation)
    rotation = rotation_z(yaw) @ rotation
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    ours = similarity_asset(asset, matrix)
    normalized, center, scale = to_benchmark_frame(ours)
    to_benchmark = np.eye(4) * scale
    to_benchmark[3, 3] = 1.0
    to_benchmark[:3, 3] = -scale * np.asarray(center)
    to_benchmark = to_benchmark @ matrix
    normalized.meta = {"model_cat": normalized.category}
    tag_used = tag or next((d.name for d in inference_dirs(run_dir, None)), layout.DEFAULT_TAG)
    record = {
        "format": IMPORT_FORMAT,
        "run": str(run_dir),
        "run_timestamp": parsed[1] if parsed else None,
        "urdf": str(urdf.relative_to(run_dir)),
        "urdf_kind": kind,
        "inference_tag": tag_used,
        "meshes": meshes,
        "frame": {"spark": SPARK_FRAME, "ours": OUR_FRAME, "root_joint": root_style,
                  "rotation": rotation.tolist(), "yaw_deg": math.degrees(yaw),
                  "yaw_from": "camera" if alignment == "camera" else "footprint",
                  "benchmark_center": np.asarray(center).tolist(), "benchmark_scale": float(scale),
                  "urdf_world_to_benchmark": to_benchmark.tolist()},
        "alignment": alignment,
        "alignment_note": ("footprint squared to the axes; the quarter turn left and the scale go to "
                           "`eval --align icp`" if alignment == "icp"
                           else "turned about Z so that SPARK's +Z faces the case camera"),
        "camera": str(camera_source) if camera_source else None,
        "stages": layout.diagnose(run_dir, tag_used).to_dict(),
        "ignored": ["<collision> elements (the metrics use visuals)"],
    }
    driver = run_dir / layout.DRIVER_RECORD
    if driver.is_file():
        record["driver"] = _driver_record(driver)
    return SparkImport(normalized, record)


def _attach_visuals(asset, urdf: Path, run_dir: Path, tag: str | None) -> list[dict]:
    """Load the meshes the URDF's visuals name (the variant :func:`resolve_mesh` chooses) onto ``asset``'s
    links; what was read, one record per visual.

    :raises InputError: a mesh that does not load, or no link with a mesh visual
    """
    from spark_bench.asset.model import Visual
    from spark_bench.asset.urdf import load_mesh_file

    meshes = []
    for link_name, visuals in _visuals(urdf).items():
        link = asset.links[link_name]
        for filename, origin, scale in visuals:
            choice = resolve_mesh(run_dir, urdf, filename, tag)
            mesh, rgba = load_mesh_file(choice.path)
            mesh.vertices = mesh.vertices * scale
            mesh.apply_transform(origin)
            source = str(choice.path.relative_to(run_dir))
            link.visuals.append(Visual(mesh=mesh, rgba=rgba or (0.7, 0.7, 0.7, 1.0), source=source))
            meshes.append({"link": link_name, "urdf_filename": filename, "file": source, "variant": choice.variant,
                           "passed_over": choice.passed_over})
    if not any(link.has_geometry for link in asset.links.values()):
        raise InputError(urdf, "no link has a mesh visual")
    return meshes


def _label_links(asset, metadata: dict) -> None:
    """Give the links the part names of the run's metadata (``parts``: ``label`` the link, ``name`` its
    label), where there is one."""
    names = {}
    for i, part in enumerate(metadata.get("parts") or []):
        if isinstance(part, dict):
            names[str(part.get("label", f"link{i}"))] = str(part.get("name", "") or "")
    for link_name, label in names.items():
        if link_name in asset.links and label:
            asset.links[link_name].label = label


def _driver_record(driver: Path) -> dict | None:
    """What the driver wrote of the run (its JSON), or None where it does not read."""
    try:
        return json.loads(driver.read_text())
    except (OSError, ValueError):
        return None
