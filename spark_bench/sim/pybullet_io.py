"""The same object in PyBullet: a URDF that references the very collision hulls of the MJCF.

Each hull is its own ``<collision>`` with its own OBJ (PyBullet takes one convex hull per mesh file
of a moving link, so one file per hull keeps the decomposition); primitives stay primitives. Inertials
are the MJCF's. The URDF is written beside ``model.xml`` and shares its ``meshes/`` folder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh import drop_degenerate_faces
from spark_bench.asset.transforms import matrix_to_rpy
from spark_bench.sim.mjcf import write_obj_file
from spark_bench.sim.physical import principal_inertia
from spark_bench.sim.prepared import PreparedObject
from spark_bench.sim.shapes import CollisionShape

MESH_DIR = "meshes"


def _origin(parent: ET.Element, transform: np.ndarray) -> None:
    xyz = " ".join(f"{v:.9g}" for v in transform[:3, 3])
    rpy = " ".join(f"{v:.9g}" for v in matrix_to_rpy(transform[:3, :3]))
    ET.SubElement(parent, "origin", xyz=xyz, rpy=rpy)


def _write_mesh(folder: Path, name: str, vertices, faces) -> str | None:
    cleaned = drop_degenerate_faces(vertices, faces)
    if cleaned is None:
        return None
    path = folder / MESH_DIR / f"{name}.obj"
    if not path.is_file():  # model.xml and model.urdf share their meshes
        write_obj_file(path, *cleaned)
    return f"{MESH_DIR}/{name}.obj"


def write_pybullet_urdf(prepared: PreparedObject, folder: Path, filename: str = "model.urdf",
                        visuals: bool = True,
                        collisions: dict[str, list[tuple[str, CollisionShape]]] | None = None) -> Path:
    """Write a URDF whose collisions are the prepared hulls (one OBJ each) into ``folder``.

    :param prepared: output of :func:`spark_bench.sim.mjcf.prepare`
    :param folder: output folder (``meshes/`` is created inside)
    :param filename: URDF file name
    :param visuals: write the visual meshes too (the ``pybullet_loads`` check counts joints and
        collision shapes only, and skips them)
    :param collisions: per link, the collision shapes to write instead of the prepared hulls, each with its name
        (its ``<collision>``'s and its OBJ file's; a name of the MJCF's hulls shares its file); default: the
        prepared hulls, named ``<link>_collision_<k>``
    """
    folder = Path(folder)
    (folder / MESH_DIR).mkdir(parents=True, exist_ok=True)
    asset = prepared.asset
    robot = ET.Element("robot", name=asset.name or "object")
    for name in asset.links:
        element = ET.SubElement(robot, "link", name=name)
        props = prepared.mass[name]
        moments, axes = principal_inertia(props.inertia)
        inertial = ET.SubElement(element, "inertial")
        frame = np.eye(4)
        frame[:3, :3], frame[:3, 3] = axes, props.com
        _origin(inertial, frame)
        ET.SubElement(inertial, "mass", value=f"{props.mass:.9g}")
        ET.SubElement(inertial, "inertia", ixx=f"{moments[0]:.9g}", iyy=f"{moments[1]:.9g}",
                      izz=f"{moments[2]:.9g}", ixy="0", ixz="0", iyz="0")
        visual = prepared.visual(name) if visuals else None
        if visual is not None:
            rel = _write_mesh(folder, f"{name}_visual", visual[0], visual[1])
            if rel is not None:
                vis = ET.SubElement(element, "visual")
                ET.SubElement(ET.SubElement(vis, "geometry"), "mesh", filename=rel)
                material = ET.SubElement(vis, "material", name=f"{name}_material")
                ET.SubElement(material, "color", rgba=" ".join(f"{c:.4g}" for c in visual[2]))
        named = (collisions.get(name, []) if collisions is not None else
                 [(f"{name}_collision_{k}", shape) for k, shape in enumerate(prepared.shapes.get(name, []))])
        for col_name, shape in named:
            col = ET.Element("collision", name=col_name)
            geometry = ET.Element("geometry")
            if shape.kind == "box":
                ET.SubElement(geometry, "box", size=" ".join(f"{v:.9g}" for v in shape.size))
            elif shape.kind == "cylinder":
                ET.SubElement(geometry, "cylinder", radius=f"{shape.size[0]:.9g}", length=f"{shape.size[1]:.9g}")
            elif shape.kind == "sphere":
                ET.SubElement(geometry, "sphere", radius=f"{shape.size[0]:.9g}")
            else:
                rel = _write_mesh(folder, col_name, shape.vertices, shape.faces)
                if rel is None:
                    continue
                ET.SubElement(geometry, "mesh", filename=rel)
            if shape.kind != "mesh":
                _origin(col, shape.origin)
            col.append(geometry)
            element.append(col)
    for joint in asset.joints.values():
        element = ET.SubElement(robot, "joint", name=joint.name, type=joint.type)
        _origin(element, joint.origin)
        ET.SubElement(element, "parent", link=joint.parent)
        ET.SubElement(element, "child", link=joint.child)
        if joint.is_movable:
            ET.SubElement(element, "axis", xyz=" ".join(f"{v:.9g}" for v in joint.axis))
            dyn = prepared.dynamics[joint.name]
            ET.SubElement(element, "dynamics", damping=f"{dyn.damping:.6g}", friction=f"{dyn.frictionloss:.6g}")
        if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            ET.SubElement(element, "limit", lower=f"{joint.lower:.9g}", upper=f"{joint.upper:.9g}",
                          effort="1000", velocity="10")
    ET.indent(robot)
    out = folder / filename
    ET.ElementTree(robot).write(out, encoding="unicode", xml_declaration=False)
    return out


@dataclass
class PybulletLoad:
    """What PyBullet made of a URDF: joints and collision shapes per link."""

    loaded: bool
    n_joints: int = 0
    collision_shapes: dict[str, int] = field(default_factory=dict)
    error: str = ""


def load_in_pybullet(urdf: Path) -> PybulletLoad:
    """Load ``urdf`` in a fresh PyBullet ``DIRECT`` client with a fixed base and count what it built.

    :param urdf: a URDF written by :func:`write_pybullet_urdf`
    """
    import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    try:
        try:
            body = pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client,
                                     flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        except pybullet.error as exc:
            return PybulletLoad(False, error=str(exc))
        n_joints = pybullet.getNumJoints(body, physicsClientId=client)
        names = {-1: pybullet.getBodyInfo(body, physicsClientId=client)[0].decode()}
        for index in range(n_joints):
            names[index] = pybullet.getJointInfo(body, index, physicsClientId=client)[12].decode()
        shapes = {}
        for index, name in names.items():
            data = pybullet.getCollisionShapeData(body, index, physicsClientId=client)
            shapes[name] = len(data)
        return PybulletLoad(True, n_joints, shapes)
    finally:
        pybullet.disconnect(client)
