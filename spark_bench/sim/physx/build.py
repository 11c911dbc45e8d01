"""A prepared object as one PhysX articulation in a physics-only SAPIEN scene (:func:`build_object`).

- The links welded together by fixed joints are one PhysX link (a *weld group*, named after its top link), as
  MuJoCo does not collide bodies of one weld either; its mass properties are its links' summed.
- Revolute joints are PhysX's unwrapped revolute joints (their limits need not lie within one turn), continuous
  joints the same without limits, prismatic joints prismatic; a joint whose limits are equal is fixed (PhysX
  needs ``lower < upper``). PhysX moves a joint along the x axis of its frame: the frame is turned onto the
  URDF's axis, so that PhysX's joint values are the URDF's.
- **Carriers.** PhysX never collides two links joined by an articulation joint, whatever their collision groups
  (a door whose axis was reversed swings through its cabinet). Links further apart in the tree do collide, so
  every moving joint hangs its part from a shapeless *carrier* link fixed to the parent at the joint's frame: the
  part and its parent are then grandchild and grandparent and collide as in MuJoCo, where every pair collides
  except :attr:`PreparedObject.excluded`. Built without carriers (``carriers=False``: the articulation as
  SAPIEN's URDF loader makes it), the parent-child pairs are filtered (:attr:`PhysxObject.filtered`) and the
  checks query them by :mod:`.query`.
- **Excluded pairs** are made not to collide by collision groups: the two links' shapes share a bit of the
  ignore word (SAPIEN's filter drops a pair of one articulation that shares one); two pairs share a bit where
  every link pair it joins is excluded. Beyond the 32 bits, a pair whose child hangs directly from its parent
  loses its carrier instead (the articulation then filters it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.sim.checks import PENETRATION_TOLERANCE
from spark_bench.sim.mjcf import base_rotation
from spark_bench.sim.physical import MassProperties, principal_inertia
from spark_bench.sim.physx import sapien_module
from spark_bench.sim.physx.hulls import HullLimits, cooked_deviation, physx_shapes
from spark_bench.sim.prepared import PreparedObject
from spark_bench.sim.shapes import CollisionShape

#: Time step (s): MuJoCo's default, which the MuJoCo checks use.
TIMESTEP = 0.002
#: Solver iterations of the articulation (position, velocity): ManiSkill3's defaults.
SOLVER_ITERATIONS = (15, 1)
#: Contact offset of every shape, as a fraction of the object's size (within PhysX's default of 1 cm): contacts
#: are made this far before shapes touch, so a camera button's 8 mm stroke is not all contact.
CONTACT_OFFSET = 0.002
MAX_CONTACT_OFFSET = 0.01
#: Mass of a carrier link, as a fraction of its part's (it is fixed to the parent: it only adds to it).
CARRIER_MASS = 1e-4
#: Bits of SAPIEN's ignore word (collision group 2).
IGNORE_BITS = 32
#: A cooked hull whose surface moved farther than this fraction of the object's size from its hull's was changed by
#: PhysX (the rest-penetration tolerance: less cannot make a contact fail; PhysX's cooking merges near-coplanar
#: faces, moving a CoACD hull's surface by up to a millimetre or so).
COOKED_TOLERANCE = PENETRATION_TOLERANCE


@dataclass
class PhysxLink:
    """One PhysX link: a weld group of the asset's links.

    :param name: the group's top link (its joint moves it, or it is the root)
    :param links: the asset links welded in it
    :param component: its ``PhysxArticulationLinkComponent``
    :param shapes: per PhysX shape attached, in order: ``(asset link, index of the prepared hull it came from)``
    """

    name: str
    links: list[str]
    component: object = None
    shapes: list[tuple[str, int]] = field(default_factory=list)


@dataclass
class PhysxObject:
    """A prepared object loaded into SAPIEN.

    :param prepared: what was loaded
    :param scene: the ``sapien.Scene`` (physics only)
    :param articulation: its ``PhysxArticulation`` (root fixed)
    :param links: PhysX links by group name
    :param group_of: each asset link's group
    :param joints: the asset's joints PhysX moves, by name, as ``PhysxArticulationJoint``
    :param dof: the index of each of those joints in ``qpos``
    :param carriers: the joints whose part hangs from a carrier link
    :param filtered: ``(parent group, child group)`` pairs with shapes that PhysX does not collide and that are
        not excluded (no carrier): the checks query them
    :param locked: joints with equal limits, built as fixed joints
    :param hulls: what PhysX's hull limits did
    :param cooked_changed: hulls whose cooked surface moved farther than :data:`COOKED_TOLERANCE` of the object's
        size (``link:index``)
    :param cooked_moved: the farthest any cooked hull's surface moved (m)
    :param ignore_bits: collision-group bits used for the excluded pairs
    :param pcm: whether PhysX's persistent contact manifolds are on
    """

    prepared: PreparedObject
    scene: object
    articulation: object
    links: dict[str, PhysxLink]
    group_of: dict[str, str]
    joints: dict[str, object]
    dof: dict[str, int]
    carriers: list[str] = field(default_factory=list)
    filtered: list[tuple[str, str]] = field(default_factory=list)
    locked: list[str] = field(default_factory=list)
    hulls: HullLimits = field(default_factory=HullLimits)
    cooked_changed: list[str] = field(default_factory=list)
    cooked_moved: float = 0.0
    ignore_bits: int = 0
    pcm: bool = True

    @property
    def timestep(self) -> float:
        return float(self.scene.physx_system.timestep)

    def shape_owner(self, body, shape) -> tuple[str, int] | None:
        """``(asset link, hull index)`` of a PhysX shape of ``body`` (a contact's), None for a carrier's."""
        group = self.links.get(body.name)
        if group is None:
            return None
        return group.shapes[list(body.collision_shapes).index(shape)]

    def set_rest(self) -> None:
        """Every joint at its rest value, at rest."""
        qpos = np.zeros(self.articulation.dof)
        for name, index in self.dof.items():
            qpos[index] = self.prepared.asset.joints[name].rest_value
        self.articulation.set_qpos(qpos)
        self.articulation.set_qvel(np.zeros(self.articulation.dof))
        self.articulation.set_qf(np.zeros(self.articulation.dof))


def weld_groups(asset: ArticulatedAsset) -> dict[str, str]:
    """Each link's weld group: the nearest link at or above it whose joint moves (or the root)."""
    group = {asset.root: asset.root}
    for joint in asset.topological_joints():
        group[joint.child] = joint.child if joint.is_movable and not _locked(joint) else group[joint.parent]
    return group


def _locked(joint) -> bool:
    return joint.type != JointType.CONTINUOUS and float(joint.upper) - float(joint.lower) < 1e-9


def axis_frame(axis) -> np.ndarray:
    """4x4 rotation whose x axis is the unit ``axis`` (PhysX moves a joint along its frame's x axis)."""
    x = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(helper, x)
    y /= np.linalg.norm(y)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, y, np.cross(x, y)])
    return out


