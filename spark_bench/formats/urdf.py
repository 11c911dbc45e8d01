"""Any method's URDF: one articulated object as a URDF (any file name) and the meshes it names, read with
the project's URDF reader (:func:`spark_bench.asset.urdf.load_urdf`) after resolving every mesh path
inside the run folder.

Read from each method's public code; the facts, each with where it comes from:

**URDFormer** (``WEIRDLabUW/urdformer``). ``demo.py`` ``object_prediction`` -> ``utils.py``
``visualization_parts`` -> ``write_urdfs`` writes ``output/<image stem>.urdf`` (kitchens:
``output/<image stem>_<k>.urdf``): robot ``my_urdf``, a ``base_link`` whose mesh is always
``../meshes/cabinet.obj`` (whatever base it predicted), one link per part ``<template><i>`` with
``../meshes/parts/<template>.obj`` (``drawer``, ``doorL``, ``doorR``, ``handle``, ``knob``...) and a
``<mesh scale>`` (the predicted box), visuals at the link origin, inertials, and joints with
``<limit>`` in radians (doors ``[-1.57, 0]`` or ``[0, 1.57]``) and metres (drawers ``[0, 0.4]``).
The meshes are the repository's templates, one folder up from ``output/``: a URDFormer run folder is
``output/<name>.urdf`` and the ``meshes/`` it names. Frame: Z up (``demo.py`` ``evaluate``: gravity
``-Z``; doors turn about ``+Z``), front ``+X`` (drawers slide along ``+X``; the templates' front faces
are at ``x = 0``, their depth along ``-X``); no root rotation. ``rpy`` holds scipy rotation vectors
(``Rot.as_rotvec``), equal to rpy for its single-axis turns.

**Articulate-Anything** (``vlongle/articulate-anything``). ``api/odio_urdf.py``
``compile_python_to_urdf`` runs the generated program and writes ``mobility.urdf`` beside it
(``<out_dir>/<stage>/iter_<i>/seed_<s>/``). Image, video and PartNet inputs reuse a PartNet-Mobility
object's links (``preprocess/preprocess_utils.py`` ``mask_urdf``, ``full_mesh_path=True``): each mesh
path is the **absolute** path of ``textured_objs/<part>.obj`` in the dataset folder of the machine
that ran it. ``Robot.align_robot_orientation`` copies the dataset URDF's root joint, which
``preprocess/preprocess_partnet.py`` ``rotate_urdf`` has turned by 180 degrees about Y: ``rpy="1.5708
0 1.5708"`` (README "Rotate meshes"): Z up, front ``+X``. Text inputs name ``<link>.obj`` (relative),
written into the stage's folder by ``mesh_retrieval/partnet_mesh_retrieval.py``
``add_mesh_to_out_folder``, or a ``<box>`` (``make_links_from_json``). Limits from
``make_revolute_joint(lower_angle_deg, upper_angle_deg)`` are written in radians (``np.radians``).

**PhysX-Anything** (``ziangcao0312/PhysX-Anything``). ``4_simready_gen.py`` writes
``<basepath>/<name>/basic.urdf``: links ``l_world`` (empty), ``l_<i>`` with ``./objs/<i>/<i>.obj``
(``3_split.py``; a part without a file gets no visual), ``abstract_*`` links (inertial only), fixed
joints, ``prismatic`` (group type B: limits ``range / 32``, the voxel cube), ``revolute`` (C: origin at
the pivot ``position / 32 - 0.5``, the child moved back by a fixed joint, limits ``range / 180 * pi``:
radians), three revolute hinges for a ball (D), prismatic + revolute (CB), and ``floating`` for a
free part (A). Every link has an ``<inertial>``. Frame: ``3_split.py`` turns TRELLIS's ``sample.glb``
(Y up) by +90 degrees about X, back to TRELLIS's voxel frame: Z up, the object in the unit cube.

**FreeArt3D** (``PeterZs/FreeArt3D``). ``pipelines/urdf.py`` ``write_urdf`` writes ``output.urdf``
from ``sds_output/joint_info.json`` and the part GLBs, but not as a URDF reader reads it: the part
meshes are in the object's frame (not the link's), the limits are ``lower = s, upper = 0`` (an upper
limit below the lower one when ``s > 0``) and a prismatic axis loses its sign (``abs``); its own
``parse_urdf_and_save`` reads it that way. A URDF naming ``sds_output/part_meshes/`` is therefore read
through ``sds_output/joint_info.json`` by :mod:`spark_bench.formats.freeart3d` (``read_through``), and
is an :class:`InputError` without it.

**What the reader does.**

- *Which URDF*: the run folder's ``*.urdf`` nearest its top (URDFormer's are in ``output/``, a ROS
  package's in ``<pkg>/urdf/``); among several, the methods' names first (:data:`KNOWN_URDFS`), else
  the first by name; the one read and the others are recorded. ``temp_robot.urdf`` (Articulate-Anything's
  PyBullet scratch file) is never chosen.
- *Mesh paths* (:func:`resolve_mesh`): relative to the URDF's folder; ``file://`` stripped;
  ``package://<pkg>/<rest>``: ``<rest>`` under the URDF's folder or a folder above it named ``<pkg>``,
  then ``<URDF folder>/<pkg>/<rest>``, ``<run>/<pkg>/<rest>``, ``<run>/<rest>``, ``<URDF folder>/<rest>``
  (ROS finds packages on its own path; the run folder is the only place here); an absolute path outside
  the run folder (Articulate-Anything's) by its longest tail found under the URDF's folder, then the
  run folder (copy the object's ``textured_objs/`` beside the URDF). A path that leads out of the run
  folder is an :class:`InputError`. OBJ, GLB, PLY, STL and DAE (DAE needs ``pycollada``) are read by trimesh.
- *Frame*: a URDF's world is Z up (REP 103; every method above), so nothing is turned: a
  PartNet-Mobility root joint, Articulate-Anything's turned one or none all give Z up. Which front
  (``-X`` for PartNet-Mobility, ``+X`` for URDFormer and Articulate-Anything, TRELLIS's for
  PhysX-Anything) and the size (metres, templates or a unit cube) stay open: ``yaw``, ``front``,
  ``scale``. The root joint's style is recorded. (SPARK's ``mobility.urdf`` is Y up with meshes
  elsewhere: its run folders have their own importer, ``import spark``.)
- *Joints*: as written, with the project's URDF conventions (docs/conventions.md "Joint types").
  ``floating`` and ``planar`` (PhysX-Anything's free part) become ``fixed`` and are listed. A revolute
  limit beyond 2 pi is an :class:`InputError` (degrees where URDF says radians). The meshes of every
  method above are written at joint value 0 (URDFormer's templates closed; PhysX-Anything's and
  Articulate-Anything's parts as reconstructed or reused), and the benchmark's rest is the lower
  limit: a joint whose range ends at 0 (``[l, 0]``, ``l < 0``: URDFormer's ``doorL`` and ``doorD``,
  ``[-1.57, 0]``) is read with the negated axis and the range ``[0, -l]``, the same motion with its
  rest as written, and listed.
- *Not read*: ``<collision>`` (the metrics use visuals) and ``<inertial>`` (may be missing).
"""

