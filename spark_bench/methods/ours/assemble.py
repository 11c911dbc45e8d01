"""Assemble a coarse URDF and part meshes into an :class:`ArticulatedAsset`, and edit its joints.

The assembled asset has the PartNet-Mobility layout (docs/conventions.md, "Object folders"): a ``base`` link without geometry, a
fixed root joint turning the object frame into the world frame (:data:`OBJECT_TO_WORLD`), the prior's
root link (the static body), and one link per prior link. When the prior itself calls a link ``base``
(objects whose root link carries the body mesh, e.g. :func:`spark_bench.envs.cabinet.procedural_cabinet`,
whose part names a VLM is told to reuse), the world link takes the first free name of
:data:`WORLD_NAMES` instead, so every prior link keeps its name. Every link frame is the object frame
translated to the link's joint pivot, so each joint origin is a pure translation and each joint axis,
given in the joint frame, is also its object-frame direction (a canonical one for the prior).

**Which mesh goes to which prior link** (:func:`pair_parts`). The ground truth's own parts
(``annotation`` geometry) carry the ground truth's link names, which an ``annotation`` prior shares and a
``vlm`` or ``file`` prior is told to use; so are a prediction's parts when the pipeline hands their names
to a ``vlm`` or ``file`` prior. In every other case -- SPARK's parts (``link0``, ``link1``...), or a
prediction under an ``annotation`` prior -- names mean nothing across the two, and the parts are paired
by geometry or structure, never by name: the prior's root takes the prediction's root part, and the
prior's other links take the prediction's movable parts by the Hungarian algorithm
(:func:`spark_bench.metrics.matching.match_parts`), on part Chamfer distance when the prior's own part
meshes are at hand (``reference``: the ground truth's parts behind an ``annotation`` prior), else on
:func:`structure_cost` against the prediction's own joints (SPARK's). A part no prior link takes stays
with the prior's root (it does not move); the pairing is recorded in the asset's ``meta``
(``part_pairing``, written to ``meta.json``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh import merge_meshes
from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import invert_transform, make_transform, transform_points
from spark_bench.errors import InputError
from spark_bench.methods.ours.geometry import PartGeometry
from spark_bench.methods.ours.structure import OBJECT_TO_WORLD, PriorJoint, PriorStructure, object_axis

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
                   category: str = "", reference: PartGeometry | None = None,
                   axis_frame: np.ndarray | None = None) -> ArticulatedAsset:
    """The articulated asset of a coarse URDF with rest-pose part meshes (benchmark frame).

    :param prior: links and joints, object frame
    :param geometry: part meshes, world frame at rest, paired with the prior's links by :func:`pair_parts`;
        prior links without a mesh get none
    :param name: the asset's name
    :param category: object category, for ``meta.json``
    :param reference: the prior's own part meshes by prior link (the ground truth's parts behind an
        ``annotation`` prior), to pair a prediction's parts by Chamfer distance
    :param axis_frame: the frame the prior's axis names mean (:func:`~spark_bench.methods.ours.structure.object_axis`;
        None: the object frame)
    :raises InputError: when the prior was told the parts' names and a mesh has no prior link
    """
    names = [link.name for link in prior.links]
    pairing = pair_parts(prior, geometry, reference, axis_frame)
    meshes = pairing.meshes(prior, geometry)
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
                                axis=object_axis(pj.axis, axis_frame), lower=0.0, upper=float(pj.upper))
        links[pj.child].semantic_joint = SEMANTIC_WORD[pj.type]
    links[prior.root].semantic_joint = "static"
    return ArticulatedAsset(name=name, links=links, joints=joints, category=category,
                            meta={"model_cat": category, "generator": "spark-bench ours",
                                  "part_pairing": pairing.to_dict()})


def world_link_name(prior_links) -> str:
    """The world link's name: ``base`` unless the prior uses it (see the module docstring)."""
    taken = set(prior_links)
    return next(n for n in (*WORLD_NAMES, *(f"world_{k}" for k in range(len(taken) + 1))) if n not in taken)


@dataclass
class PartPairing:
    """Which part of the geometry each prior link gets.

    :param pairs: prior link -> geometry part
    :param by: ``names`` (the prior named the parts itself), ``chamfer`` or ``structure``
    :param unpaired: geometry parts no prior link took (they stay with the prior's root)
    :param costs: prior link -> the cost of its pair (``chamfer``, ``structure``)
    """

    pairs: dict[str, str]
    by: str
    unpaired: list[str] = field(default_factory=list)
    costs: dict[str, float] = field(default_factory=dict)

    def meshes(self, prior: PriorStructure, geometry: PartGeometry) -> dict:
        """The geometry's meshes keyed by prior link; unpaired parts merged into the prior's root's."""
        out = {link: geometry.meshes[part] for link, part in self.pairs.items() if part in geometry.meshes}
        extra = [geometry.meshes[p] for p in self.unpaired if p in geometry.meshes]
        if extra:
            out[prior.root] = merge_meshes(([out[prior.root]] if prior.root in out else []) + extra)
        return out

    def to_dict(self) -> dict:
        return {"by": self.by, "pairs": dict(self.pairs), "unpaired": list(self.unpaired),
                "costs": {k: round(float(v), 6) for k, v in self.costs.items()}}