def combined_mass(parts: list[tuple[MassProperties, np.ndarray]]) -> MassProperties:
    """The mass properties of rigidly joined parts, each given in its own frame with its pose in the common one."""
    moved = []
    for props, pose in parts:
        rotation = pose[:3, :3]
        moved.append((props.mass, rotation @ props.com + pose[:3, 3], rotation @ props.inertia @ rotation.T))
    mass = sum(m for m, _, _ in moved)
    com = sum(m * c for m, c, _ in moved) / mass
    inertia = np.zeros((3, 3))
    for m, c, inert in moved:
        d = c - com
        inertia += inert + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return MassProperties(float(mass), com, inertia, sum(p.volume for p, _ in parts))


def _pose(matrix: np.ndarray):
    return sapien_module().Pose(np.asarray(matrix, np.float64))


def _new_link(parent, name: str, props: MassProperties):
    """A named link component and its entity, with ``props`` as its mass properties."""
    sapien = sapien_module()
    component = sapien.physx.PhysxArticulationLinkComponent(parent)
    moments, axes = principal_inertia(props.inertia)
    frame = np.eye(4)
    frame[:3, :3], frame[:3, 3] = axes, props.com
    component.mass = float(props.mass)
    component.cmass_local_pose = _pose(frame)
    component.inertia = moments.astype(np.float32)
    component.name = name
    entity = sapien.Entity()
    entity.name = name
    entity.add_component(component)
    return component, entity


