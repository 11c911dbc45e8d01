"""Part geometry backends of the SPARK pipeline (stage 2): one rest-pose mesh per part, benchmark frame.

- ``annotation``: the case's ground-truth part meshes at rest (offline default; shape metrics of rows
  made with it measure nothing, the leaderboard shows them as n/a).
- ``predictions``: an object folder per case, ``<dir>/<case id>/`` (any format
  :func:`spark_bench.data.load_object` reads), e.g. SPARK runs imported by ``spark-bench import spark``.
- ``spark``: SPARK run per case by an external command (e.g. ``spark-bench run-spark --image {image}
  --output {out}``, which runs SPARK's own stage scripts); the command leaves a SPARK run folder in
  ``{out}`` as SPARK writes it, read by :func:`spark_bench.formats.spark.reader.read_spark_run` (SPARK's
  names, its meshes under ``inference/<tag>/``, its frame, its own joints).
- ``retrieval``: the part meshes of the gallery object retrieved from the input image and camera
  (:mod:`spark_bench.methods.ours.retrieved`; one retrieval per case also serves a ``retrieval`` prior).

Every backend returns :class:`PartGeometry`: meshes by part name, in the benchmark frame, at rest.
Predicted objects are first normalized to the benchmark frame (rest-pose box centered, fit to [-1, 1]).
A part is a maximal group of links that move together: a movable joint's child and every link hanging
from it by fixed joints (:func:`group_parts`); the root part is everything that never moves. A
prediction's parts keep their own names and the object they came from (:attr:`PartGeometry.asset`,
with its own joints); :func:`spark_bench.methods.ours.assemble.pair_parts` pairs them with the prior's links
by geometry or structure, never by name.
"""

from __future__ import annotations

import shlex
import shutil
import string
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from spark_bench.asset.mesh import merge_meshes
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.methods.predictions import prediction_folder
from spark_bench.methods.process import ProgramError, ProgramResult, run_program

if TYPE_CHECKING:
    from spark_bench.methods.base import CaseInput


@dataclass
class Part:
    """A group of links that move together.

    :param name: the part's name (its first link's name)
    :param links: the links in it
    :param joint: the movable joint that moves it (None for the root part)
    :param label: semantic label of its first labelled link
    """

    name: str
    links: list[str]
    joint: str | None
    label: str = ""


@dataclass
class PartGeometry:
    """Rest-pose meshes of an object's parts in the benchmark frame.

    :param meshes: part name -> mesh (world frame, rest pose); parts without geometry are absent
    :param labels: part name -> semantic label
    :param source: the backend name and where the meshes came from, for the report
    :param members: part name -> the source object's links merged into it (where known)
    :param root: the name of the part that never moves (where known)
    :param asset: the predicted object the parts come from (benchmark frame, its own link names and
        joints: SPARK's for the ``spark`` backend); None for the ground truth's own parts
    :param parts: the parts of ``asset`` (:func:`group_parts`), root first
    :param offered_to_prior: whether the pipeline hands these part names to the prior backend before it
        answers (``annotation``, ``predictions``: a ``vlm`` or ``file`` prior then names them itself);
        False for ``spark``, which runs after the prior and names its parts its own way
    :param record: what the backend read, for the report (the ``spark`` backend: SPARK's import record)
    """

    meshes: dict[str, trimesh.Trimesh]
    labels: dict[str, str] = field(default_factory=dict)
    source: str = ""
    members: dict[str, list[str]] = field(default_factory=dict)
    root: str = ""
    asset: ArticulatedAsset | None = None
    parts: list[Part] = field(default_factory=list)
    offered_to_prior: bool = True
    record: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return list(self.labels) or list(self.meshes)


