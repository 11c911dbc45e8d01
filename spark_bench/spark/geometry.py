"""Part geometry backends of the SPARK pipeline (stage 2): one rest-pose mesh per part, benchmark frame.

- ``annotation``: the case's ground-truth part meshes at rest (offline default; shape metrics of rows
  made with it measure nothing, the leaderboard shows them as n/a).
- ``predictions``: an object folder per case, ``<dir>/<case id>/`` (any format
  :func:`spark_bench.data.load_object` reads), e.g. SPARK's generated assets copied from elsewhere.
- ``spark``: SPARK's public pipeline run as an external command per case; it must write
  ``mobility.urdf`` with one GLB per link into the folder it is given.

Every backend returns :class:`PartGeometry`: meshes by part name, in the benchmark frame, at rest.
Predicted objects are first normalized to the benchmark frame (rest-pose box centered, fit to [-1, 1]).
A part is a maximal group of links that move together: a movable joint's child and every link hanging
from it by fixed joints (:func:`group_parts`); the root part is everything that never moves.
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
    """

    meshes: dict[str, trimesh.Trimesh]
    labels: dict[str, str] = field(default_factory=dict)
    source: str = ""
    members: dict[str, list[str]] = field(default_factory=dict)
    root: str = ""

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
    return PartGeometry(meshes, labels, members={p.name: list(p.links) for p in parts}, root=parts[0].name)


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
    out = part_meshes(asset)
    out.source = str(source)
    return out


def predictions_geometry(predictions_dir: str | Path, case_id: str) -> PartGeometry:
    """The ``predictions`` backend: ``<predictions_dir>/<case_id>/`` is an object folder
    (:func:`spark_bench.methods.predictions.prediction_folder`, which refuses unsafe case ids)."""
    return load_predicted_object(prediction_folder(predictions_dir, case_id))


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
    return (f"geometry.spark_command {command!r} is not a valid template (placeholders: {{image}} {{prior}} "
            f"{{out}} {{case}}; double literal braces): {exc!r}")


def spark_command_argv(command: str, case: CaseInput, prior_json: Path, out: Path) -> list[str]:
    """The argument list of a ``spark`` command template (see :func:`spark_geometry`), without a shell.

    :param case: the case; ``{case}`` (its whole folder) needs the ``gt`` input, since the folder holds
        the ground truth
    :raises InputError: when the template does not split or names an unknown placeholder
    """
    fields = command_fields(command)
    values = {"prior": Path(prior_json).resolve(), "out": Path(out).resolve()}
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


def read_spark_output(out: Path) -> ArticulatedAsset:
    """SPARK's output folder: ``mobility.urdf`` whose links each show one mesh file (GLB).

    GLB scenes are flattened with their node transforms (:func:`spark_bench.asset.urdf.load_mesh_file`).

    :raises InputError: naming the file when the URDF is missing or broken, a mesh file is missing or
        unreadable, or a mesh file holds no triangles
    """
    from spark_bench.data import load_object

    urdf = Path(out) / "mobility.urdf"
    if not urdf.is_file():
        raise InputError(urdf, "the SPARK geometry command wrote no mobility.urdf")
    asset = load_object(out)
    for link in asset.links.values():
        for visual in link.visuals:
            if visual.source and len(visual.mesh.faces) == 0:
                raise InputError(Path(out) / visual.source, f"mesh of link {link.name!r} holds no triangles")
    if not any(link.has_geometry for link in asset.links.values()):
        raise InputError(urdf, "no link has a mesh")
    return asset


def spark_geometry(command: str, case: CaseInput, prior_json: Path, work_dir: Path,
                   timeout_s: float = 3600.0) -> PartGeometry:
    """The ``spark`` backend: run SPARK's public pipeline as an external command.

    ``command`` is a template with ``{image}`` (the case's input image), ``{prior}`` (the coarse URDF
    JSON of stage 1), ``{out}`` (an empty folder where it must write ``mobility.urdf`` with one GLB per
    link) and ``{case}`` (the case folder: it holds the ground truth, so ``ours`` then declares the
    ``gt`` input and says so in its regime), all absolute paths, e.g.
    ``python /opt/SPARK/infer.py --image {image} --urdf_prior {prior} --output {out}``. It runs without
    a shell. Its links must be named as the prior's (the root part may have another name: it becomes
    the prior's root), its meshes may be at any scale and position: they are normalized to the
    benchmark frame like any predicted object.

    :param case: the case (:class:`~spark_bench.methods.base.CaseInput`)
    :param work_dir: ``{out}`` is ``<work_dir>/spark_geometry``, emptied first
    :param timeout_s: time limit; the command's whole process group is killed after it
    :raises InputError: one line naming the command or the file, on any failure
    """
    out = Path(work_dir) / "spark_geometry"
    if out.exists():  # a stale mobility.urdf from an earlier run must not pass for this one's
        shutil.rmtree(out)
    out.mkdir(parents=True)
    run_spark_command(spark_command_argv(command, case, prior_json, out), timeout_s)
    return _normalized_parts(read_spark_output(out), out)


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
