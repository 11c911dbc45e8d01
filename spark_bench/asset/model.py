"""The articulated-asset model: links with meshes, joints, and forward kinematics in NumPy.

An :class:`ArticulatedAsset` is plain data: dicts of :class:`Link` and :class:`Joint`, in file order.
Forward kinematics follows URDF: ``T_child = T_parent @ joint.origin @ motion(joint, q)``, where the
motion is a rotation about ``joint.axis`` (revolute, continuous) or a translation along it (prismatic),
both expressed in the joint frame.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import trimesh

from spark_bench.asset.joint_type import MOVABLE_TYPES, JointType, is_movable, is_rotational
from spark_bench.asset.transforms import axis_angle_matrix, transform_points

#: The joint types an asset holds (:class:`~spark_bench.asset.joint_type.JointType`; floating and planar
#: joints are not read).
JOINT_TYPES = (*MOVABLE_TYPES, JointType.FIXED)
#: Opening angle used for the "open" state of a continuous joint, which has no upper limit.
CONTINUOUS_OPEN_ANGLE = np.pi / 2
#: Upper limit assumed for a revolute joint whose URDF has no ``<limit>`` (SPARK appendix: pi).
DEFAULT_REVOLUTE_UPPER = np.pi

Configuration = Mapping[str, float]


@dataclass
class Visual:
    """One visual mesh of a link, with vertices already in the link frame.

    :param mesh: the triangle mesh, in the link frame (the URDF visual origin and scale applied)
    :param rgba: display colour, each channel in [0, 1]
    :param source: the file it was read from, relative to the object folder, if any
    """

    mesh: trimesh.Trimesh
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    source: str | None = None


@dataclass
class Collision:
    """One collision shape of a link: a primitive, or a mesh that may or may not be convex.

    :param kind: ``box`` (``size`` = full extents), ``cylinder`` (``size`` = radius, length along local z),
        ``sphere`` (``size`` = radius,) or ``mesh`` (a convex mesh, vertices in the geom frame)
    :param origin: 4x4 pose of the geom frame in the link frame
    :param size: the primitive's dimensions, see ``kind``
    :param mesh: for ``kind == "mesh"``, the convex mesh
    :param source: the file a mesh was read from, relative to the object folder, if any
    """

    kind: str
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))
    size: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mesh: trimesh.Trimesh | None = None
    source: str | None = None

    @property
    def is_convex(self) -> bool:
        """Primitives always are; a mesh is when it equals its convex hull (trimesh's test)."""
        return self.kind != "mesh" or (self.mesh is not None and bool(self.mesh.is_convex))

    def to_trimesh(self) -> trimesh.Trimesh:
        """This shape as a mesh in the link frame."""
        if self.kind == "box":
            shape = trimesh.creation.box(extents=self.size)
        elif self.kind == "cylinder":
            shape = trimesh.creation.cylinder(radius=self.size[0], height=self.size[1], sections=32)
        elif self.kind == "sphere":
            shape = trimesh.creation.icosphere(subdivisions=2, radius=self.size[0])
        elif self.kind == "mesh" and self.mesh is not None:
            shape = self.mesh.copy()
        else:
            raise ValueError(f"collision of kind {self.kind!r} has no geometry")
        shape.apply_transform(self.origin)
        return shape


@dataclass
class Link:
    """A rigid body of the asset.

    :param name: unique link name (``base``, ``link_0``, ``link_0_helper``, ...)
    :param visuals: meshes in the link frame
    :param collisions: convex collision shapes, when the source provides them
    :param label: semantic label (``drawer``, ``door``, ``handle``...), from ``semantics.txt``
    :param semantic_joint: PartNet-Mobility joint word from ``semantics.txt``
        (``hinge``, ``slider``, ``free``, ``heavy``, ``static``)
    :param annotations: extra per-link annotations, e.g. GAPartNet's ``category`` and ``bbox``
    :param skipped_meshes: mesh files of the source that were skipped because they have no surface
        (missing, empty, no faces) while others of the link have one, each as ``"role: problem"``
    """

    name: str
    visuals: list[Visual] = field(default_factory=list)
    collisions: list[Collision] = field(default_factory=list)
    label: str = ""
    semantic_joint: str = ""
    annotations: dict = field(default_factory=dict)
    skipped_meshes: list[str] = field(default_factory=list)

    def merged_mesh(self) -> trimesh.Trimesh:
        """All visuals as one mesh in the link frame, by vertex-face concatenation (no processing)."""
        from spark_bench.asset.mesh import merge_meshes

        return merge_meshes([v.mesh for v in self.visuals])

    @property
    def has_geometry(self) -> bool:
        return any(len(v.mesh.faces) for v in self.visuals)


@dataclass
class Joint:
    """A joint between two links, URDF semantics.

    :param name: unique joint name
    :param type: one of :data:`JOINT_TYPES`
    :param parent: parent link name
    :param child: child link name
    :param origin: 4x4 pose of the joint frame in the parent link frame
    :param axis: unit axis in the joint frame (rotation axis or sliding direction)
    :param lower: lower limit (rad or m); 0 for continuous joints
    :param upper: upper limit (rad or m); ``lower + 2 pi`` for continuous joints
    :param has_limits: whether the source gave ``<limit>`` (a revolute without one gets [0, pi])
    :param has_axis: whether the source gave ``<axis>`` (without one: (1, 0, 0), as in URDF)
    :param damping: URDF ``<dynamics damping>``, if given
    :param friction: URDF ``<dynamics friction>``, if given
    :param effort: URDF ``<limit effort>``, if given
    :param velocity: URDF ``<limit velocity>``, if given
    """

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    lower: float = 0.0
    upper: float = 0.0
    has_limits: bool = True
    has_axis: bool = True
    damping: float | None = None
    friction: float | None = None
    effort: float | None = None
    velocity: float | None = None

    @property
    def is_movable(self) -> bool:
        return is_movable(self.type)

    @property
    def is_rotational(self) -> bool:
        return is_rotational(self.type)

    @property
    def rest_value(self) -> float:
        """The rest configuration: the lower limit, 0 for continuous joints."""
        return 0.0 if self.type in (JointType.CONTINUOUS, JointType.FIXED) else float(self.lower)

    @property
    def open_value(self) -> float:
        """The open configuration: the upper limit, :data:`CONTINUOUS_OPEN_ANGLE` for continuous joints."""
        if self.type == JointType.CONTINUOUS:
            return CONTINUOUS_OPEN_ANGLE
        if self.type == JointType.FIXED:
            return 0.0
        return float(self.upper)

    def motion(self, value: float) -> np.ndarray:
        """4x4 motion of the child in the joint frame for the joint value ``value``."""
        out = np.eye(4)
        if self.is_rotational:
            out[:3, :3] = axis_angle_matrix(self.axis, value)
        elif self.type == JointType.PRISMATIC:
            out[:3, 3] = np.asarray(self.axis, dtype=float) * value
        return out


@dataclass
class ArticulatedAsset:
    """An articulated object: a tree of links connected by joints.

    :param name: object id (folder name for PartNet-Mobility objects)
    :param links: links by name, in file order
    :param joints: joints by name, in file order
    :param category: object category (``StorageFurniture``, ``Oven``...), from ``meta.json``
    :param source: where it was read from (a folder or file), for messages
    :param meta: any further metadata (``meta.json`` content, provenance)
    :param warnings: what reading the source left out or could not resolve without it mattering to the
        geometry or the joints (a material's shader file that is not there, a sublayer that holds none of
        the articulation), one line each naming the file and the element; reports show them
    """

    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]
    category: str = ""
    source: str = ""
    meta: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    # ----- structure -------------------------------------------------------------------------
    @property
    def root(self) -> str:
        """The root link: the one link that is never a joint's child."""
        children = {j.child for j in self.joints.values()}
        roots = [name for name in self.links if name not in children]
        if len(roots) != 1:
            raise ValueError(f"{self.name}: expected one root link, found {roots}")
        return roots[0]

    def joint_of_child(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (None for the root)."""
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None

    def topological_joints(self) -> list[Joint]:
        """Joints in breadth-first order from the root (parents before children, siblings in file order)."""
        by_parent: dict[str, list[Joint]] = {}
        for joint in self.joints.values():
            by_parent.setdefault(joint.parent, []).append(joint)
        order: list[Joint] = []
        frontier = [self.root]
        while frontier:
            below = [j for link in frontier for j in by_parent.get(link, [])]
            order.extend(below)
            frontier = [j.child for j in below]
        return order

    def movable_joints(self) -> list[Joint]:
        """Revolute, continuous and prismatic joints, in file order."""
        return [j for j in self.joints.values() if j.is_movable]

    def moving_links(self, joint: str) -> list[str]:
        """The child link of ``joint`` and every link below it."""
        start = self.joints[joint].child
        out, stack = [], [start]
        while stack:
            link = stack.pop()
            out.append(link)
            stack.extend(j.child for j in self.joints.values() if j.parent == link)
        return out

    def part_of_joint(self, joint: str) -> list[str]:
        """Links that move with ``joint`` and no other movable joint below it (the joint's own part)."""
        start = self.joints[joint].child
        out, stack = [], [start]
        while stack:
            link = stack.pop()
            out.append(link)
            stack.extend(j.child for j in self.joints.values() if j.parent == link and not j.is_movable)
        return out

    # ----- configurations --------------------------------------------------------------------
    def rest_configuration(self) -> dict[str, float]:
        """Every movable joint at its lower limit (0 for continuous joints)."""
        return {j.name: j.rest_value for j in self.movable_joints()}

    def open_configuration(self) -> dict[str, float]:
        """Every movable joint at its upper limit (:data:`CONTINUOUS_OPEN_ANGLE` for continuous)."""
        return {j.name: j.open_value for j in self.movable_joints()}

    # ----- kinematics ------------------------------------------------------------------------
    def link_poses(self, q: Configuration | None = None) -> dict[str, np.ndarray]:
        """World pose (4x4) of every link; joints missing from ``q`` are at rest.

        :param q: joint values by joint name
        """
        values = self.rest_configuration()
        if q:
            unknown = set(q) - set(self.joints)
            if unknown:
                raise KeyError(f"{self.name}: no joint named {sorted(unknown)}")
            values.update({k: float(v) for k, v in q.items()})
        poses = {self.root: np.eye(4)}
        for joint in self.topological_joints():
            motion = joint.motion(values.get(joint.name, 0.0))
            poses[joint.child] = poses[joint.parent] @ joint.origin @ motion
        return poses

    def joint_frames(self, q: Configuration | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """World-frame ``(point on axis, unit axis direction)`` of every movable joint at ``q``."""
        poses = self.link_poses(q)
        out = {}
        for joint in self.movable_joints():
            frame = poses[joint.parent] @ joint.origin
            direction = frame[:3, :3] @ np.asarray(joint.axis, dtype=float)
            out[joint.name] = (frame[:3, 3].copy(), direction / np.linalg.norm(direction))
        return out

    def link_meshes(self, q: Configuration | None = None, links=None) -> dict[str, trimesh.Trimesh]:
        """Each link's merged visual mesh in the world frame at ``q`` (links without geometry omitted)."""
        poses = self.link_poses(q)
        out = {}
        for name in links if links is not None else self.links:
            link = self.links[name]
            if not link.has_geometry:
                continue
            mesh = link.merged_mesh()
            out[name] = trimesh.Trimesh(transform_points(poses[name], mesh.vertices), mesh.faces, process=False)
        return out

    def mesh(self, q: Configuration | None = None, links=None) -> trimesh.Trimesh:
        """The whole object (or the given links) as one mesh in the world frame at ``q``."""
        from spark_bench.asset.mesh import merge_meshes

        return merge_meshes(list(self.link_meshes(q, links).values()))

    def bounds(self, q: Configuration | None = None) -> np.ndarray:
        """World axis-aligned bounding box ``[[min], [max]]`` at ``q``."""
        meshes = list(self.link_meshes(q).values())
        if not meshes:
            raise ValueError(f"{self.name}: asset has no geometry")
        points = np.concatenate([m.vertices for m in meshes])
        return np.stack([points.min(0), points.max(0)])

    def copy(self, visuals: bool = True) -> ArticulatedAsset:
        """A deep copy (meshes included).

        :param visuals: False: the copy's links have no visuals (for a caller that gives them new ones: the
            meshes are not copied only to be replaced)
        """
        if visuals:
            return copy.deepcopy(self)
        memo = {id(link.visuals): [] for link in self.links.values()}  # each visuals list copies to a new []
        return copy.deepcopy(self, memo)
