"""FreeArt3D: one articulated object as ``sds_output/joint_info.json`` and ``sds_output/part_meshes/``
(GLB), read as FreeArt3D's code writes them.

Read from ``PeterZs/FreeArt3D`` (the only public copy found in the index: a mirror of the SIGGRAPH Asia
2025 code its README describes; ``czzzzh/FreeArt3D`` is not in it). The facts, each with where it comes
from:

**Layout.** ``run_two_parts.py`` and ``run_multi_parts.py`` write ``outputs/<name>/`` (the run folder):
``pipelines/sds.py`` ``recon`` writes ``sds_output/joint_info.json``, ``sds_output/part_meshes/fixed.glb``
(the base), ``sds_output/part_meshes/articulated_<i:02d>.glb`` (joint ``i``'s part, only when its mesh
is not None) and ``sds_output/states/qpos_<k:02d>.glb`` (the whole object at six states); then
``pipelines/urdf.py`` ``write_urdf`` writes ``output.urdf``. The reader takes the run folder, or the
``sds_output/`` folder itself. Every part hangs from the base (``write_urdf``: one joint per part,
parent ``base_link``).

**joint_info.json** (``recon``): a list, one entry per joint in part order: ``{"type": "prismatic" |
"revolute", "range": [0, s], "axis": {"origin": [x, y, z], "direction": [x, y, z]}}``; ``s`` is the
learned ``transform_scale``: **radians** for a revolute joint (``recon`` turns the mesh by ``cos(qpos)``,
``qpos = s * j / 5``; ``write_urdf``'s docstring: "For revolute: radians about axis"), a length in
TRELLIS's unit cube for a prismatic one. ``origin`` is a point on the axis for a revolute joint (the
learned pivot, ``joint_position / 63 - 0.5``) and ``[0, 0, 0]`` for a prismatic one. A revolute ``s``
beyond 2 pi (degrees written where radians are meant), a NaN or zero axis, a range not starting at 0 or
any other type is an :class:`InputError`.

**Frames.** ``joint_info.json`` is in TRELLIS's voxel frame (Z up, the object in [-0.5, 0.5]^3). The
GLB meshes are that frame turned Y up by TRELLIS's ``to_glb`` (``trellis/utils/postprocessing_utils.py``:
``vertices @ [[1, 0, 0], [0, 0, -1], [0, 1, 0]]``, so a mesh point is ``(x, z, -y)``); FreeArt3D's own
evaluation maps the joints onto the meshes the same way (``eval_utils/joints.py`` ``Joint``, ``method ==
'ours'``: ``(x, z, -y)``), and so does ``write_urdf``. The reader turns the meshes back
(:data:`GLB_TO_TRELLIS`) and keeps the joints as written: Z up is ours; the turn about Z (the view) and
the scale stay open.

**Which state the meshes are in.** ``recon`` reconstructs the parts at the last input state
(``idx = train_num_state - 1``, image ``rendering_joint_00_state_05``): the open one (the examples'
``05.png`` shows the drawer out, ``00.png`` closed). From there, ``recon``'s state export turns a
revolute part by ``+s`` about ``direction`` through ``origin`` to close it (``states/qpos_00.glb``), and
``train`` slides the grid of a prismatic part by ``qpos * axis`` in reversed (z, y, x) grid coordinates
(``pipelines/utils/transforms.py`` ``GridTransformer.translate_grid``; ``hash_grid.py``
``generate_image_grid_3d``), with ``direction = -axis`` reversed: the closed part is the mesh moved by
``-s * direction``. The reader moves each part to its closed state and gives the joint the limits
``[0, |s|]`` with the axis that opens it (``-sign(s) * direction`` for a revolute joint, ``sign(s) *
direction`` for a prismatic one). For a prismatic joint along TRELLIS's Y this agrees with ``recon``'s
state export and with ``output.urdf``; along X or Z those two disagree with ``train`` (``recon`` slides
by the unreversed axis; ``write_urdf`` takes the absolute value of each axis component), and ``train``,
the motion the parts were fitted with, is the one followed.

**Why joint_info.json and not output.urdf**: ``write_urdf`` builds ``output.urdf`` from
``joint_info.json`` and the same GLBs, adding nothing (no inertials), but takes the absolute value of a
prismatic axis and writes the limits ``lower = s, upper = 0``, an upper limit below the lower one when
``s > 0`` (URDF readers, ours included, refuse it). ``output.urdf`` is noted, not read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject, axis_line

FORMAT = "freeart3d"
SDS_DIR = "sds_output"
JOINT_INFO = "joint_info.json"
PART_DIR = "part_meshes"
BASE_MESH = "fixed.glb"
URDF = "output.urdf"
JOINT_TYPES = ("prismatic", "revolute")
#: The matrix TRELLIS's ``to_glb`` multiplies row vertices by (``v_glb = v @ TO_GLB_ROWS``: Z up -> Y up).
TO_GLB_ROWS = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
#: Its inverse as a rotation of column vectors: ``v = GLB_TO_TRELLIS @ v_glb`` (``v_glb @ TO_GLB_ROWS.T``).
GLB_TO_TRELLIS = TO_GLB_ROWS
RANGE_TOL = 1e-9

REPO = "PeterZs/FreeArt3D"
FACTS = [
    {"fact": "sds_output/joint_info.json: list of {type prismatic|revolute, range [0, s], axis {origin, "
             "direction}}, one per part articulated_<i:02d>.glb; fixed.glb is the base",
     "source": f"{REPO} pipelines/sds.py recon"},
    {"fact": "every part hangs from the base", "source": f"{REPO} pipelines/urdf.py write_urdf"},
    {"fact": "revolute s in radians; prismatic s in TRELLIS unit-cube lengths; revolute origin = pivot "
             "(joint_position / 63 - 0.5), prismatic origin [0, 0, 0]",
     "source": f"{REPO} pipelines/sds.py recon; pipelines/urdf.py write_urdf docstring"},
    {"fact": "joints in TRELLIS's Z-up voxel frame; GLB meshes Y up: glb = (x, z, -y), turned back here",
     "source": f"{REPO} TRELLIS/trellis/utils/postprocessing_utils.py to_glb; eval_utils/joints.py Joint "
               "(method 'ours'); pipelines/urdf.py write_urdf"},
    {"fact": "the part meshes are at the last (open) input state; closed: revolute part turned by +s about "
             "direction through origin, prismatic part moved by -s * direction; limits [0, |s|]",
     "source": f"{REPO} pipelines/sds.py recon (idx = train_num_state - 1, state export), train; "
               "pipelines/utils/transforms.py GridTransformer; examples/cabinet/00.png, 05.png"},
    {"fact": "output.urdf not read: built from joint_info.json by write_urdf with |axis| for prismatic "
             "joints and limits lower = s, upper = 0 (invalid when s > 0), no inertials",
     "source": f"{REPO} pipelines/urdf.py write_urdf"},
]


@dataclass
class PartJoint:
    """One entry of ``joint_info.json``, checked (TRELLIS's frame).

    :param type: ``prismatic`` or ``revolute``
    :param origin: a point on the axis (zeros for a prismatic joint)
    :param direction: unit direction as written
    :param scale: ``range[1]``, the learned ``transform_scale`` (radians or unit-cube length)
    """

    type: str
    origin: np.ndarray
    direction: np.ndarray
    scale: float


def find_sds_dir(run_dir: Path) -> Path:
    """The ``sds_output/`` folder of a run (or the run folder itself when it is one).

    :raises InputError: when neither holds ``joint_info.json``
    """
    for folder in (run_dir / SDS_DIR, run_dir):
        if (folder / JOINT_INFO).is_file():
            return folder
    raise InputError(run_dir / SDS_DIR / JOINT_INFO, "no FreeArt3D joint_info.json (pipelines/sds.py recon "
                                                     "did not run or failed)")


def read_joint(entry, index: int, path: Path) -> PartJoint:
    """Entry ``index`` of ``joint_info.json``, checked (see the module docstring).

    :raises InputError: naming the joint and the problem
    """
    if not isinstance(entry, dict):
        raise InputError(path, f"joint {index} is not an object")
    kind = entry.get("type")
    if kind not in JOINT_TYPES:
        raise InputError(path, f"joint {index}: type {kind!r} is not prismatic or revolute")
    span = entry.get("range")
    try:
        lo, hi = (float(v) for v in span)
    except (TypeError, ValueError):
        raise InputError(path, f"joint {index}: range is not two numbers: {span!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(path, f"joint {index}: range {span!r} is not finite")
    if abs(lo) > RANGE_TOL:
        raise InputError(path, f"joint {index}: range starts at {lo}, not 0 (recon writes [0, transform_scale])")
    if kind == JointType.REVOLUTE and abs(hi) > 2 * math.pi + 1e-9:
        raise InputError(path, f"joint {index}: revolute range {hi} is beyond 2 pi: FreeArt3D writes radians "
                               "(looks like degrees)")
    origin, direction = axis_line(entry.get("axis"), path, f"joint {index}:")
    return PartJoint(kind, origin, direction, hi)


def load_joints(path: Path) -> list[PartJoint]:
    """The joints of ``joint_info.json``.

    :raises InputError: when it is not JSON, not a non-empty list, or an entry is bad
    """
    data = read_json(path)
    if not isinstance(data, list) or not data:
        raise InputError(path, "not FreeArt3D's joint_info: expected a non-empty list of joints")
    return [read_joint(entry, i, path) for i, entry in enumerate(data)]


def load_part(path: Path, what: str) -> trimesh.Trimesh:
    """A part GLB in TRELLIS's frame (Z up).

    :raises InputError: when it is missing or cannot be read
    """
    from spark_bench.asset.urdf import load_mesh_file

    if not path.is_file():
        raise InputError(path, f"{what} mesh file is missing (pipelines/sds.py recon writes none for an empty "
                               "part)")
    mesh, _ = load_mesh_file(path)
    return trimesh.Trimesh(mesh.vertices @ GLB_TO_TRELLIS.T, mesh.faces, process=False)


def closed_part(mesh: trimesh.Trimesh, joint: PartJoint) -> tuple[trimesh.Trimesh, np.ndarray]:
    """``(the part moved from the written (open) state to the closed one, the axis that opens it)``."""
    if joint.type == JointType.REVOLUTE:
        rotation = axis_angle_matrix(joint.direction, joint.scale)
        vertices = (mesh.vertices - joint.origin) @ rotation.T + joint.origin
        axis = -math.copysign(1.0, joint.scale) * joint.direction
    else:
        vertices = mesh.vertices - joint.scale * joint.direction
        axis = math.copysign(1.0, joint.scale) * joint.direction
    return trimesh.Trimesh(vertices, mesh.faces, process=False), axis


def build_asset(base: trimesh.Trimesh, parts: list[trimesh.Trimesh], joints: list[PartJoint],
                sources: list[str], name: str) -> ArticulatedAsset:
    """The object: ``base`` (``fixed.glb``) and a link per part, each hanging from the base by its joint,
    its frame at the joint's origin, closed at rest and open at the upper limit ``|s|``.

    :param sources: the mesh files, relative to the run folder: the base's first
    """
    links = {"base": Link("base", [Visual(base, source=sources[0])], label="base")}
    out_joints = {}
    for index, (mesh, joint) in enumerate(zip(parts, joints)):
        closed, axis = closed_part(mesh, joint)
        frame = np.eye(4)
        frame[:3, 3] = joint.origin
        local = trimesh.Trimesh(closed.vertices - joint.origin, closed.faces, process=False)
        links[f"link_{index}"] = Link(f"link_{index}", [Visual(local, source=sources[index + 1])],
                                      label=f"articulated_{index:02d}")
        out_joints[f"joint_{index}"] = Joint(f"joint_{index}", joint.type, "base", f"link_{index}", frame, axis,
                                             0.0, abs(joint.scale))
    return ArticulatedAsset(name=name, links=links, joints=out_joints)


def read_run(run_dir: Path) -> ForeignObject:
    """One FreeArt3D output folder (``outputs/<name>/``), read into our frame (see the module docstring).

    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    sds = find_sds_dir(run_dir)
    info = sds / JOINT_INFO
    joints = load_joints(info)
    names = [BASE_MESH] + [f"articulated_{i:02d}.glb" for i in range(len(joints))]
    paths = [sds / PART_DIR / n for n in names]
    meshes = [load_part(p, "the base" if i == 0 else f"joint {i - 1}'s part") for i, p in enumerate(paths)]
    files = [str(p.relative_to(run_dir)) for p in [info, *paths]]
    asset = build_asset(meshes[0], meshes[1:], joints, files[1:], run_dir.name)
    asset.source = str(info)
    unlisted = sorted(p.name for p in (sds / PART_DIR).glob("articulated_*.glb") if p.name not in names)
    record = {"format": FORMAT, "files": files, "facts": list(FACTS),
              "format_frame": "TRELLIS voxel frame: Z up, unit cube [-0.5, 0.5]^3 (GLB meshes Y up, turned back)",
              "joints": [{"index": i, "type": j.type, "range_written": j.scale,
                          "unit": "rad" if j.type == JointType.REVOLUTE else "TRELLIS unit cube"}
                         for i, j in enumerate(joints)],
              "not_read": [f"{URDF} (present; see facts)" if (run_dir / URDF).is_file() else f"{URDF} (absent)",
                           "sds_output/states/ (the same parts posed)"] + [f"{n} (no joint lists it)"
                                                                             for n in unlisted]}
    return ForeignObject(asset, record, articulated=True, open_questions=("yaw", "scale"))
