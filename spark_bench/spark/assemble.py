"""Assemble a coarse URDF and part meshes into an :class:`ArticulatedAsset`, and edit its joints.

The assembled asset has the PartNet-Mobility layout (DESIGN.md): a ``base`` link without geometry, a
fixed root joint turning the object frame into the world frame (:data:`OBJECT_TO_WORLD`), the prior's
root link (the static body), and one link per prior link. Every link frame is the object frame
translated to the link's joint pivot, so each joint origin is a pure translation and each joint axis,
given in the joint frame, is also its object-frame direction (a canonical one for the prior).
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import invert_transform, make_transform, transform_points
from spark_bench.errors import InputError
from spark_bench.spark.geometry import PartGeometry
from spark_bench.spark.structure import OBJECT_TO_WORLD, PriorStructure

BASE = "base"
SEMANTIC_WORD = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slider", "fixed": "static"}


def _link_positions(prior: PriorStructure) -> dict[str, np.ndarray]:
    """Object-frame position of every prior link's frame: its joint's pivot (0 for the root)."""
    out = {prior.root: np.zeros(3)}
    for joint in prior.joints:
        out[joint.child] = np.asarray(joint.origin, dtype=float)
    return out


def assemble_asset(prior: PriorStructure, geometry: PartGeometry, name: str = "ours",
                   category: str = "") -> ArticulatedAsset:
    """The articulated asset of a coarse URDF with rest-pose part meshes (benchmark frame).

    :param prior: links and joints, object frame
    :param geometry: part meshes by link name, world frame at rest; prior links without a mesh get none
    :param name: the asset's name
    :param category: object category, for ``meta.json``
    :raises InputError: when a link is called ``base`` (reserved) or a mesh has no prior link
    """
    names = {link.name for link in prior.links}
    if BASE in names:
        raise InputError(None, f"prior link name {BASE!r} is reserved for the world link")
    missing = set(geometry.meshes) - names
    if missing:
        raise InputError(geometry.source or None, f"part meshes {sorted(missing)} have no link in the prior")
    position = _link_positions(prior)
    world_to_object = OBJECT_TO_WORLD.T
    links = {BASE: Link(BASE)}
    for plink in prior.links:
        link = Link(plink.name, label=plink.label)
        mesh = geometry.meshes.get(plink.name)
        if mesh is not None and len(mesh.faces):
            local = transform_points(make_transform(world_to_object), mesh.vertices) - position[plink.name]
            link.visuals.append(Visual(mesh=_trimesh(local, mesh.faces)))
        links[plink.name] = link
    joints: dict[str, Joint] = {}
    root_joint = f"joint_{len(prior.joints)}"
    if root_joint in {j.name for j in prior.joints}:
        root_joint = "joint_root"
    joints[root_joint] = Joint(root_joint, "fixed", BASE, prior.root, origin=make_transform(OBJECT_TO_WORLD))
    for pj in prior.joints:
        origin = make_transform(translation=position[pj.child] - position[pj.parent])
        joints[pj.name] = Joint(pj.name, pj.type, pj.parent, pj.child, origin=origin,
                                axis=pj.axis_vector.copy(), lower=0.0, upper=float(pj.upper))
        links[pj.child].semantic_joint = SEMANTIC_WORD[pj.type]
    links[prior.root].semantic_joint = "static"
    ordered = {BASE: links[BASE], **{n: links[n] for n in links if n != BASE}}
    return ArticulatedAsset(name=name, links=ordered, joints=joints, category=category,
                            meta={"model_cat": category, "generator": "spark-bench ours"})


def _trimesh(vertices, faces):
    import trimesh

    return trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)


def apply_pivot_offset(asset: ArticulatedAsset, joint_name: str, offset) -> None:
    """Move a joint's axis line by ``offset`` (parent frame) in place, keeping every rest pose.

    The joint origin's translation gains ``offset``; the child's frame moves with it, so the child's
    meshes, collision shapes and outgoing joint origins are re-expressed by ``inv(O') @ O``. This is the
    URDF form of :func:`spark_bench.asset.torch_fk.link_poses_torch`'s ``pivot_offsets``.
    """
    joint = asset.joints[joint_name]
    old = joint.origin.copy()
    new = old.copy()
    new[:3, 3] = new[:3, 3] + np.asarray(offset, dtype=float)
    correction = invert_transform(new) @ old
    joint.origin = new
    child = asset.links[joint.child]
    for visual in child.visuals:
        visual.mesh = _trimesh(transform_points(correction, visual.mesh.vertices), visual.mesh.faces)
    for col in child.collisions:
        col.origin = correction @ col.origin  # collision meshes live in their geom frame
    for other in asset.joints.values():
        if other.parent == joint.child:
            other.origin = correction @ other.origin


def set_joint(asset: ArticulatedAsset, joint_name: str, joint_type: str, axis, upper: float) -> None:
    """Give a joint a new type, axis (joint frame, normalized here) and limits ``[0, upper]``, in place."""
    joint = asset.joints[joint_name]
    axis = np.asarray(axis, dtype=float)
    joint.type = joint_type
    joint.axis = axis / np.linalg.norm(axis)
    joint.lower = 0.0
    joint.upper = float(upper) if joint_type != "fixed" else 0.0
    asset.links[joint.child].semantic_joint = SEMANTIC_WORD[joint_type]


def joint_summary(asset: ArticulatedAsset, joint_names: list[str] | None = None) -> list[dict]:
    """World-frame (benchmark) description of joints at rest, in case.json's form, for reports."""
    poses = asset.link_poses()
    out = []
    for joint in asset.joints.values():
        if joint_names is not None and joint.name not in joint_names:
            continue
        if joint_names is None and joint.parent == BASE:
            continue
        frame = poses[joint.parent] @ joint.origin
        direction = frame[:3, :3] @ joint.axis
        out.append({"name": joint.name, "type": joint.type, "parent": joint.parent, "child": joint.child,
                    "axis": np.round(direction / np.linalg.norm(direction), 10).tolist(),
                    "origin": np.round(frame[:3, 3], 10).tolist(),
                    "lower": float(joint.lower), "upper": float(joint.upper)})
    return out