def _attach_shape(component, shape: CollisionShape, pose: np.ndarray, material, offset: float) -> tuple[object, float]:
    """Attach ``shape`` (link frame) placed by ``pose`` in the PhysX link; returns the PhysX shape and how far
    (m) its cooked hull's surface moved from the hull's (:func:`cooked_deviation`; 0 for a primitive)."""
    physx = sapien_module().physx
    change = 0.0
    if shape.kind == "box":
        px = physx.PhysxCollisionShapeBox(half_size=(0.5 * np.asarray(shape.size, float)).tolist(), material=material)
        px.local_pose = _pose(pose @ shape.origin)
    elif shape.kind == "sphere":
        px = physx.PhysxCollisionShapeSphere(radius=float(shape.size[0]), material=material)
        px.local_pose = _pose(pose @ shape.origin)
    else:  # a mesh hull, or a cylinder as MuJoCo's prism of it
        vertices = np.asarray(shape.to_trimesh().vertices, float) @ pose[:3, :3].T + pose[:3, 3]
        px = physx.PhysxCollisionShapeConvexMesh(vertices=vertices.astype(np.float32), scale=[1.0, 1.0, 1.0],
                                                 material=material)
        change = cooked_deviation(vertices, np.asarray(px.get_vertices(), float))
    px.set_contact_offset(offset)
    px.set_rest_offset(0.0)
    px.set_collision_groups([1, 1, 0, 0])
    component.attach(px)
    return px, change


def _ignore_bits(prepared: PreparedObject, group_of: dict[str, str]) -> tuple[dict[str, int], list[tuple[str, str]]]:
    """Ignore-word bits per asset link for the excluded pairs, and the pairs no bit was left for.

    A bit joins a set of links every two of which are an excluded pair (so it excludes nothing else)."""
    excluded = {frozenset(pair) for pair in prepared.excluded if group_of[pair[0]] != group_of[pair[1]]}
    members: list[set[str]] = []
    bits: dict[str, int] = {}
    left = []
    for parent, child in sorted(prepared.excluded):
        if frozenset((parent, child)) not in excluded:
            continue
        joins = [k for k, links in enumerate(members)
                 if all(frozenset((a, b)) in excluded for a in links | {parent, child} for b in links if a != b)]
        if joins:
            bit = joins[0]
            members[bit] |= {parent, child}
        elif len(members) == IGNORE_BITS:
            left.append((parent, child))
            continue
        else:
            members.append({parent, child})
            bit = len(members) - 1
        for link in (parent, child):
            bits[link] = bits.get(link, 0) | (1 << bit)
    return bits, left


def _joint_pose(prepared: PreparedObject, group_of: dict[str, str], joint) -> np.ndarray:
    """The joint's frame in its parent's group frame (URDF axis not yet turned onto x)."""
    poses = prepared.asset.link_poses()
    parent_group = group_of[joint.parent]
    to_group = np.linalg.inv(poses[parent_group]) @ poses[joint.parent]
    return to_group @ joint.origin