from __future__ import annotations

import importlib.util
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path, PurePath

import numpy as np
from lxml import etree

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.transforms import rpy_to_matrix
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject

FORMAT = "urdf"
#: What a refused path outside the run folder says: an import reads its run folder only; a URDF the user names
#: directly is read as it lies (:mod:`spark_bench.asset.mesh_paths`).
OUTSIDE_HINT = ("(an import reads its run folder only: copy what the run names into it, or name the URDF file "
                "itself: `spark-bench check|convert|metrics FILE.urdf` resolves ../ and package:// as ROS does, "
                "with --package-path DIR)")
URDFORMER = "WEIRDLabUW/urdformer"
ARTICULATE_ANYTHING = "vlongle/articulate-anything"
PHYSX_ANYTHING = "ziangcao0312/PhysX-Anything"
FREEART3D = "PeterZs/FreeArt3D"

#: URDF names the methods write, preferred in this order when a run holds several.
KNOWN_URDFS = {
    "basic.urdf": f"{PHYSX_ANYTHING} 4_simready_gen.py",
    "mobility.urdf": f"{ARTICULATE_ANYTHING} api/odio_urdf.py compile_python_to_urdf (and PartNet-Mobility)",
    "output.urdf": f"{FREEART3D} pipelines/urdf.py write_urdf",
}
#: Never the result: Articulate-Anything's ``pybullet_session`` scratch copy (removed when it ends).
SCRATCH_URDFS = ("temp_robot.urdf",)
#: Joint types with no counterpart in ours, read as ``fixed``.
FREE_TYPES = ("floating", "planar")
REVOLUTE_LIMIT_MAX = 2.0 * math.pi + 1e-6
ROOT_STYLES = {
    "partnet-mobility": rpy_to_matrix([math.pi / 2, 0.0, -math.pi / 2]),
    "articulate-anything": rpy_to_matrix([math.pi / 2, 0.0, math.pi / 2]),
}
FREEART3D_MESHES = "sds_output/part_meshes/"

