"""Small articulated assets built in code, for tests of every module."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh
from helpers_boxes import box_between, box_mesh, box_visual

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.asset.transforms import make_transform


def tiny_cabinet() -> ArticulatedAsset:
    """A carcass box with a drawer (prismatic along -X, the front) and a door (revolute about +Z).

    World frame directly (no PartNet root rotation): Z up, front towards -X.
    """
    base = Link("base")
    body = Link("body", visuals=[box_visual((0.4, 0.6, 0.8), (0.0, 0.0, 0.4))], label="cabinet_body",
                collisions=[Collision("box", make_transform(translation=(0, 0, 0.4)), np.array([0.4, 0.6, 0.8]))])
    drawer = Link("drawer", visuals=[box_visual((0.05, 0.5, 0.2), (-0.225, 0.0, 0.6))], label="drawer")
    door = Link("door", visuals=[box_visual((0.02, 0.28, 0.4), (-0.21, 0.14, 0.25))], label="door")
    joints = {
        "root": Joint("root", "fixed", "base", "body"),
        "joint_drawer": Joint("joint_drawer", "prismatic", "body", "drawer", axis=np.array([-1.0, 0, 0]),
                              lower=0.0, upper=0.3),
        "joint_door": Joint("joint_door", "revolute", "body", "door",
                            origin=make_transform(translation=(-0.22, -0.0, 0.0)),
                            axis=np.array([0.0, 0.0, 1.0]), lower=0.0, upper=np.pi / 2),
    }
    links = {link.name: link for link in (base, body, drawer, door)}
    return ArticulatedAsset("tiny_cabinet", links, joints, category="StorageFurniture")


def box_cabinet(door_pivot: Sequence[float] = (-0.9, -0.5, 0.0), door_axis: Sequence[float] = (0.0, 0.0, 1.0),
                door_type: str = "revolute", drawer_axis: Sequence[float] = (-1.0, 0.0, 0.0),
                drawer_type: str = "prismatic", door_offset: float = 0.0, handle: bool = False,
                with_drawer: bool = True, annotate: bool = False) -> ArticulatedAsset:
    """A 2x2x2 box (so the benchmark frame is the world frame) with, inside it, a door plate in the plane
    x = -0.9 hinged on a vertical axis at ``door_pivot`` and a drawer box sliding along -x (the metrics'
    hand-worked cabinet). Links ``base``, ``door``, [``handle``], [``drawer``], in that order.

    :param door_pivot: a point of the door's joint line
    :param door_axis: the door's joint direction
    :param door_type: the door's joint type
    :param drawer_axis: the drawer's joint direction
    :param drawer_type: the drawer's joint type
    :param door_offset: the door plate's x offset from its link frame
    :param handle: a handle link fixed to the door (joint ``handle_joint``)
    :param with_drawer: the drawer and its joint are there
    :param annotate: GAPartNet classes on the door, the handle and the drawer (the handle's never a joint's)
    """
    links = {"base": Link("base", [Visual(box_mesh((2.0, 2.0, 2.0)))]),
             "door": Link("door", [Visual(box_mesh((0.0, 1.0, 1.6), (door_offset, 0.5, 0.0)))])}
    joints = {"door_joint": Joint("door_joint", door_type, "base", "door",
                                  make_transform(translation=door_pivot), np.asarray(door_axis, float), 0.0,
                                  math.pi / 2)}
    if handle:
        links["handle"] = Link("handle", [Visual(box_mesh((0.05, 0.05, 0.3), (-0.05, 0.8, 0.0)))])
        joints["handle_joint"] = Joint("handle_joint", "fixed", "door", "handle", np.eye(4),
                                       np.array([1.0, 0.0, 0.0]), 0.0, 0.0)
    if with_drawer:
        links["drawer"] = Link("drawer", [Visual(box_mesh((0.6, 0.6, 0.3), (0.3, 0.0, 0.0)))])
        joints["drawer_joint"] = Joint("drawer_joint", drawer_type, "base", "drawer",
                                       make_transform(translation=(-0.5, 0.2, 0.5)),
                                       np.asarray(drawer_axis, float), 0.0, 0.4)
    if annotate:
        links["door"].annotations = {"is_gapart": True, "category": "hinge_door"}
        if handle:
            links["handle"].annotations = {"is_gapart": True, "category": "line_fixed_handle"}
        if with_drawer:
            links["drawer"].annotations = {"is_gapart": True, "category": "slider_drawer"}
    return ArticulatedAsset("cabinet", links, joints, source="cabinet")


def object_with_door_meshes(folder: Path, files: dict[str, bytes | None], collisions: bool = False) -> Path:
    """The tiny cabinet with the door's visual meshes replaced by ``files`` (None: listed, not written);
    with ``collisions`` the door lists the same files as collision meshes."""
    from spark_bench.asset.urdf import write_object_folder

    write_object_folder(tiny_cabinet(), folder)
    for name, data in files.items():
        if data is not None:
            (folder / "textured_objs" / name).write_bytes(data)
    urdf = folder / "mobility.urdf"
    text = urdf.read_text()
    start = text.index('<link name="door">')
    end = text.index("</link>", start) + len("</link>")
    meshes = "".join(f'<visual><geometry><mesh filename="textured_objs/{n}"/></geometry></visual>'
                     for n in files)
    if collisions:
        meshes += "".join(f'<collision><geometry><mesh filename="textured_objs/{n}"/></geometry></collision>'
                          for n in files)
    urdf.write_text(text[:start] + f'<link name="door">{meshes}</link>' + text[end:])
    return folder


def open_cabinet(door_axis=(0.0, 0.0, 1.0)) -> ArticulatedAsset:
    """A 40 x 60 x 80 cm cabinet body of 2 cm boards, open at the front (-x), and a door closing the opening,
    hinged on its left edge about ``door_axis``. The body is one mesh, the boards' union, and nothing has a
    ``<collision>``: as a prediction carries its parts."""
    boards = [box_between((0.18, -0.3, 0.0), (0.2, 0.3, 0.8)),  # back
              box_between((-0.2, -0.3, 0.0), (0.2, -0.28, 0.8)), box_between((-0.2, 0.28, 0.0), (0.2, 0.3, 0.8)),
              box_between((-0.2, -0.3, 0.0), (0.2, 0.3, 0.02)), box_between((-0.2, -0.3, 0.78), (0.2, 0.3, 0.8))]
    body = trimesh.boolean.union(boards)
    links = {"base": Link("base"), "body": Link("body", [Visual(body)], label="cabinet_body"),
             "door": Link("door", [Visual(box_between((-0.01, 0.0, 0.0), (0.01, 0.6, 0.8)))], label="door")}
    joints = {"root": Joint("root", "fixed", "base", "body"),
              "door_joint": Joint("door_joint", "revolute", "body", "door", make_transform(translation=(-0.21, -0.3, 0.0)),
                                  np.asarray(door_axis, float), 0.0, np.pi / 2)}
    return ArticulatedAsset("open_cabinet", links, joints, category="StorageFurniture")
