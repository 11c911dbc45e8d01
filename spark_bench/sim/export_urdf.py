"""The sim-ready URDF: the prepared object as one URDF that PyBullet and MuJoCo both load with the same joints.

It is the PyBullet URDF of :func:`spark_bench.sim.pybullet_io.write_pybullet_urdf` (the very collision hulls
of the MJCF, one OBJ each under ``meshes/``; inertials from the documented mass rule,
:mod:`spark_bench.sim.physical`; limits; ``<dynamics damping friction>``) with what a simulator needs to
take it as it is:

- **a fixed base**: a massless link ``world`` welded to the root link. PyBullet makes a base of zero mass
  static; MuJoCo's URDF importer takes a link named ``world`` as its world body (checked with MuJoCo 3.3 and
  PyBullet 3.2.7: the root is welded, the movable joints are the URDF's);
- ``<mujoco><compiler strippath="false"/></mujoco>``: MuJoCo strips a URDF's mesh folders by default
  (``strippath`` is true for URDF), which would lose ``meshes/``; PyBullet ignores the element;
- **hulls PhysX takes as they are** (SAPIEN, ManiSkill3): a hull over PhysX's 255 vertices or 255 polygons
  (a convex mesh the source gave, never CoACD's 64-vertex hulls) is written as the pieces
  :func:`spark_bench.sim.physx.hulls.physx_shapes` splits it into, ``<link>_collision_<k>_<j>``, which cover it
  exactly; PhysX would otherwise cook it into another shape. The other hulls are model.xml's own files.

The armature (MuJoCo's rotor inertia) has no URDF element: it is in ``model.xml`` and the USD only.
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

from spark_bench.asset.transforms import matrix_to_rpy
from spark_bench.sim.mjcf import base_rotation
from spark_bench.sim.physx.hulls import physx_shapes, piece_names
from spark_bench.sim.prepared import PreparedObject
from spark_bench.sim.pybullet_io import write_pybullet_urdf
from spark_bench.sim.shapes import CollisionShape

SIM_URDF = "object.urdf"
WORLD_LINK = "world"


def write_sim_urdf(prepared: PreparedObject, folder: Path, filename: str = SIM_URDF,
                   pieces: dict[str, list[tuple[int, CollisionShape]]] | None = None) -> Path:
    """Write the sim-ready URDF (see the module docstring) into ``folder``; returns its path.

    :param prepared: output of :func:`spark_bench.sim.mjcf.prepare`
    :param folder: output folder (``meshes/`` beside the URDF, shared with ``model.xml``)
    :param filename: the URDF's file name
    :param pieces: the hulls as PhysX takes them (:func:`spark_bench.sim.physx.hulls.physx_shapes`), when the
        caller has them
    """
    pieces = physx_shapes(prepared.shapes)[0] if pieces is None else pieces
    collisions = {link: [(f"{link}_collision_{suffix}", shape)
                         for suffix, (_, shape) in zip(piece_names(found), found)] for link, found in pieces.items()}
    path = write_pybullet_urdf(prepared, Path(folder), filename, visuals=True, collisions=collisions)
    tree = ET.parse(path)
    robot = tree.getroot()
    if WORLD_LINK in prepared.asset.links:  # the object already names its base world: it is the world
        return path
    extension = ET.Element("mujoco")
    ET.SubElement(extension, "compiler", strippath="false", discardvisual="false")
    robot.insert(0, extension)
    robot.insert(1, ET.Element("link", name=WORLD_LINK))
    weld = ET.Element("joint", name=f"{WORLD_LINK}_to_{prepared.asset.root}", type="fixed")
    xyz = " ".join(f"{v:.9g}" for v in prepared.options.base_pos)
    rpy = " ".join(f"{v:.9g}" for v in matrix_to_rpy(base_rotation(prepared.options)))
    ET.SubElement(weld, "origin", xyz=xyz, rpy=rpy)  # where the MJCF puts the root
    ET.SubElement(weld, "parent", link=WORLD_LINK)
    ET.SubElement(weld, "child", link=prepared.asset.root)
    robot.insert(2, weld)
    ET.indent(robot)
    tree.write(path, encoding="unicode", xml_declaration=False)
    return path