FACTS = {
    "frame": {
        "fact": "the URDF's world is Z up (URDF convention, REP 103): nothing turned; front and size left "
                "open (yaw, front, scale)",
        "source": f"{URDFORMER} demo.py evaluate (gravity -Z), utils.py write_urdfs (doors about +Z, "
                  f"drawers along +X); {PHYSX_ANYTHING} 3_split.py (sample.glb turned +90 deg about X: "
                  f"TRELLIS's Z-up unit cube); {ARTICULATE_ANYTHING} README 'Rotate meshes'"},
    "units": {
        "fact": "revolute limits in radians (URDF); lengths as written (metres, templates or a unit cube)",
        "source": f"{URDFORMER} utils.py write_urdfs (1.57); {PHYSX_ANYTHING} 4_simready_gen.py "
                  "(range / 180 * pi, range / 32)"},
    "visuals": {
        "fact": "visual meshes in their link's frame with <mesh scale> and the visual origin applied; "
                "<collision> and <inertial> not read",
        "source": f"URDF specification; {URDFORMER} utils.py write_urdfs (scale = the predicted box)"},
    "package": {
        "fact": "package://<pkg>/<rest> resolved inside the run folder: under a folder named <pkg> (the "
                "URDF's or one above it), then <URDF folder>/<pkg>/, <run>/<pkg>/, <run>/, the URDF's folder",
        "source": "ROS package:// convention (no package path here: the run folder is the only place)"},
    "absolute": {
        "fact": "absolute mesh paths outside the run folder re-rooted by their longest tail found under the "
                "URDF's folder, then the run folder",
        "source": f"{ARTICULATE_ANYTHING} preprocess/preprocess_utils.py mask_urdf (full_mesh_path=True: "
                  "absolute paths into the PartNet-Mobility dataset)"},
    "ends-at-zero": {
        "fact": "a joint whose range ends at 0 ([l, 0], l < 0) read with the negated axis and range [0, -l]: "
                "the same motion, rest (the lower limit) = the meshes as written (joint value 0)",
        "source": f"{URDFORMER} utils.py write_urdfs (doorL, doorD: lower -1.57, upper 0; templates closed)"},
    "free": {
        "fact": "floating / planar joints read as fixed (no such joint type in the benchmark)",
        "source": f"{PHYSX_ANYTHING} 4_simready_gen.py (group type A: a floating joint)"},
    "root-partnet-mobility": {
        "fact": "PartNet-Mobility root joint rpy (pi/2, 0, -pi/2): Y-up meshes, world Z up, front -X (ours)",
        "source": "PartNet-Mobility mobility.urdf; docs/conventions.md 'Object folders'"},
    "root-articulate-anything": {
        "fact": "root joint rpy (pi/2, 0, pi/2): PartNet-Mobility's turned 180 deg about the mesh Y; world Z "
                "up, front +X (a half turn from ours, left to yaw)",
        "source": f"{ARTICULATE_ANYTHING} preprocess/preprocess_partnet.py rotate_urdf; api/odio_urdf.py "
                  "Robot.align_robot_orientation; README"},
    "freeart3d": {
        "fact": "FreeArt3D's output.urdf (meshes in the object frame, limits lower = s, upper = 0, |axis| "
                "for prismatic joints) read through sds_output/joint_info.json",
        "source": f"{FREEART3D} pipelines/urdf.py write_urdf, parse_urdf_and_save"},
}


@dataclass
class MeshPath:
    """Where one ``<mesh filename>`` leads.

    :param written: the filename as the URDF writes it
    :param path: the file (inside the run folder; may not exist: the URDF reader then says so)
    :param rule: how it was found: ``relative``, ``package``, ``absolute`` (inside the run folder) or
        ``absolute-tail`` (re-rooted)
    """

    written: str
    path: Path
    rule: str


@dataclass
class PreparedUrdf:
    """A URDF's XML with every visual mesh path resolved (absolute), collisions dropped.

    :param xml: the rewritten URDF
    :param meshes: ``(link, MeshPath)`` per visual mesh, in file order
    :param free_joints: names of the ``floating`` / ``planar`` joints made ``fixed``
    :param collisions: how many ``<collision>`` elements were dropped
    """

    xml: bytes
    meshes: list[tuple[str, MeshPath]] = field(default_factory=list)
    free_joints: list[str] = field(default_factory=list)
    collisions: int = 0