def group_parts(asset: ArticulatedAsset) -> list[Part]:
    """The asset's parts: the root part first, then one per movable joint in file order."""
    root_links = [asset.root]
    stack = [asset.root]
    while stack:
        link = stack.pop()
        for joint in asset.joints.values():
            if joint.parent == link and not joint.is_movable:
                root_links.append(joint.child)
                stack.append(joint.child)
    with_geometry = [n for n in root_links if asset.links[n].has_geometry]
    root_name = with_geometry[0] if with_geometry else root_links[-1]
    parts = [Part(root_name, root_links, None, _label(asset, root_links) or "body")]
    for joint in asset.movable_joints():
        links = asset.part_of_joint(joint.name)
        parts.append(Part(joint.child, links, joint.name, _label(asset, links)))
    return parts


def _label(asset: ArticulatedAsset, links: list[str]) -> str:
    return next((asset.links[n].label for n in links if asset.links[n].label), "")


def part_meshes(asset: ArticulatedAsset, parts: list[Part] | None = None) -> PartGeometry:
    """Each part's merged world-frame mesh at the asset's rest configuration."""
    parts = parts or group_parts(asset)
    world = asset.link_meshes()
    meshes, labels = {}, {}
    for part in parts:
        pieces = [world[n] for n in part.links if n in world]
        labels[part.name] = part.label
        if pieces:
            meshes[part.name] = merge_meshes(pieces)
    return PartGeometry(meshes, labels, members={p.name: list(p.links) for p in parts}, root=parts[0].name,
                        parts=list(parts))


def annotation_geometry(gt: ArticulatedAsset) -> PartGeometry:
    """The ground truth's part meshes at rest (the ``annotation`` backend)."""
    out = part_meshes(gt)
    out.source = "annotation"
    return out


def load_predicted_object(folder: Path) -> PartGeometry:
    """A predicted object folder's part meshes, normalized to the benchmark frame."""
    from spark_bench.data import load_object

    return _normalized_parts(load_object(folder), folder)


def _normalized_parts(asset: ArticulatedAsset, source) -> PartGeometry:
    from spark_bench.asset.ops import normalize_asset

    asset, _, _ = normalize_asset(asset)
    return predicted_parts(asset, source)


def predicted_parts(asset: ArticulatedAsset, source, offered_to_prior: bool = True) -> PartGeometry:
    """A predicted object's part meshes, keeping the object (its names and joints) beside them.

    :param asset: the object, already in the benchmark frame
    :param source: where it came from, for the report
    :param offered_to_prior: see :class:`PartGeometry`
    """
    out = part_meshes(asset)
    out.source = str(source)
    out.asset = asset
    out.offered_to_prior = offered_to_prior
    return out


def predictions_geometry(predictions_dir: str | Path, case_id: str) -> PartGeometry:
    """The ``predictions`` backend: ``<predictions_dir>/<case_id>/`` is an object folder
    (:func:`spark_bench.methods.predictions.prediction_folder`, which refuses unsafe case ids)."""
    return load_predicted_object(prediction_folder(predictions_dir, case_id))


#: The placeholders of a ``spark`` command template.
COMMAND_FIELDS = ("image", "prior", "out", "case_id", "case")


def command_fields(command: str) -> set[str]:
    """The placeholder names of a ``spark`` command template (``{image}`` -> ``image``).

    :raises InputError: when the template does not split like a shell command line
    """
    try:
        return {name.split(".")[0].split("[")[0] for arg in shlex.split(command)
                for _, name, _, _ in string.Formatter().parse(arg) if name is not None}
    except ValueError as exc:
        raise InputError(None, _bad_template(command, exc)) from None


def _bad_template(command: str, exc: Exception) -> str:
    return (f"geometry.spark_command {command!r} is not a valid template (placeholders: "
            f"{' '.join('{' + f + '}' for f in COMMAND_FIELDS)}; double literal braces): {exc!r}")


def spark_command_argv(command: str, case: CaseInput, prior_json: Path, out: Path) -> list[str]:
    """The argument list of a ``spark`` command template (see :func:`spark_geometry`), without a shell.

    :param case: the case; ``{case}`` (its whole folder) needs the ``gt`` input, since the folder holds
        the ground truth
    :raises InputError: when the template does not split or names an unknown placeholder
    """
    fields = command_fields(command)
    values = {"prior": Path(prior_json).resolve(), "out": Path(out).resolve(), "case_id": case.case_id}
    if "image" in fields:
        values["image"] = Path(case.image).resolve()
    if "case" in fields:
        values["case"] = Path(case.folder).resolve()
    try:
        argv = [arg.format(**values) for arg in shlex.split(command)]
    except (ValueError, KeyError, IndexError) as exc:
        raise InputError(None, _bad_template(command, exc)) from None
    if not argv:
        raise InputError(None, "geometry.spark_command is empty")
    return argv


