"""Small articulated assets built in code, for tests of every module."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.asset.transforms import make_transform


def box_visual(extents, center=(0.0, 0.0, 0.0), rgba=(0.6, 0.5, 0.4, 1.0)) -> Visual:
    mesh = trimesh.creation.box(extents=extents, transform=make_transform(translation=center))
    return Visual(mesh=mesh, rgba=rgba)


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