# ----- which URDF -------------------------------------------------------------------------------------------
def urdf_candidates(run_dir: Path) -> list[Path]:
    """The run's URDF files nearest its top (URDFormer's are in ``output/``, a ROS package's in
    ``<pkg>/urdf/``), sorted; scratch files left out."""
    found = [p for p in run_dir.rglob("*.urdf") if p.is_file() and p.name not in SCRATCH_URDFS]
    if not found:
        return []
    depth = min(len(p.relative_to(run_dir).parts) for p in found)
    return sorted(p for p in found if len(p.relative_to(run_dir).parts) == depth)


def choose_urdf(run_dir: Path) -> tuple[Path, str, list[Path]]:
    """``(the URDF to read, why, the others)`` (see the module docstring).

    :raises InputError: when the run holds no URDF, or the chosen one leads out of the run folder
    """
    found = urdf_candidates(run_dir)
    if not found:
        raise InputError(run_dir, "no URDF (*.urdf) in the run folder (the method did not write one: it "
                                  "failed or did not run)")
    known = [p for name in KNOWN_URDFS for p in found if p.name == name]
    if known:
        chosen, why = known[0], f"known name ({KNOWN_URDFS[known[0].name]})"
    else:
        chosen, why = found[0], "the only URDF" if len(found) == 1 else "the first by name (no known name)"
    if not chosen.resolve().is_relative_to(run_dir):
        raise InputError(chosen, "the URDF is a link leading out of the run folder")
    return chosen, why, [p for p in found if p != chosen]


# ----- mesh paths -------------------------------------------------------------------------------------------
def _inside(path: Path, run_dir: Path) -> bool:
    return path.resolve().is_relative_to(run_dir)


def _first_file(candidates: list[Path], run_dir: Path) -> Path | None:
    return next((c.resolve() for c in candidates if _inside(c, run_dir) and c.is_file()), None)


def resolve_mesh(written: str, urdf: Path, run_dir: Path) -> MeshPath:
    """The file a ``<mesh filename>`` names, inside the run folder (module docstring, *Mesh paths*).

    :param written: the filename as written
    :param urdf: the URDF (relative paths start at its folder)
    :param run_dir: the run folder (resolved)
    :raises InputError: naming the URDF when the path leads out of the run folder
    """
    name = written.removeprefix("file://")
    here = urdf.parent
    if name.startswith("package://"):
        package, _, rest = name.removeprefix("package://").partition("/")
        above = [d for d in [here, *here.parents] if d.is_relative_to(run_dir)]
        candidates = [d / rest for d in above if d.name == package]
        candidates += [here / package / rest, run_dir / package / rest, run_dir / rest, here / rest]
        found = _first_file(candidates, run_dir)
        if found is None and not _inside(here / package / rest, run_dir):
            raise InputError(urdf, f"mesh path {written!r} leaves the run folder {OUTSIDE_HINT}")
        # none there: where the URDF reader looks (package name as a folder), for its "not found"
        return MeshPath(written, found or (here / package / rest).resolve(), "package")
    path = PurePath(name)
    if path.is_absolute():
        if _inside(Path(path), run_dir):
            return MeshPath(written, Path(path).resolve(), "absolute")
        tails = [Path(*path.parts[-k:]) for k in range(len(path.parts) - 1, 0, -1)]
        found = _first_file([base / tail for tail in tails for base in (here, run_dir)], run_dir)
        if found is None:
            raise InputError(urdf, f"mesh path {written!r} is absolute, outside the run folder, and no file "
                                   "of its tail is in the run folder (copy the meshes it names beside the "
                                   "URDF)")
        return MeshPath(written, found, "absolute-tail")
    resolved = (here / path).resolve()
    if not resolved.is_relative_to(run_dir):
        raise InputError(urdf, f"mesh path {written!r} leaves the run folder {OUTSIDE_HINT}")
    return MeshPath(written, resolved, "relative")


def check_mesh_reader(mesh: MeshPath, urdf: Path) -> None:
    """A DAE mesh needs ``pycollada`` (trimesh's COLLADA loader).

    :raises InputError: naming the URDF and the file when it is not installed
    """
    if mesh.path.suffix.lower() == ".dae" and importlib.util.find_spec("collada") is None:
        raise InputError(urdf, f"mesh {mesh.written!r} is COLLADA (DAE): reading it needs pycollada "
                               "(pip install pycollada)")


