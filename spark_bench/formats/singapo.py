"""SINGAPO / DIPO / CAGE: one generated object as ``object.json`` (a ``diffuse_tree`` of parts, each with
its box and the joint to its parent) and one PLY per part, read as these methods write them.

Read from the code of ``3dlg-hcvc/singapo`` (SINGAPO, ICLR 2025), ``RQ-Wu/DIPO`` (same output code,
copied from SINGAPO) and ``3dlg-hcvc/cage`` (CAGE, CVPR 2024, where the format and the retrieval come
from). The facts, each with where it comes from:

**Layout.**

- ``object.json``: ``{"meta": {"obj_cat": ...}, "diffuse_tree": [node, ...]}`` written by
  ``demo/demo.py`` (``post_process``: ``<save_dir>/<i>/object.json``, one folder per sample ``i``) and
  ``systems/base.py`` (``save_json(f"{save_dir}/{b}/object.json")``) of singapo; DIPO's ``demo_img.py``
  and ``results/<i>/object.json`` are the same. CAGE's ``demo.py`` (``retrieve_meshes``) names the JSON
  ``#<b>.json`` and its meshes ``#<b>_meshes/part_<i>.ply``. The reader takes ``object.json``, else the
  one ``*.json`` holding a ``diffuse_tree`` with joints; a run folder holding sample folders ``0/``,
  ``1/``... (the demo's ``demo_output/``, beside ``pred_graph.json``: the predicted part graph, no
  joints, ``demo.py`` ``save_graph``) is read from its lowest-numbered sample, the one SINGAPO's
  ``scripts/eval_metrics.py`` reports as "first".
- Part meshes: ``scripts/mesh_retrieval/retrieve.py`` (``_retrieve_part_meshes``) retrieves a mesh per
  node from the training data, scales it to the node's ``aabb`` size, moves it to the ``aabb`` centre and
  writes ``plys/part_<i>.ply``; it sets ``node["plys"] = ["plys/part_<i>.ply"]`` (paths relative to the
  JSON's folder) and writes ``object.ply`` (all parts, not read here). So every part is already in the
  object frame, at rest. When retrieval fails (``RuntimeError`` in ``pick_and_rescale_parts``, caught
  by ``run_retrieve.py``) ``object.json`` keeps no ``plys``: an :class:`InputError` here (the boxes alone
  are no surface to score). CAGE's preprocessed data (``preprocess.py``) lists several PLYs per part:
  all are read.

**Tree.** ``data/utils.py`` ``parse_tree``: node ``id`` = its index (``preprocess.py`` ``_renumber`` says
so too), ``parent`` (-1 for the root), ``children`` (ids), ``name`` (``door``, ``drawer``, ``base``,
``handle``, ``wheel``, ``knob``, ``shelf``, ``tray``: ``utils/refs.py`` ``sem_ref``), ``aabb``
(``center``, ``size``) and ``joint`` (``type``, ``range``, ``axis``: ``origin``, ``direction``). Each
node's joint links it to its parent and a part moves with its parent (``objects/motions.py``
``transform_all_parts``; ``utils/render.py`` ``prepare_meshes`` draws a handle with its door's joint).
A second root, a parent that is not there, a ``children`` list that disagrees with the ``parent``
fields, or a cycle is an :class:`InputError`.

**Joints** (``parse_tree``; ``convert_data_range``; ``preprocess.py`` ``_convert_joint``,
``_reset_state``):

- types ``fixed``, ``revolute``, ``prismatic``, ``screw``, ``continuous`` (``utils/refs.py``
  ``joint_ref``). A ``screw`` (a PartNet-Mobility slider that also rotates) becomes a prismatic joint to
  a helper link and a continuous joint about the same axis, as PartNet-Mobility's URDFs chain them.
- ``axis.origin`` is a point on the axis and ``axis.direction`` its direction, both in the object frame
  (``motions.py`` rotates ``vertices - origin`` about ``direction`` and adds ``origin`` back;
  ``utils/render.py`` ``rescale_axis`` moves the point along the axis next to the box, and puts a
  prismatic joint's origin at the box centre). A fixed joint's axis is zeros or absent (CAGE's handles).
- ``range`` is ``[0, r]``: the part as written is at rest (``preprocess.py`` ``_reset_state`` moves
  the meshes to the lower limit and rewrites the range as ``[0, b - a]``); the open state moves it by
  ``r``. A revolute ``r`` is in **degrees** (``convert_data_range``: ``range * 360``; ``motions.py``:
  ``np.radians(joint["range"][1] ...)``; ``render.py``: ``np.deg2rad(jrange[1])``); a prismatic or screw
  ``r`` in the object's length unit (``motions.py``: ``direction * range[1]``); a continuous one is
  ``[0, 360]`` (generated) or ``[0, 0]`` (CAGE's data) and has no limit. A negative ``r`` opens the
  other way: the axis is negated and the limits are ``[0, |r|]`` (same motion). A revolute ``r`` beyond
  a full turn, or every revolute ``r`` within 2 pi (radians written where degrees are meant) is an
  :class:`InputError`, and so is a ``range[0]`` other than 0 (``motions.py`` ignores it: no code of
  these methods writes one).

**Frame.** The training data is PartNet-Mobility's meshes and ``mobility_v2.json`` axes as they are
(``preprocess.py`` reads ``textured_objs/*.obj`` and ``jointData.axis`` with no transform): Y up, the
front towards +Z (the renders of ``utils/render.py`` ``render_anim_parts`` look from +Z with +Y up). The
reader applies PartNet-Mobility's root joint ``rpy="1.570796 0 -1.570796"`` (:data:`RAW_TO_OURS`) to
meshes, points and directions. The objects are generated in that canonical frame whatever the view of
the input image (the model is trained on 20 random views of each object, against its canonical
``object.json``), so the turn about the up axis is not left open; the scale is (PartNet-Mobility's own
mesh units, not metres).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import rpy_to_matrix
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject, axis_line

FORMAT = "singapo"
JSON_NAME = "object.json"
#: ``diffuse_tree``; ``arti_tree`` is the older name ``retrieval/obj_retrieval.py`` still renames.
TREE_KEYS = ("diffuse_tree", "arti_tree")
NODE_JOINT_TYPES = ("fixed", "revolute", "prismatic", "screw", "continuous")
#: PartNet-Mobility's root joint, ``rpy="1.570796 0 -1.570796"``: Y up, front +Z -> Z up, front -X.
RAW_TO_OURS = rpy_to_matrix((math.pi / 2, 0.0, -math.pi / 2))
#: A revolute range beyond this many degrees is no SINGAPO range (``convert_data_range`` clips to 360).
FULL_TURN_DEG = 360.0
RANGE_TOL = 1e-9

SINGAPO = "3dlg-hcvc/singapo"
FACTS = [
    {"fact": "object.json diffuse_tree: node id = index, parent (-1: root), children, name, aabb, joint "
             "{type, range, axis {origin, direction}}", "source": f"{SINGAPO} data/utils.py parse_tree"},
    {"fact": "part meshes plys/part_<i>.ply, already in the object frame at rest (retrieved mesh scaled to "
             "the node's aabb size and moved to its centre); paths relative to object.json",
     "source": f"{SINGAPO} scripts/mesh_retrieval/retrieve.py _retrieve_part_meshes"},
    {"fact": "a node's joint links it to its parent; a part moves with its parent",
     "source": f"{SINGAPO} objects/motions.py transform_all_parts"},
    {"fact": "axis.origin is a point on the axis, axis.direction its direction, both in the object frame",
     "source": f"{SINGAPO} objects/motions.py transform_all_parts; utils/render.py rescale_axis"},
    {"fact": "range [0, r]: the part as written is at rest; revolute r in degrees, prismatic/screw r in "
             "object units, continuous [0, 360] or [0, 0] without limit",
     "source": f"{SINGAPO} data/utils.py convert_data_range, parse_tree; objects/motions.py; "
               "3dlg-hcvc/cage preprocess.py _reset_state"},
    {"fact": "screw (slider that also rotates) = prismatic + continuous about the same axis, chained by a "
             "helper link", "source": "3dlg-hcvc/cage preprocess.py _convert_joint"},
    {"fact": "frame: PartNet-Mobility's raw mesh frame (Y up, front +Z); PartNet-Mobility's root joint "
             "rpy=(pi/2, 0, -pi/2) applied to meshes, points and directions",
     "source": "3dlg-hcvc/cage preprocess.py process_model (textured_objs and mobility_v2 axes untransformed); "
               f"{SINGAPO} utils/render.py render_anim_parts (camera +Z, up +Y)"},
]


@dataclass
class NodeJoint:
    """One node's joint, read and checked (object frame, as written).

    :param type: one of :data:`NODE_JOINT_TYPES`
    :param origin: a point on the axis
    :param direction: unit direction (None for a fixed joint)
    :param amount: ``range[1]`` as written (degrees for revolute, length otherwise)
    """

    type: str
    origin: np.ndarray
    direction: np.ndarray | None
    amount: float


# ----- finding and reading the JSON ------------------------------------------------------------------------
def find_object_json(run_dir: Path) -> tuple[Path, str | None]:
    """``(the JSON to read, the sample folder it is in or None)`` (module docstring, *Layout*).

    :raises InputError: when the run folder holds no such JSON
    """
    if (run_dir / JSON_NAME).is_file():
        return run_dir / JSON_NAME, None
    candidates = [p for p in sorted(run_dir.glob("*.json")) if _has_tree(p)]
    if len(candidates) == 1:
        return candidates[0], None
    if len(candidates) > 1:
        raise InputError(run_dir, f"several object JSONs ({', '.join(p.name for p in candidates)}): one run "
                                  "folder holds one object")
    samples = sorted((p for p in run_dir.iterdir() if p.is_dir() and p.name.isdigit()
                      and (p / JSON_NAME).is_file()), key=lambda p: int(p.name))
    if samples:
        return samples[0] / JSON_NAME, samples[0].name
    raise InputError(run_dir, f"no SINGAPO output: no {JSON_NAME}, no *.json with a diffuse_tree, no sample "
                              f"folder 0/ holding {JSON_NAME}")


def _has_tree(path: Path) -> bool:
    """Whether ``path`` is an object JSON: a tree whose nodes have joints (not the demo's
    ``pred_graph.json``, the part graph GPT-4o predicts, whose nodes have none)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    nodes = next((data[k] for k in TREE_KEYS if k in data), None) if isinstance(data, dict) else None
    return isinstance(nodes, list) and any(isinstance(n, dict) and "joint" in n for n in nodes)


