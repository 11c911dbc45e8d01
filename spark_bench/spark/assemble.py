"""Assemble a coarse URDF and part meshes into an :class:`ArticulatedAsset`, and edit its joints.

The assembled asset has the PartNet-Mobility layout (DESIGN.md): a ``base`` link without geometry, a
fixed root joint turning the object frame into the world frame (:data:`OBJECT_TO_WORLD`), the prior's
root link (the static body), and one link per prior link. When the prior itself calls a link ``base``
(objects whose root link carries the body mesh, e.g. :func:`spark_bench.envs.cabinet.procedural_cabinet`,
whose part names a VLM is told to reuse), the world link takes the first free name of
:data:`WORLD_NAMES` instead, so every prior link keeps its name. Every link frame is the object frame
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
#: Names for the world link, in order of preference: the first one the prior does not use.
WORLD_NAMES = (BASE, "world", "base_world")
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
    :param geometry: part meshes by link name, world frame at rest; prior links without a mesh get none.
        The geometry's root part (:attr:`PartGeometry.root`) goes to the prior's root link when the prior
        has no link of its name (e.g. a generated object whose ``base`` link carries the body)
    :param name: the asset's name
    :param category: object category, for ``meta.json``
    :raises InputError: when a mesh has no prior link
    """
    names = [link.name for link in prior.links]
    meshes = _meshes_by_prior_link(prior, geometry)
    position = _link_positions(prior)
    world_to_object = OBJECT_TO_WORLD.T
    world = world_link_name(names)
    links = {world: Link(world)}
    for plink in prior.links:
        link = Link(plink.name, label=plink.label)
        mesh = meshes.get(plink.name)
        if mesh is not None and len(mesh.faces):
            local = transform_points(make_transform(world_to_object), mesh.vertices) - position[plink.name]
            link.visuals.append(Visual(mesh=_trimesh(local, mesh.faces)))
        links[plink.name] = link
    joints: dict[str, Joint] = {}
    root_joint = f"joint_{len(prior.joints)}"
    if root_joint in {j.name for j in prior.joints}:
        root_joint = "joint_root"
    joints[root_joint] = Joint(root_joint, "fixed", world, prior.root, origin=make_transform(OBJECT_TO_WORLD))
    for pj in prior.joints:
        origin = make_transform(translation=position[pj.child] - position[pj.parent])
        joints[pj.name] = Joint(pj.name, pj.type, pj.parent, pj.child, origin=origin,
                                axis=pj.axis_vector.copy(), lower=0.0, upper=float(pj.upper))
        links[pj.child].semantic_joint = SEMANTIC_WORD[pj.type]
    links[prior.root].semantic_joint = "static"
    return ArticulatedAsset(name=name, links=links, joints=joints, category=category,
                            meta={"model_cat": category, "generator": "spark-bench ours"})


def world_link_name(prior_links) -> str:
    """The world link's name: ``base`` unless the prior uses it (see the module docstring)."""
    taken = set(prior_links)
    return next(n for n in (*WORLD_NAMES, *(f"world_{k}" for k in range(len(taken) + 1))) if n not in taken)


def _meshes_by_prior_link(prior: PriorStructure, geometry: PartGeometry) -> dict:
    """``geometry.meshes`` keyed by prior link; the root part may be renamed to the prior's root."""
    names = {link.name for link in prior.links}
    meshes = dict(geometry.meshes)
    root_part = geometry.root
    if root_part and root_part in meshes and root_part not in names and prior.root not in meshes:
        meshes[prior.root] = meshes.pop(root_part)
    missing = set(meshes) - names
    if missing:
        raise InputError(geometry.source or None, f"part meshes {sorted(missing)} have no link in the prior "
                                                  f"(its links: {sorted(names)})")
    return meshes


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
    """World-frame (benchmark) description of joints at rest, in case.json's form, for reports.

    :param joint_names: the joints to describe (default: all but the root joint, the one hanging from
        a world link without geometry)
    """
    poses = asset.link_poses()
    world = None if asset.links[asset.root].has_geometry else asset.root
    out = []
    for joint in asset.joints.values():
        if joint_names is not None and joint.name not in joint_names:
            continue
        if joint_names is None and joint.parent == world:
            continue
        frame = poses[joint.parent] @ joint.origin
        direction = frame[:3, :3] @ joint.axis
        out.append({"name": joint.name, "type": joint.type, "parent": joint.parent, "child": joint.child,
                    "axis": np.round(direction / np.linalg.norm(direction), 10).tolist(),
                    "origin": np.round(frame[:3, 3], 10).tolist(),
                    "lower": float(joint.lower), "upper": float(joint.upper)})
    return out