# ----- the XML ----------------------------------------------------------------------------------------------
def parse_urdf(urdf: Path) -> etree._Element:
    """The URDF's ``<robot>`` element (checked by :func:`spark_bench.asset.urdf.read_urdf_xml`: well-formed,
    no DTD or entities, root ``<robot>``).

    :raises InputError: naming the file when it is not a URDF
    """
    from spark_bench.asset.urdf import read_urdf_xml

    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    return etree.fromstring(read_urdf_xml(urdf), parser=parser)


def prepare_urdf(root: etree._Element, urdf: Path, run_dir: Path) -> PreparedUrdf:
    """The URDF with its visual mesh paths resolved, collisions dropped and free joints made fixed.

    :param root: its ``<robot>`` element (changed in place)
    :param urdf: the URDF file
    :param run_dir: the run folder (resolved)
    :raises InputError: for a visual mesh without a filename or a mesh path leading out of the run folder
    """
    prepared = PreparedUrdf(b"")
    for link in root.findall("link"):
        for collision in link.findall("collision"):
            link.remove(collision)
            prepared.collisions += 1
        for mesh in link.findall("visual/geometry/mesh"):
            written = mesh.get("filename")
            if not written:
                raise InputError(urdf, f"link {link.get('name')!r}: a visual <mesh> without a filename")
            found = resolve_mesh(written, urdf, run_dir)
            check_mesh_reader(found, urdf)
            mesh.set("filename", str(found.path))
            prepared.meshes.append((link.get("name"), found))
    for joint in root.findall("joint"):
        if joint.get("type") in FREE_TYPES:
            joint.set("type", "fixed")
            prepared.free_joints.append(joint.get("name"))
    prepared.xml = etree.tostring(root, xml_declaration=True, encoding="utf-8")
    return prepared


def freeart3d_urdf(root: etree._Element) -> bool:
    """Whether a URDF (its ``<robot>`` element) is FreeArt3D's ``output.urdf`` (meshes in
    ``sds_output/part_meshes/``)."""
    return any(FREEART3D_MESHES in (m.get("filename") or "") for m in root.iter("mesh"))


def load_prepared(prepared: PreparedUrdf, urdf: Path, run_dir: Path) -> ArticulatedAsset:
    """The object of a prepared URDF, read by :func:`spark_bench.asset.urdf.load_urdf`.

    :raises InputError: what the URDF reader finds, naming ``urdf`` (not the rewritten copy) and each mesh
        file relative to the run folder
    """
    from spark_bench.asset.urdf import load_urdf

    with tempfile.TemporaryDirectory(prefix="spark_bench_urdf_") as scratch:
        copy = Path(scratch) / urdf.name
        copy.write_bytes(prepared.xml)
        try:
            return load_urdf(copy, folder=run_dir)
        except InputError as exc:
            problem = exc.problem
            for _, mesh in prepared.meshes:
                problem = problem.replace(str(mesh.path), str(mesh.path.relative_to(run_dir)))
            where = urdf if exc.path in (None, str(copy.resolve()), str(copy)) else exc.path
            raise InputError(where, problem) from None


def check_limits(asset: ArticulatedAsset, urdf: Path) -> None:
    """Revolute limits are radians: one beyond 2 pi is degrees written where radians are meant.

    :raises InputError: naming the joint and its limits
    """
    for joint in asset.joints.values():
        if joint.type == JointType.REVOLUTE and max(abs(joint.lower), abs(joint.upper)) > REVOLUTE_LIMIT_MAX:
            span = f"[{joint.lower:g}, {joint.upper:g}]"
            raise InputError(urdf, f"joint {joint.name!r}: revolute limits {span} are beyond 2 pi: URDF "
                                   "limits are radians (these look like degrees)")


def rest_as_written(asset: ArticulatedAsset) -> list[str]:
    """Re-express each movable joint whose range ends at 0 (``[l, 0]``, ``l < 0``) with the negated axis and
    the range ``[0, -l]``, so that its rest (the lower limit) is the state the meshes are written in (module
    docstring, *Joints*). Changes ``asset`` in place.

    :returns: the names of the joints re-expressed
    """
    flipped = []
    for joint in asset.joints.values():
        ends_at_zero = joint.has_limits and joint.upper == 0.0 and joint.lower < 0.0
        if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC) and ends_at_zero:
            joint.axis = -np.asarray(joint.axis, dtype=float)
            joint.lower, joint.upper = 0.0, -joint.lower
            flipped.append(joint.name)
    return flipped