def load_tree(path: Path) -> tuple[list[dict], dict]:
    """``(the nodes, meta)`` of an object JSON.

    :raises InputError: when it is not JSON, or holds no list of node objects
    """
    data = read_json(path)
    if not isinstance(data, dict):
        raise InputError(path, "not a SINGAPO object: the JSON is not an object")
    key = next((k for k in TREE_KEYS if k in data), None)
    if key is None:
        raise InputError(path, f"not a SINGAPO object: no {TREE_KEYS[0]!r}")
    nodes = data[key]
    if not isinstance(nodes, list) or not nodes or not all(isinstance(n, dict) for n in nodes):
        raise InputError(path, f"{key} is not a non-empty list of nodes")
    meta = data.get("meta") if isinstance(data.get("meta"), dict) else {}
    return nodes, meta


# ----- the tree ------------------------------------------------------------------------------------------
def _int(value, path: Path, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(path, f"{what} is not an integer: {value!r}")
    return value


def check_tree(nodes: list[dict], path: Path) -> int:
    """The root's index, after checking ids, parents, children and that the tree has no cycle.

    :raises InputError: naming the node and the problem
    """
    n = len(nodes)
    parents = []
    for index, node in enumerate(nodes):
        if _int(node.get("id"), path, f"node {index}: id") != index:
            raise InputError(path, f"node {index}: id {node['id']} is not its index (ids are indices)")
        parent = _int(node.get("parent"), path, f"node {index}: parent")
        if parent != -1 and not 0 <= parent < n:
            raise InputError(path, f"node {index}: parent {parent} is not a node")
        if parent == index:
            raise InputError(path, f"node {index} is its own parent")
        parents.append(parent)
    roots = [i for i, p in enumerate(parents) if p == -1]
    if len(roots) != 1:
        raise InputError(path, f"expected one root (parent -1), found {len(roots)}: {roots}")
    for index, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            raise InputError(path, f"node {index}: children is not a list")
        for child in children:
            if not 0 <= _int(child, path, f"node {index}: child") < n or parents[child] != index:
                raise InputError(path, f"node {index} lists child {child}, whose parent is not {index}")
    for index in range(n):
        chain, at = [], index
        while at != -1:
            if at in chain:
                loop = chain[chain.index(at):] + [at]
                raise InputError(path, f"cycle in the tree: nodes {' -> '.join(map(str, loop))} are each "
                                       "other's parents (no path to the root)")
            chain.append(at)
            at = parents[at]
    return roots[0]


def read_joint(node: dict, index: int, path: Path) -> NodeJoint:
    """Node ``index``'s joint, checked (see the module docstring, *Joints*).

    :raises InputError: an unknown type, a range that is not ``[0, r]``, a NaN or zero axis
    """
    joint = node.get("joint")
    if not isinstance(joint, dict):
        raise InputError(path, f"node {index}: no joint object")
    kind = joint.get("type")
    if kind not in NODE_JOINT_TYPES:
        raise InputError(path, f"node {index}: joint type {kind!r} is not one of {', '.join(NODE_JOINT_TYPES)}")
    span = joint.get("range", [0.0, 0.0])
    try:
        lo, hi = (float(v) for v in span)
    except (TypeError, ValueError):
        raise InputError(path, f"node {index}: joint range is not two numbers: {span!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(path, f"node {index}: joint range {span!r} is not finite")
    if abs(lo) > RANGE_TOL:
        raise InputError(path, f"node {index}: joint range starts at {lo}, not 0 (parts are written at rest, "
                               "range [0, r])")
    if kind == JointType.FIXED:
        return NodeJoint(kind, np.zeros(3), None, 0.0)
    origin, direction = axis_line(joint.get("axis"), path, f"node {index}: {kind} joint")
    if kind == JointType.REVOLUTE and abs(hi) > FULL_TURN_DEG + 1e-6:
        raise InputError(path, f"node {index}: revolute range {hi} is beyond a full turn (degrees, at most "
                               f"{FULL_TURN_DEG:g})")
    return NodeJoint(kind, origin, direction, hi)


def check_degrees(joints: dict[int, NodeJoint], path: Path) -> None:
    """Refuse revolute ranges that are all within 2 pi: radians written where SINGAPO writes degrees.

    :raises InputError: naming the nodes
    """
    turning = {i: j.amount for i, j in joints.items() if j.type == JointType.REVOLUTE and abs(j.amount) > RANGE_TOL}
    if turning and all(abs(a) <= 2 * math.pi + 1e-9 for a in turning.values()):
        listed = ", ".join(f"node {i}: {a:g}" for i, a in sorted(turning.items()))
        raise InputError(path, f"revolute ranges look like radians ({listed}); SINGAPO writes degrees "
                               "(data/utils.py convert_data_range: range * 360)")


# ----- meshes ---------------------------------------------------------------------------------------------
def part_meshes(node: dict, index: int, json_path: Path, run_dir: Path) -> tuple[list[trimesh.Trimesh], list[str]]:
    """The node's part meshes (object frame as written) and their paths relative to the run folder.

    :raises InputError: no ``plys`` (the retrieval did not run or failed), a path leaving the run folder,
        a missing or unreadable file
    """
    from spark_bench.asset.urdf import load_mesh_file

    plys = node.get("plys")
    if plys is None:
        raise InputError(json_path, f"node {index}: no 'plys': the part mesh retrieval "
                                    "(scripts/mesh_retrieval/retrieve.py) did not run or failed")
    if not isinstance(plys, list) or not all(isinstance(p, str) for p in plys):
        raise InputError(json_path, f"node {index}: plys is not a list of paths: {plys!r}")
    meshes, files = [], []
    for name in plys:
        target = (json_path.parent / name).resolve()
        if Path(name).is_absolute() or not target.is_relative_to(run_dir):
            raise InputError(json_path, f"node {index}: mesh path {name!r} leaves the run folder")
        if not target.is_file():
            raise InputError(target, f"node {index}: part mesh file is missing")
        mesh, _ = load_mesh_file(target)
        meshes.append(mesh)
        files.append(str(target.relative_to(run_dir)))
    return meshes, files


# ----- the asset ------------------------------------------------------------------------------------------
def _translation(xyz) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = xyz
    return out


def _order(nodes: list[dict], root: int) -> list[int]:
    """Node indices breadth-first from the root (parents first)."""
    children: dict[int, list[int]] = {}
    for index, node in enumerate(nodes):
        children.setdefault(node["parent"], []).append(index)
    order, frontier = [], [root]
    while frontier:
        order.extend(frontier)
        frontier = [c for i in frontier for c in children.get(i, [])]
    return order


def _joints_of(index: int, nodes: list[dict], joint: NodeJoint, positions: dict[int, np.ndarray]
               ) -> tuple[list[Joint], list[Link]]:
    """The URDF joints (and helper link) that link node ``index`` to its parent, in our frame."""
    parent, name = nodes[index]["parent"], f"link_{index}"
    origin = _translation(positions[index] - positions[parent])
    if joint.type == JointType.FIXED:
        return [Joint(f"joint_{index}", "fixed", f"link_{parent}", name, origin=origin)], []
    sign = -1.0 if joint.amount < 0 else 1.0  # a negative range opens the other way: same motion
    axis = sign * (RAW_TO_OURS @ joint.direction)
    amount = abs(joint.amount)
    if joint.type == JointType.REVOLUTE:
        return [Joint(f"joint_{index}", "revolute", f"link_{parent}", name, origin, axis, 0.0,
                      math.radians(amount))], []
    if joint.type == JointType.CONTINUOUS:
        return [Joint(f"joint_{index}", "continuous", f"link_{parent}", name, origin, axis, 0.0,
                      2 * math.pi, has_limits=False)], []
    if joint.type == JointType.PRISMATIC:
        return [Joint(f"joint_{index}", "prismatic", f"link_{parent}", name, origin, axis, 0.0, amount)], []
    helper = f"{name}_helper"  # screw: slide, then turn about the same axis
    return ([Joint(f"joint_{index}", "prismatic", f"link_{parent}", helper, origin, axis, 0.0, amount),
             Joint(f"joint_{index}_turn", "continuous", helper, name, np.eye(4), axis, 0.0, 2 * math.pi,
                   has_limits=False)],
            [Link(helper)])


def build_asset(nodes: list[dict], root: int, joints: dict[int, NodeJoint],
                meshes: dict[int, list[tuple[trimesh.Trimesh, str]]], name: str) -> ArticulatedAsset:
    """The object in our frame: link ``link_<id>`` per node, its frame at its joint's axis point (its
    parent's frame for a fixed joint), meshes moved into it.

    :param nodes: the checked nodes
    :param root: the root's index
    :param joints: each non-root node's joint
    :param meshes: each node's ``(mesh, file as listed)``, object frame as written
    :param name: the asset's name
    """
    positions: dict[int, np.ndarray] = {}
    links: dict[str, Link] = {}
    all_joints: dict[str, Joint] = {}
    for index in _order(nodes, root):
        joint = joints.get(index)
        if index == root:
            positions[index] = np.zeros(3)
        elif joint.type == JointType.FIXED:
            positions[index] = positions[nodes[index]["parent"]]
        else:
            positions[index] = RAW_TO_OURS @ joint.origin
        if index != root:
            made, helpers = _joints_of(index, nodes, joint, positions)
            links.update({h.name: h for h in helpers})  # a helper comes before its child
            all_joints.update({j.name: j for j in made})
        visuals = [Visual(trimesh.Trimesh(mesh.vertices @ RAW_TO_OURS.T - positions[index], mesh.faces,
                                          process=False), source=source) for mesh, source in meshes[index]]
        label = nodes[index].get("name")
        links[f"link_{index}"] = Link(f"link_{index}", visuals=visuals, label=label if isinstance(label, str)
                                      else "")
    return ArticulatedAsset(name=name, links=links, joints=all_joints)


# ----- the reader -----------------------------------------------------------------------------------------
def read_run(run_dir: Path) -> ForeignObject:
    """One SINGAPO / DIPO / CAGE output folder, read into our frame (see the module docstring).

    :param run_dir: the folder holding ``object.json`` and ``plys/`` (or the sample folders ``0/``...)
    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    json_path, sample = find_object_json(run_dir)
    nodes, meta = load_tree(json_path)
    root = check_tree(nodes, json_path)
    joints = {i: read_joint(node, i, json_path) for i, node in enumerate(nodes) if i != root}
    check_degrees(joints, json_path)
    meshes, files = {}, [str(json_path.relative_to(run_dir))]
    for index, node in enumerate(nodes):
        loaded, used = part_meshes(node, index, json_path, run_dir)
        meshes[index] = list(zip(loaded, node["plys"]))
        files.extend(used)
    asset = build_asset(nodes, root, joints, meshes, run_dir.name)
    category = meta.get("obj_cat")
    asset.category = category if isinstance(category, str) else ""
    asset.source = str(json_path)
    facts = list(FACTS)
    root_joint = nodes[root].get("joint")
    root_type = root_joint.get("type") if isinstance(root_joint, dict) else None
    if root_type not in (None, "fixed"):
        facts.append({"fact": f"the root's joint ({root_type}) is ignored: the root has no parent",
                      "source": f"{SINGAPO} data/utils.py parse_tree (only the base is forced fixed)"})
    flipped = [i for i, j in joints.items() if j.type != JointType.FIXED and j.amount < 0]
    if flipped:
        facts.append({"fact": f"negative ranges (nodes {flipped}) read as the negated axis with range [0, |r|]",
                      "source": f"{SINGAPO} objects/motions.py (motion = r * direction; same motion)"})
    record = {"format": FORMAT, "files": files, "facts": facts, "object_json": files[0], "sample": sample,
              "format_frame": "PartNet-Mobility raw: Y up, front +Z", "not_read": ["object.ply (all parts merged)"],
              "joints": [{"node": i, "type": j.type, "range_written": j.amount,
                          "unit": "deg" if j.type == JointType.REVOLUTE else ("none" if j.type in (JointType.FIXED, JointType.CONTINUOUS)
                                                                       else "object length")}
                         for i, j in sorted(joints.items())]}
    return ForeignObject(asset, record, articulated=True, open_questions=("scale",))
