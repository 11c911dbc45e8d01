"""Articulate AnyMesh: one articulated object as ``mobility.json`` (parts, their parents and joints) and
``mesh_parts/<part>.glb``, read as Articulate AnyMesh's code writes them.

Read from ``UMass-Embodied-AGI/ArticulateAnymesh`` (the code the paper's project page links; ``jasongzy/
Articulate-AnyMesh`` is not in the index), newest snapshot (2025-05-12). The facts, each with where it
comes from:

**Layout.** ``run.py`` works in ``<data_dir>/<object_name>/`` (the run folder, from the config YAML):
the input ``mesh.{ply,obj,glb}``; ``ArticulateAnymesh/render_object.py`` ``render_object`` writes
``mesh_normalized.glb`` and the renders; ``ArticulateAnymesh/postprocess_segmentation.py``
``postprocess_segmentation`` writes one GLB per part, ``mesh_parts/<link>@<k>.glb`` (``<link>`` the
segmented part's name, ``<k>`` its instance), and ``mesh_parts/base.glb`` (the faces no part took),
each the faces of ``mesh_normalized.glb`` that the part's points cover, exported by trimesh;
``ArticulateAnymesh/joint_estimation.py`` ``joint_estimation`` writes ``mobility.json`` last
(``json.dump``), so a run that failed in any stage has none.

**mobility.json** (``joint_estimation.py`` ``get_mobility_json``): a list, one entry per part in the
order of ``gpt4o_out/link_hierarchy.txt``, the moving parts first, ``base`` last:
``{"id": int, "parent": name | null, "joint": type, "name": "<link>@<k>" | "base", "jointData": ...}``.
``parent`` is the parent part's *name* (``"base"`` or ``"<link>@<k>"``), null for ``base``
(``postprocess_segmentation`` picks the nearest part of the parent link; when there is none it writes
``None``, read back as the name ``"None"``: an :class:`InputError` here). ``joint`` is one of
``fixed``, ``prismatic``, ``revolute``, ``continuous`` (``prompts.py``: "Available joint types are";
``base`` is ``fixed``: ``parse_utils.py`` ``parse_articulation_tree``). ``jointData`` is
``{"axis": {"origin": [x, y, z], "direction": [x, y, z]}}`` for a revolute or continuous joint,
``{"axis": {"origin": [0, 0, 0], "direction": ...}}`` for a prismatic one, ``{}`` for a fixed one.
There are **no limits** anywhere (no ``limit`` key; no code of the repository gives one).

**Axes** (``joint_estimation``): ``origin`` is a **point on the axis** in the object frame (revolute: the
mean of the label points the VLM chose, or the one it chose), ``direction`` the axis in the same frame:
a principal direction (``np.linalg.svd``) or a contact-plane normal (open3d ``segment_plane``) for a
revolute joint, a plane normal or an arrow ``arrow_points[k] - arrow_points[0]`` (not unit) for a
prismatic one. Its sign is not chosen to open the part (an SVD's sign is arbitrary). The reader
normalizes it; a NaN, zero or non-3-vector axis is an :class:`InputError`.

**Frame** (``render_object.py``): ``mesh_normalized.glb`` is the input mesh loaded by trimesh
(``force='mesh'``), centred on its box, scaled so that the box **diagonal** is 2
(``scale_factor = 2.0 / norm(extents)``) and turned by the config's ``render.euler`` (zeros in both
example configs); the sampled points, the part meshes and the joints are all in this frame. It is
**Y up**: the cameras orbit about Y with ``up=(0, 1, 0)`` (``get_camera_poses``, ``scene.add_camera``)
and ``draw_image.py`` ``get_orthogonal_directions`` takes ``up_vector=[0, 1, 0]``. Which side is the
front is the input mesh's own (glTF: +Z). The reader turns Y up, +Z front into ours (Z up, front -X)
with PartNet-Mobility's root rotation (:data:`spark_bench.formats.parts.Y_UP_TO_OURS`); the turn
about the up axis, the front and the scale stay open. The meshes are the input mesh as given: the rest
state.

**Limits given here** (:data:`LIMITS`; none in the format): the project's values for a URDF joint
without ``<limit>`` (docs/conventions.md "Joint types"): revolute ``[0, pi]`` (``has_limits`` False),
prismatic ``[0, 0]``, continuous ``[0, 2 pi]``. Recorded in ``import.json`` (``limits``). A
``jointData.limit`` (PartNet-Mobility's ``mobility_v2.json`` has one, in degrees, with the words
``hinge``/``slider``) means the file is not Articulate AnyMesh's: an :class:`InputError`.

**Checks**: each of these is an :class:`InputError` naming the file: a missing or unreadable part mesh,
a name whose mesh path leaves ``mesh_parts/``, two parts of one name, no root or two, a parent that
names no part, a cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import DEFAULT_REVOLUTE_UPPER, ArticulatedAsset, Joint, Link, Visual
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject, axis_line
from spark_bench.formats.parts import Y_UP_TO_OURS, inside

FORMAT = "anymesh"
REPO = "UMass-Embodied-AGI/ArticulateAnymesh"
MOBILITY = "mobility.json"
MESH_DIR = "mesh_parts"
JOINT_TYPES = ("fixed", "prismatic", "revolute", "continuous")
#: PartNet-Mobility's ``mobility_v2.json`` joint words: such a file is not this format.
PARTNET_WORDS = ("hinge", "slider", "free", "heavy", "static")
#: ``(lower, upper, has_limits)`` given to each type (the format has no limits; see the module docstring).
LIMITS = {"revolute": (0.0, DEFAULT_REVOLUTE_UPPER, False), "prismatic": (0.0, 0.0, False),
          "continuous": (0.0, 2.0 * math.pi, False), "fixed": (0.0, 0.0, True)}

FACTS = [
    {"fact": "run folder = <data_dir>/<object_name>/: mobility.json (written last) and mesh_parts/<name>.glb "
             "per part (base.glb: the faces no part took)",
     "source": f"{REPO} run.py; ArticulateAnymesh/postprocess_segmentation.py postprocess_segmentation; "
               "ArticulateAnymesh/joint_estimation.py joint_estimation"},
    {"fact": "mobility.json: list of {id, parent (parent part's name, null for base), joint (fixed | "
             "prismatic | revolute | continuous), name, jointData {axis {origin, direction}} or {}}; "
             "no limits",
     "source": f"{REPO} ArticulateAnymesh/joint_estimation.py get_mobility_json; "
               "ArticulateAnymesh/prompts.py; ArticulateAnymesh/parse_utils.py parse_articulation_tree, "
               "parse_link_hierarchy"},
    {"fact": "axis origin = a point on the axis (prismatic: [0, 0, 0]), direction not unit and of arbitrary "
             "sign, both in the mesh frame (world, not parent or child)",
     "source": f"{REPO} ArticulateAnymesh/joint_estimation.py joint_estimation; "
               "ArticulateAnymesh/draw_image.py"},
    {"fact": "frame: input mesh centred, box diagonal 2, turned by render.euler; Y up (cameras orbit "
             "about Y, up (0, 1, 0)): turned to Z up, front -X by PartNet-Mobility's root rotation; yaw, "
             "front and scale left open; meshes at rest",
     "source": f"{REPO} ArticulateAnymesh/render_object.py render_object, get_camera_poses; "
               "ArticulateAnymesh/draw_image.py get_orthogonal_directions"},
    {"fact": "no limits in the format: revolute [0, pi], prismatic [0, 0], continuous [0, 2 pi] (the "
             "project's values for a joint without <limit>)",
     "source": "spark-bench docs/conventions.md 'Joint types' (not the method's)"},
]


@dataclass
class Entry:
    """One part of ``mobility.json``, checked (the method's frame).

    :param name: the part's name (``base``, ``door@1``)
    :param parent: its parent's name (None for the root)
    :param type: joint type
    :param origin: a point on the axis (movable joints), else None
    :param direction: the unit axis (movable joints), else None
    """

    name: str
    parent: str | None
    type: str
    origin: np.ndarray | None = None
    direction: np.ndarray | None = None


def read_entry(item, index: int, path: Path) -> Entry:
    """Entry ``index`` of ``mobility.json``, checked (see the module docstring).

    :raises InputError: naming the entry and the problem
    """
    if not isinstance(item, dict) or not {"name", "parent", "joint", "jointData"} <= set(item):
        raise InputError(path, f"entry {index} is not a part of Articulate AnyMesh's mobility.json "
                               "(expected keys id, parent, joint, name, jointData)")
    name, parent, kind, data = item["name"], item["parent"], item["joint"], item["jointData"]
    if not isinstance(name, str) or not name:
        raise InputError(path, f"entry {index}: name {name!r} is not a part name")
    if kind in PARTNET_WORDS:
        raise InputError(path, f"part {name!r}: joint {kind!r} is PartNet-Mobility's mobility_v2.json word, "
                               f"not Articulate AnyMesh's ({', '.join(JOINT_TYPES)})")
    if kind not in JOINT_TYPES:
        raise InputError(path, f"part {name!r}: joint type {kind!r} is not one of {', '.join(JOINT_TYPES)}")
    if parent is not None and not isinstance(parent, str):
        raise InputError(path, f"part {name!r}: parent {parent!r} is not a part name (PartNet-Mobility's "
                               "mobility_v2.json gives ids; Articulate AnyMesh gives names)")
    if not isinstance(data, dict):
        raise InputError(path, f"part {name!r}: jointData is not an object")
    if "limit" in data:
        raise InputError(path, f"part {name!r}: jointData has a limit: Articulate AnyMesh writes none "
                               "(joint_estimation.py get_mobility_json); PartNet-Mobility's are in degrees")
    if kind == JointType.FIXED:
        return Entry(name, parent, kind)
    origin, direction = axis_line(data.get("axis"), path, f"part {name!r}: {kind} joint (jointData)")
    return Entry(name, parent, kind, origin, direction)


def load_entries(path: Path) -> list[Entry]:
    """The parts of ``mobility.json``, checked one by one and as a tree.

    :raises InputError: for a file that is not JSON or not a non-empty list, a bad entry, or a bad tree
    """
    data = read_json(path)
    if not isinstance(data, list) or not data:
        raise InputError(path, "not Articulate AnyMesh's mobility.json: expected a non-empty list of parts")
    entries = [read_entry(item, i, path) for i, item in enumerate(data)]
    check_tree(entries, path)
    return entries


def check_tree(entries: list[Entry], path: Path) -> None:
    """One root, unique names, every parent a part, no cycle.

    :raises InputError: naming the problem
    """
    names = [e.name for e in entries]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(path, f"two parts are named {twice[0]!r}")
    roots = [e.name for e in entries if e.parent is None]
    if len(roots) != 1:
        raise InputError(path, f"expected one part without a parent (base), found {len(roots)}: {roots[:5]}")
    known = set(names)
    for entry in entries:
        if entry.parent is not None and entry.parent not in known:
            why = (" (postprocess_segmentation.py found no part of the parent link)" if entry.parent == "None"
                   else "")
            raise InputError(path, f"part {entry.name!r}: parent {entry.parent!r} names no part{why}")
    parent_of = {e.name: e.parent for e in entries}
    for entry in entries:
        seen, name = [entry.name], entry.parent
        while name is not None:
            if name in seen:
                raise InputError(path, f"cycle in the part tree: {' -> '.join([*seen, name])}")
            seen.append(name)
            name = parent_of[name]


def mesh_path(run_dir: Path, name: str) -> Path:
    """``mesh_parts/<name>.glb`` of a part, checked to stay in ``mesh_parts/``.

    :raises InputError: when the name leads out of it, or the file is missing
    """
    folder = run_dir / MESH_DIR
    path = folder / f"{name}.glb"
    if not path.resolve().is_relative_to(folder.resolve()) or Path(name).name != name:
        raise InputError(run_dir / MOBILITY,
                         f"part {name!r}: its mesh path {MESH_DIR}/{name}.glb leaves {MESH_DIR}/")
    if not path.is_file():
        raise InputError(path, f"part {name!r}'s mesh is missing (postprocess_segmentation.py writes "
                               f"{MESH_DIR}/<name>.glb for every part)")
    inside(run_dir, path)
    return path


def load_part(path: Path) -> tuple[trimesh.Trimesh, tuple | None]:
    """A part GLB in our frame (Z up).

    :raises InputError: when it cannot be read or has no surface
    """
    from spark_bench.asset.urdf import load_mesh_file

    mesh, rgba = load_mesh_file(path.resolve())
    if not float(mesh.area) > 0.0:
        raise InputError(path, "part mesh has no surface (zero area)")
    return trimesh.Trimesh(mesh.vertices @ Y_UP_TO_OURS.T, mesh.faces, process=False), rgba


def topological(entries: list[Entry]) -> list[Entry]:
    """The entries, parents before children (file order among siblings)."""
    order, placed = [], set()
    while len(order) < len(entries):
        for entry in entries:
            if entry.name not in placed and (entry.parent is None or entry.parent in placed):
                order.append(entry)
                placed.add(entry.name)
    return order


def build_asset(entries: list[Entry], meshes: dict[str, tuple[trimesh.Trimesh, tuple | None]],
                sources: dict[str, str], name: str) -> ArticulatedAsset:
    """The object in our frame: a link per part, its frame at its joint's point on the axis (its parent's
    frame for a fixed joint), no rotation; each joint's axis the part's direction turned into our frame;
    limits from :data:`LIMITS`.

    :param meshes: part name -> (mesh in our frame, colour)
    :param sources: part name -> its mesh file, relative to the run folder
    """
    link_of = {e.name: ("base" if e.parent is None else f"link_{k}") for k, e in enumerate(entries)}
    position: dict[str, np.ndarray] = {}
    links, joints = {}, {}
    for entry in topological(entries):
        link = link_of[entry.name]
        if entry.parent is None:
            position[entry.name] = np.zeros(3)
        elif entry.type == JointType.FIXED:
            position[entry.name] = position[entry.parent]
        else:
            position[entry.name] = Y_UP_TO_OURS @ entry.origin
        mesh, rgba = meshes[entry.name]
        local = trimesh.Trimesh(mesh.vertices - position[entry.name], mesh.faces, process=False)
        visual = Visual(local, rgba=rgba or (0.7, 0.7, 0.7, 1.0), source=sources[entry.name])
        links[link] = Link(link, [visual], label=entry.name)
        if entry.parent is None:
            continue
        origin = np.eye(4)
        origin[:3, 3] = position[entry.name] - position[entry.parent]
        axis = Y_UP_TO_OURS @ entry.direction if entry.direction is not None else np.array([1.0, 0.0, 0.0])
        lower, upper, has_limits = LIMITS[entry.type]
        joint = f"joint_{link.removeprefix('link_')}"
        joints[joint] = Joint(joint, entry.type, link_of[entry.parent], link, origin, axis, lower, upper,
                              has_limits=has_limits)
    return ArticulatedAsset(name=name, links=links, joints=joints)


def read_run(run_dir: Path) -> ForeignObject:
    """One Articulate AnyMesh run folder (``<data_dir>/<object_name>/``), read into our frame (see the
    module docstring).

    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    path = run_dir / MOBILITY
    if not path.is_file():
        raise InputError(path, "no Articulate AnyMesh mobility.json (joint_estimation.py writes it last: a "
                               "stage failed or did not run)")
    entries = load_entries(path)
    paths = {e.name: mesh_path(run_dir, e.name) for e in entries}
    meshes = {name: load_part(p) for name, p in paths.items()}
    sources = {name: str(p.relative_to(run_dir)) for name, p in paths.items()}
    asset = build_asset(entries, meshes, sources, run_dir.name)
    asset.source = str(path)
    listed = {p.name for p in paths.values()}
    unlisted = sorted(p.name for p in (run_dir / MESH_DIR).glob("*.glb") if p.name not in listed)
    record = {"format": FORMAT, "files": [MOBILITY, *sources.values()], "facts": list(FACTS),
              "frame": "Articulate AnyMesh: the input mesh centred, box diagonal 2, Y up (turned to Z up)",
              "parts": [{"name": e.name, "parent": e.parent, "joint": e.type,
                         "link": "base" if e.parent is None else f"link_{k}"} for k, e in enumerate(entries)],
              "limits": {kind: {"lower": lo, "upper": hi, "given_by": "spark-bench (the format has none)"}
                         for kind, (lo, hi, _) in LIMITS.items() if kind != JointType.FIXED},
              "not_read": [f"{MESH_DIR}/{n} (no part of mobility.json names it)" for n in unlisted]}
    return ForeignObject(asset, record, articulated=True, open_questions=("yaw", "scale", "front"))