def root_style(asset: ArticulatedAsset) -> str:
    """How the root is turned: ``partnet-mobility``, ``articulate-anything`` (:data:`ROOT_STYLES`),
    ``identity`` or ``other``: the rotation of the only joint below a root link without geometry."""
    root = asset.root
    below = [j for j in asset.joints.values() if j.parent == root]
    if asset.links[root].has_geometry or len(below) != 1:
        return "identity"
    rotation = np.asarray(below[0].origin, dtype=float)[:3, :3]
    if np.allclose(rotation, np.eye(3), atol=1e-5):
        return "identity"
    return next((style for style, matrix in ROOT_STYLES.items() if np.allclose(rotation, matrix, atol=1e-5)),
                "other")


# ----- the reader -------------------------------------------------------------------------------------------
def read_freeart3d(run_dir: Path, urdf: Path, why: str, others: list[Path]) -> ForeignObject:
    """FreeArt3D's ``output.urdf``, read through ``sds_output/joint_info.json`` (module docstring).

    :raises InputError: when ``joint_info.json`` is not there, or what the FreeArt3D reader finds
    """
    from spark_bench.formats import freeart3d

    if not (run_dir / freeart3d.SDS_DIR / freeart3d.JOINT_INFO).is_file():
        raise InputError(urdf, "FreeArt3D's output.urdf (pipelines/urdf.py write_urdf) cannot be read as a "
                               "URDF (meshes in the object frame, limits lower = s, upper = 0, |axis|) and "
                               "sds_output/joint_info.json, which it is built from, is missing")
    found = freeart3d.read_run(run_dir)
    found.record.update(format=FORMAT, read_through=freeart3d.FORMAT, urdf=str(urdf.relative_to(run_dir)),
                        urdf_choice=why, other_urdfs=[str(p.relative_to(run_dir)) for p in others])
    found.record["files"] = [str(urdf.relative_to(run_dir)), *found.record["files"]]
    found.record["facts"] = [FACTS["freeart3d"], *found.record["facts"]]
    found.record["not_read"] = [n for n in found.record["not_read"] if not n.startswith(freeart3d.URDF)]
    return found


def read_run(run_dir: Path) -> ForeignObject:
    """One run folder holding a URDF and its meshes, read into our frame (see the module docstring).

    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    urdf, why, others = choose_urdf(run_dir)
    root = parse_urdf(urdf)
    if freeart3d_urdf(root):
        return read_freeart3d(run_dir, urdf, why, others)
    prepared = prepare_urdf(root, urdf, run_dir)
    asset = load_prepared(prepared, urdf, run_dir)
    check_limits(asset, urdf)
    flipped = rest_as_written(asset)
    asset.name = run_dir.name
    asset.source = str(urdf)
    style = root_style(asset)
    rules = {mesh.rule for _, mesh in prepared.meshes}
    applied = ["frame", "units", "visuals"]
    applied += [key for key, rule in (("package", "package"), ("absolute", "absolute-tail")) if rule in rules]
    applied += ["ends-at-zero"] if flipped else []
    applied += ["free"] if prepared.free_joints else []
    applied += [f"root-{style}"] if f"root-{style}" in FACTS else []
    files = list(dict.fromkeys(str(m.path.relative_to(run_dir)) for _, m in prepared.meshes))
    record = {"format": FORMAT, "urdf": str(urdf.relative_to(run_dir)), "urdf_choice": why,
              "other_urdfs": [str(p.relative_to(run_dir)) for p in others],
              "files": [str(urdf.relative_to(run_dir)), *files], "facts": [FACTS[key] for key in applied],
              "format_frame": "the URDF's world: Z up (URDF convention); front and size as the method wrote",
              "root_joint": style,
              "meshes": [{"link": link, "written": m.written, "file": str(m.path.relative_to(run_dir)),
                          "rule": m.rule} for link, m in prepared.meshes],
              "joints_made_fixed": prepared.free_joints, "joints_negated": flipped,
              "skipped_meshes": {name: link.skipped_meshes for name, link in asset.links.items()
                                 if link.skipped_meshes},
              "not_read": [f"{prepared.collisions} <collision> elements (the metrics use visuals)",
                           "<inertial> elements"]}
    return ForeignObject(asset, record, articulated=True, open_questions=("yaw", "scale", "front"))