def _set_joint(component, joint, parent_pose: np.ndarray) -> None:
    """Make ``component``'s incoming joint the URDF ``joint`` whose frame sits at ``parent_pose`` in the parent."""
    turn = axis_frame(joint.axis)
    component.joint.name = joint.name
    if joint.type == JointType.PRISMATIC:
        component.joint.type = "prismatic"
    else:
        component.joint.type = "revolute_unwrapped"
    component.joint.pose_in_parent = _pose(parent_pose @ turn)
    component.joint.pose_in_child = _pose(turn)
    # PhysX's own joint friction (a coefficient on the load the joint carries, 0.05 by default) off: the checks apply
    # the prepared dry friction and damping themselves, as MuJoCo's joints have them
    component.joint.friction = 0.0
    if joint.type == JointType.CONTINUOUS:
        component.joint.limit = np.array([[-np.inf, np.inf]], np.float32)
    else:
        component.joint.limit = np.array([[float(joint.lower), float(joint.upper)]], np.float32)


def _group_parts(prepared: PreparedObject, group_of: dict[str, str]) -> dict[str, list[tuple[str, np.ndarray]]]:
    """Per group, its links with their poses in the group's frame."""
    poses = prepared.asset.link_poses()
    out: dict[str, list[tuple[str, np.ndarray]]] = {}
    for link, group in group_of.items():
        out.setdefault(group, []).append((link, np.linalg.inv(poses[group]) @ poses[link]))
    return out


def _carrier_dropped(prepared: PreparedObject, group_of: dict[str, str], left: list[tuple[str, str]]) -> set[str]:
    """The joints whose carrier is left out so that the articulation filters an excluded pair no bit was left for.

    :raises InputError: such a pair is not a part hanging directly from its parent
    """
    asset = prepared.asset
    dropped = set()
    for parent, child in left:
        joint = asset.joint_of_child(child)
        if group_of[child] != child or joint is None or group_of[joint.parent] != group_of[parent]:
            raise InputError(asset.source or asset.name, f"more excluded parent-child pairs than PhysX's "
                                                         f"{IGNORE_BITS} collision-group bits hold ({parent}, {child})")
        dropped.add(joint.name)
    return dropped


def _has_excluded(prepared: PreparedObject, group_of: dict[str, str], first: str, second: str) -> bool:
    return any({group_of[a], group_of[b]} == {first, second} for a, b in prepared.excluded)


class _Builder:
    """Collects the link components of one articulation (see :func:`build_object`)."""

    def __init__(self, prepared: PreparedObject, ignore: dict[str, int]):
        physx = sapien_module().physx
        self.prepared, self.ignore = prepared, ignore
        self.group_of = weld_groups(prepared.asset)
        self.parts = _group_parts(prepared, self.group_of)
        self.pieces, self.hulls = physx_shapes(prepared.shapes)
        self.material = physx.PhysxMaterial(prepared.options.friction, prepared.options.friction, 0.0)
        self.offset = float(np.clip(CONTACT_OFFSET * prepared.size, 1e-4, MAX_CONTACT_OFFSET))
        self.links: dict[str, PhysxLink] = {}
        self.entities: list = []
        self.cooked_changed: list[str] = []
        self.cooked_moved = 0.0

    def has_shapes(self, group: str) -> bool:
        return any(self.pieces.get(link) for link, _ in self.parts[group])

    def group(self, group: str, parent) -> object:
        """The PhysX link of weld group ``group`` under ``parent`` (None: the root), shapes and mass attached."""
        props = combined_mass([(self.prepared.mass[link], pose) for link, pose in self.parts[group]])
        component, entity = _new_link(parent, group, props)
        link = PhysxLink(group, [name for name, _ in self.parts[group]], component)
        for name, pose in self.parts[group]:
            for index, piece in self.pieces.get(name, []):
                shape, change = _attach_shape(component, piece, pose, self.material, self.offset)
                if self.ignore.get(name):
                    shape.set_collision_groups([1, 1, self.ignore[name], 0])
                link.shapes.append((name, index))
                self.cooked_moved = max(self.cooked_moved, change)
                if change > COOKED_TOLERANCE * self.prepared.size:
                    self.cooked_changed.append(f"{name}:{index}")
        self.links[group] = link
        self.entities.append(entity)
        return component

    def carrier(self, joint, parent, pose: np.ndarray) -> object:
        """A shapeless link fixed to ``parent`` at ``pose``, from which ``joint``'s part will hang."""
        child_mass = combined_mass([(self.prepared.mass[n], p) for n, p in self.parts[joint.child]]).mass
        mass = CARRIER_MASS * child_mass
        props = MassProperties(mass, np.zeros(3), np.eye(3) * mass * (0.01 * self.prepared.size) ** 2, 0.0)
        component, entity = _new_link(parent, f"{joint.name}_carrier", props)
        component.joint.type = "fixed"
        component.joint.pose_in_parent = _pose(pose)
        component.joint.pose_in_child = _pose(np.eye(4))
        self.entities.append(entity)
        return component