def run_spark_command(argv: list[str], timeout_s: float) -> ProgramResult:
    """Run ``argv`` with :func:`spark_bench.methods.process.run_program` (its own process group, killed
    whole on timeout: SPARK's pipeline starts child processes).

    :raises InputError: when it cannot start, times out, or exits non-zero (with its output's tail)
    """
    try:
        done = run_program(argv, timeout_s)
    except ProgramError as exc:
        raise InputError(exc.program, f"SPARK geometry command {exc.problem}") from None
    if done.returncode != 0:
        tail = " | ".join(done.last_lines(3)) or "no output"
        raise InputError(argv[0], f"SPARK geometry command exited {done.returncode}: {tail}")
    return done


def find_spark_run(out: Path) -> Path:
    """The SPARK run folder a command left in ``out``: ``out`` itself when it holds a run's files
    (a URDF or ``metadata.json``), else the newest ``<name>_<YYYYmmdd_HHMMSS>/`` folder in it (the
    folder ``run.py`` and ``spark-bench run-spark`` make).

    :raises InputError: naming ``out`` when it holds neither
    """
    from spark_bench.formats.spark import layout

    out = Path(out)
    if any(out.glob("*.urdf")) or (out / layout.METADATA).is_file():
        return out
    runs = []
    for entry in sorted(out.iterdir()) if out.is_dir() else []:
        parsed = layout.parse_run_name(entry.name) if entry.is_dir() else None
        if parsed is not None:
            runs.append((parsed[1], entry.name, entry))
    if not runs:
        raise InputError(out, "the SPARK geometry command left no SPARK run (expected a URDF or metadata.json "
                              "there, or <name>_<YYYYmmdd_HHMMSS>/ run folders)")
    return max(runs)[2]


def read_spark_geometry(run: Path, case: CaseInput, import_dir: Path | None = None) -> PartGeometry:
    """One SPARK run folder as part geometry in the case's benchmark frame, with SPARK's own object.

    Read by :func:`spark_bench.formats.spark.reader.read_spark_run`: SPARK's URDF (``*_optimized.urdf``
    first), its meshes where SPARK leaves them, its joints, its frame mapped to ours. The turn about the
    up axis that SPARK's view-dependent frame leaves is resolved with the case camera (``alignment =
    camera``) when the method declared the ``camera`` input, as ``ours`` does whenever it optimizes
    joints against the case's images; otherwise it is left (``icp``) and recorded.

    :param run: the run folder
    :param case: the case (its camera is read only when declared)
    :param import_dir: where to write SPARK's own object (its joints) with its ``import.json``
    :raises InputError: naming the file, with the first SPARK stage whose output is missing (SPARK
        exits 0 when a stage fails)
    """
    from spark_bench.formats.foreign import write_import
    from spark_bench.formats.spark import layout
    from spark_bench.formats.spark.reader import read_spark_run

    camera_declared = "camera" in case.allowed
    camera_path = case.path("camera") if camera_declared else None
    try:
        result = read_spark_run(run, alignment="camera" if camera_declared else "icp",
                                camera=case.camera if camera_declared else None, camera_source=camera_path,
                                name=case.case_id)
    except InputError as exc:
        failed = layout.diagnose(run).failed_stage
        where = f"; first SPARK stage without its output: {failed}" if failed else ""
        raise InputError(exc.path, exc.problem + where) from None
    result.record["case_id"] = case.case_id
    if import_dir is not None:
        write_import(result.asset, result.record, import_dir)
    out = predicted_parts(result.asset, run, offered_to_prior=False)
    out.record = result.record
    return out