def prior_names_the_parts(prior: PriorStructure, geometry: PartGeometry) -> bool:
    """Whether the prior's link names are the geometry's part names by construction: the ground truth's
    own parts (:attr:`PartGeometry.asset` is None), or a prediction's parts whose names the pipeline
    handed to a ``vlm`` or ``file`` prior (:attr:`PartGeometry.offered_to_prior`), or a retrieved object's
    parts under the prior of the same retrieval (:mod:`spark_bench.methods.ours.retrieved`: both name the
    object's parts alike)."""
    if prior.source == "retrieval":
        return geometry.asset is not None and geometry.source.startswith("retrieval:")
    if geometry.asset is None:
        return True
    return geometry.offered_to_prior and prior.source in ("vlm", "file")


def pair_parts(prior: PriorStructure, geometry: PartGeometry, reference: PartGeometry | None = None,
               axis_frame: np.ndarray | None = None) -> PartPairing:
    """Pair the prior's links with the geometry's parts (see the module docstring).

    :param prior: the coarse URDF
    :param geometry: the part meshes (for ``chamfer`` and ``structure``: with :attr:`PartGeometry.asset`)
    :param reference: the prior's own part meshes by prior link (``chamfer`` pairing), in the geometry's
        frame
    :param axis_frame: the frame the prior's axis names mean (None: the object frame)
    :raises InputError: when the prior named the parts and a mesh has no prior link
    """
    if prior_names_the_parts(prior, geometry):
        return PartPairing(_pairs_by_prior_names(prior, geometry), "names")
    from spark_bench.metrics.matching import match_parts, part_cost_matrix

    movable = [p for p in geometry.parts if p.joint is not None]
    pairs = {prior.root: geometry.root} if geometry.root else {}
    candidates = list(prior.joints)
    by = "structure"
    if reference is not None and all(j.child in reference.meshes for j in candidates):
        by = "chamfer"
        samples = [_samples(reference.meshes[j.child]) for j in candidates]
        cost = part_cost_matrix(samples, [_samples(geometry.meshes.get(p.name)) for p in movable], workers=1)
    else:
        frames = geometry.asset.joint_frames()
        cost = np.array([[structure_cost(j, geometry.meshes.get(p.name), geometry.asset.joints[p.joint].type,
                                         frames[p.joint][1], axis_frame) for p in movable] for j in candidates])
        cost = cost.reshape(len(candidates), len(movable))
    costs = {}
    for pair in match_parts(cost.T):  # rows: the geometry's parts, columns: the prior's joints
        link = candidates[pair.gt].child
        pairs[link] = movable[pair.pred].name
        costs[link] = pair.cost
    taken = set(pairs.values())
    unpaired = [p.name for p in geometry.parts if p.name not in taken and p.name in geometry.meshes]
    return PartPairing(pairs, by, unpaired, costs)


def _samples(mesh, n: int = 2000):
    """Seeded surface samples of a mesh (None without one): the matching's input."""
    from spark_bench.asset.mesh import sample_surface

    if mesh is None or len(mesh.faces) == 0 or not float(mesh.area) > 0:
        return None
    return sample_surface(mesh, n, seed=0)


def structure_cost(joint: PriorJoint, mesh, part_type: str, part_axis, axis_frame: np.ndarray | None = None) -> float:
    """How badly prior joint ``joint`` describes a part of the geometry, in ``[0, 3]``: a different joint
    type costs 1 (revolute and continuous are one type); the axis lines' misalignment ``1 - |cos|`` (0.5
    for a fixed prior joint, which has no axis); and the distance from the prior's origin (a point on its
    axis) to the part's bounding box, clipped to 1 (0 for a prismatic or fixed prior joint, whose origin
    may be anywhere). Both sides must be in one frame (the ``spark`` backend reads SPARK's run with the
    case camera for that).

    :param joint: the prior's joint (object frame)
    :param mesh: the part's rest mesh (benchmark frame); None or empty: ``inf``
    :param part_type: the type of the joint that moves the part in its own object (SPARK's)
    :param part_axis: that joint's axis direction (benchmark frame)
    :param axis_frame: the frame the prior's axis names mean (None: the object frame)
    """
    if mesh is None or len(mesh.faces) == 0:
        return np.inf
    kind = {"continuous": "revolute"}
    cost = 0.0 if kind.get(joint.type, joint.type) == kind.get(part_type, part_type) else 1.0
    if joint.type == JointType.FIXED:
        return cost + 0.5
    axis = OBJECT_TO_WORLD @ object_axis(joint.axis, axis_frame)
    direction = np.asarray(part_axis, dtype=float)
    cost += 1.0 - abs(float(np.dot(axis, direction / np.linalg.norm(direction))))
    if joint.type == JointType.REVOLUTE:
        origin = OBJECT_TO_WORLD @ np.asarray(joint.origin, dtype=float)
        lo, hi = mesh.bounds
        cost += min(1.0, float(np.linalg.norm(origin - np.clip(origin, lo, hi))))
    return cost


def _pairs_by_prior_names(prior: PriorStructure, geometry: PartGeometry) -> dict[str, str]:
    """Prior link -> geometry part, where the prior named the parts itself; the geometry's root part
    goes to the prior's root when the prior has no link of its name (e.g. a generated object whose
    ``base`` link carries the body)."""
    names = {link.name for link in prior.links}
    parts = set(geometry.meshes)
    pairs = {n: n for n in parts & names}
    root_part = geometry.root
    if root_part and root_part in parts and root_part not in names and prior.root not in parts:
        pairs[prior.root] = root_part
    missing = parts - set(pairs.values())
    if missing:
        raise InputError(geometry.source or None, f"part meshes {sorted(missing)} have no link in the prior "
                                                  f"(its links: {sorted(names)})")
    return pairs


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
    joint.upper = float(upper) if joint_type != JointType.FIXED else 0.0
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