def build_object(prepared: PreparedObject, carriers: bool = True, timestep: float = TIMESTEP,
                 pcm: bool = True) -> PhysxObject:
    """Load ``prepared`` into a new physics-only SAPIEN scene (see the module docstring), at rest.

    :param prepared: :func:`spark_bench.sim.mjcf.prepare`'s object
    :param carriers: hang every moving part from a carrier link, so that it collides with its parent
    :param timestep: the scene's time step (s)
    :param pcm: PhysX's persistent contact manifolds (SAPIEN's and ManiSkill3's default); False: PhysX's
        full contact generation every step
    :raises SapienMissing: SAPIEN is not installed
    """
    sapien_module()  # SAPIEN missing: say what to install before anything is built
    asset = prepared.asset
    group_of = weld_groups(asset)
    ignore, left = _ignore_bits(prepared, group_of)
    dropped = _carrier_dropped(prepared, group_of, left)
    build = _Builder(prepared, ignore)
    scene = _scene(timestep, pcm)
    root = build.group(asset.root, None)
    root.joint.type = "fixed"
    used, filtered, locked = [], [], []
    for joint in asset.topological_joints():
        if group_of[joint.child] != joint.child:
            locked += [joint.name] if joint.is_movable else []
            continue
        parent_group = group_of[joint.parent]
        parent = build.links[parent_group].component
        pose = _joint_pose(prepared, group_of, joint)
        both = build.has_shapes(parent_group) and build.has_shapes(joint.child)
        if carriers and both and joint.name not in dropped:
            parent, pose = build.carrier(joint, parent, pose), np.eye(4)
            used.append(joint.name)
        elif both and not _has_excluded(prepared, group_of, parent_group, joint.child):
            filtered.append((parent_group, joint.child))
        _set_joint(build.group(joint.child, parent), joint, pose)
    base = np.eye(4)
    base[:3, :3], base[:3, 3] = base_rotation(prepared.options), np.asarray(prepared.options.base_pos, float)
    build.entities[0].pose = _pose(base)
    for entity in build.entities:
        scene.add_entity(entity)
    articulation = root.articulation
    articulation.set_solver_position_iterations(SOLVER_ITERATIONS[0])
    articulation.set_solver_velocity_iterations(SOLVER_ITERATIONS[1])
    names = [j.name for j in articulation.active_joints]
    out = PhysxObject(prepared, scene, articulation, build.links, group_of,
                      {n: articulation.find_joint_by_name(n) for n in names}, {n: k for k, n in enumerate(names)},
                      used, filtered, locked, build.hulls, build.cooked_changed, build.cooked_moved,
                      int(bool(ignore)) and max(ignore.values()).bit_length(), pcm)
    out.set_rest()
    return out


def _scene(timestep: float, pcm: bool):
    """A physics-only scene; SAPIEN reads the scene configuration (PCM) when the system is made."""
    sapien = sapien_module()
    config = sapien.physx.get_scene_config()
    default = config.enable_pcm
    config.enable_pcm = pcm
    sapien.physx.set_scene_config(config)
    try:
        scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])
    finally:
        config.enable_pcm = default
        sapien.physx.set_scene_config(config)
    scene.set_timestep(timestep)
    return scene