def spark_geometry(command: str, case: CaseInput, prior_json: Path, work_dir: Path,
                   timeout_s: float = 3600.0) -> PartGeometry:
    """The ``spark`` backend: run SPARK on the case by an external command and read what it left.

    ``command`` is a template with ``{image}`` (the case's input image), ``{out}`` (an empty folder where
    SPARK's run must end up), ``{case_id}``, ``{prior}`` (the coarse URDF JSON of stage 1, for a command
    that wants it; SPARK's own code makes its own) and ``{case}`` (the case folder: it holds the ground
    truth, so ``ours`` then declares the ``gt`` input and says so in its regime), paths absolute. It runs
    without a shell, e.g. ``spark-bench run-spark --spark /opt/SPARK --image {image} --name {case_id}
    --output {out} --python /opt/conda/envs/spark/bin/python --skip texture``, which runs SPARK's stage
    scripts with their real flags in SPARK's folder. The run folder it leaves (:func:`find_spark_run`) is
    read as SPARK writes it (:func:`read_spark_geometry`); SPARK's own object, joints included, is kept
    in ``<work_dir>/spark_import/`` and as :attr:`PartGeometry.asset`. Nothing requires SPARK's part
    names to be the prior's: :func:`spark_bench.methods.ours.assemble.pair_parts` pairs them. The case camera
    is required: without it SPARK's parts would stay turned by the view while the prior's joints are not.

    :param case: the case (:class:`~spark_bench.methods.base.CaseInput`)
    :param work_dir: ``{out}`` is ``<work_dir>/spark_geometry``, emptied first
    :param timeout_s: time limit; the command's whole process group is killed after it
    :raises InputError: one line naming the command or the file, on any failure (also when the case
        camera is not an input of the method)
    """
    if "camera" not in case.allowed:  # before SPARK runs for an hour
        raise InputError(case.case.camera_path, "the spark geometry backend needs the case camera (input "
                                                "'camera') to bring SPARK's view-turned parts into the "
                                                "prior's frame")
    out = Path(work_dir) / "spark_geometry"
    if out.exists():  # a stale run from an earlier call must not pass for this one's
        shutil.rmtree(out)
    out.mkdir(parents=True)
    run_spark_command(spark_command_argv(command, case, prior_json, out), timeout_s)
    return read_spark_geometry(find_spark_run(out), case, Path(work_dir) / "spark_import")


def decimate(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """A mesh with at most about ``max_faces`` faces, for silhouette rendering.

    Uses quadric decimation when ``fast_simplification`` is installed, otherwise vertex clustering on a
    grid whose cell shrinks until the face budget is met (silhouettes tolerate it: a cell of 1/64 of the
    part's extent is below a pixel at the optimization resolutions).
    """
    if len(mesh.faces) <= max_faces:
        return mesh
    try:
        return mesh.simplify_quadric_decimation(face_count=max_faces)
    except (ImportError, ModuleNotFoundError, ValueError, TypeError):
        pass
    extent = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
    best = mesh
    for cells in (128, 96, 64, 48, 32, 24, 16, 12, 8, 6, 4):
        clustered = cluster_vertices(mesh, extent / cells)
        best = clustered
        if len(clustered.faces) <= max_faces:
            break
    return best


def cluster_vertices(mesh: trimesh.Trimesh, cell: float) -> trimesh.Trimesh:
    """Vertex clustering: snap vertices to a grid of ``cell``, merge, drop collapsed and duplicate faces."""
    keys = np.floor((mesh.vertices - mesh.vertices.min(0)) / cell).astype(np.int64)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    sums = np.zeros((len(unique), 3))
    np.add.at(sums, inverse, mesh.vertices)
    vertices = sums / np.bincount(inverse, minlength=len(unique))[:, None]
    faces = inverse[mesh.faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    faces = np.unique(np.sort(faces[keep], axis=1), axis=0, return_index=True)[1]
    faces = inverse[mesh.faces][keep][np.sort(faces)]
    return trimesh.Trimesh(vertices, faces, process=False)
