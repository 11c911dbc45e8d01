"""The compiled scene of an opening task: the object's MJCF (from :mod:`spark_bench.sim`), the floating
gripper, the chosen joint and where to grasp its part.

The object's :class:`mujoco.MjSpec` comes from :func:`spark_bench.sim.build_spec`, the sim-readiness
conversion (bodies named by link, joints by URDF joint name with ``qpos`` in URDF values, convex
collision geoms in class ``collision`` with ``contype = conaffinity = 1``, CoACD hulls cached under
``SPARK_BENCH_HOME``). The gripper's geoms have ``contype 2, conaffinity 1``: they touch the object and
not each other.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from dataclasses import dataclass, replace

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Joint
from spark_bench.errors import InputError
from spark_bench.manipulation.grasp import find_grasp
from spark_bench.manipulation.grasp_target import GraspTarget
from spark_bench.manipulation.gripper import GripperConfig, GripperHandles
from spark_bench.manipulation.handle_search import N_SAMPLES
from spark_bench.manipulation.rest_meshes import RestMeshes
from spark_bench.manipulation.suction import (
    SuctionConfig,
    SuctionHandles,
    plan_suction,
)
from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

#: Physics step, s. The control period is ``TIMESTEP * N_SUBSTEPS`` (25 Hz).
TIMESTEP = 0.004
N_SUBSTEPS = 10
#: Friction-to-normal impedance ratio, with elliptic friction cones: MuJoCo's default (1, pyramidal)
#: lets a pinched handle creep out of the pads under a steady pull (measured: 7 of 117 synth drawers
#: slipped off at 55-70 % open); 10 makes the grip hold.
IMPRATIO = 10.0
#: Room (m) left between the pads and a notch's edges, along its depth (the pads' height direction), and
#: the lowest pads a notch gets, m.
NOTCH_CLEARANCE = 0.014
NOTCH_MIN_PAD_HEIGHT = 0.008
#: Contact ``solref`` of pads thinned to fit beside a handle: the stiffest MuJoCo allows at this step
#: (2 steps), so that a 3 mm pad squeezing a 5 mm lip sinks about 0.5 mm into it, not 2 mm (at 0.02 s).
#: The default pads use it too (:class:`~spark_bench.manipulation.gripper.GripperConfig`'s ``pad_solref``).
THIN_PAD_SOLREF = (2 * TIMESTEP, 1.0)
#: Half-range (joint units) left to a joint hinged to the opened part (:func:`hold_hinged_parts`).
HELD_RANGE = 1e-4
#: How far (m) around the object's box the gripper may move.
WORKSPACE_MARGIN = 0.35

#: A default joint's part is at least this fraction of the largest candidate part's size (bounding-box
#: diagonal): a knob or a lever is a part too, but not the one a task means.
DEFAULT_PART_FRACTION = 0.3

KIND_TYPES = {JointType.PRISMATIC: (JointType.PRISMATIC,), JointType.REVOLUTE: (JointType.REVOLUTE, JointType.CONTINUOUS)}


@dataclass
class Scene:
    """A compiled opening task.

    :param model: the compiled model (object + gripper); share it read-only between environments
    :param asset: the object
    :param joint: the joint to open (its asset entry)
    :param grasp: where to grasp the part, world frame at rest
    :param grasp_body: the MuJoCo body the grasp point moves with (the joint's child link)
    :param grasp_local: the grasp point in that body's frame
    :param gripper: names of the gripper's elements
    :param workspace: ``[[min], [max]]`` box the TCP may reach
    :param rest_qpos: the full ``qpos`` with every object joint at rest, gripper at the origin
    :param held_joints: joints of parts hinged to the opened part, held at rest (:func:`hold_hinged_parts`)
    :param free_fraction: the fraction of its range the joint reaches driven directly with the gripper's
        largest pull (:func:`~spark_bench.manipulation.drive_check.stuck_reason`), when checked (the planner found a grasp): below
        :data:`~spark_bench.manipulation.drive_check.JAM_FRACTION` the grasp's ``reason`` says why no policy of this gripper can open the part
    :param end_effector: ``gripper`` (the parallel gripper: ``gripper`` holds :class:`GripperHandles`) or
        ``suction`` (the suction cup, :mod:`spark_bench.manipulation.suction`: ``gripper`` holds its
        :class:`~spark_bench.manipulation.suction.SuctionHandles`, ``grasp`` the cup's place)
    """

    model: mujoco.MjModel
    asset: ArticulatedAsset
    joint: Joint
    grasp: GraspTarget
    grasp_body: str
    grasp_local: np.ndarray
    gripper: GripperHandles | SuctionHandles
    workspace: np.ndarray
    rest_qpos: np.ndarray
    held_joints: tuple[str, ...] = ()
    free_fraction: float | None = None
    end_effector: str = "gripper"

    @property
    def joint_range(self) -> tuple[float, float]:
        """The joint's opening range: ``(rest, open)``."""
        return self.joint.rest_value, self.joint.open_value


def choose_joint(asset: ArticulatedAsset, kind: str, joint: str | None) -> Joint:
    """The joint to open: ``joint`` checked against ``kind``, or the default one of that kind.

    The default is the first joint of the kind that a task would name: a limited joint before a continuous
    one (a dial, a turntable), and a part at least :data:`DEFAULT_PART_FRACTION` of the largest such part's
    size (a safe's door, not the lever on it).

    :param kind: ``prismatic`` or ``revolute``
    :raises InputError: no such joint, or not of the right kind
    """
    types = KIND_TYPES[kind]
    where = asset.source or asset.name
    movable = [j.name for j in asset.movable_joints()]
    if joint is not None:
        if joint not in asset.joints:
            raise InputError(where, f"no joint named {joint!r} (movable joints: {', '.join(movable) or 'none'})")
        found = asset.joints[joint]
        if found.type not in types:
            raise InputError(where, f"joint {joint!r} is {found.type}, this task needs a {kind} joint")
        candidate = found
    else:
        matches = [j for j in asset.movable_joints() if j.type in types]
        if not matches:
            raise InputError(where, f"asset has no {kind} joint (movable joints: {', '.join(movable) or 'none'})")
        ranks = _default_rank(asset, matches)
        candidate = matches[min(range(len(matches)), key=ranks.__getitem__)]
    if candidate.open_value <= candidate.rest_value:
        raise InputError(where, f"joint {candidate.name!r} has an empty range [{candidate.lower}, {candidate.upper}]")
    return candidate


def _default_rank(asset: ArticulatedAsset, joints: list[Joint]) -> list[tuple]:
    """Sort keys of the candidate joints for the default: limited with a range first, large parts first,
    then the asset's order."""
    sizes = {}
    for j in joints:
        mesh = asset.mesh(links=asset.part_of_joint(j.name))
        sizes[j.name] = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0))) if len(mesh.vertices) else 0.0
    largest = max(sizes.values())
    return [(j.type == JointType.CONTINUOUS or j.open_value <= j.rest_value, sizes[j.name] < DEFAULT_PART_FRACTION * largest, k)
            for k, j in enumerate(joints)]


#: Positions of the opened joint (fractions of its range) whose part's box the workspace holds: a door
#: swinging 170 degrees sweeps far out of the box of its rest and open positions (a safe's door, at 90
#: degrees, stands a door's width in front of the safe).
SWEEP_FRACTIONS = np.linspace(0.0, 1.0, 9)


def _rest_and_open_bounds(asset: ArticulatedAsset) -> tuple[np.ndarray, np.ndarray]:
    """The low and high corners of the box holding the object at rest and fully open."""
    rest, opened = asset.bounds(), asset.bounds(asset.open_configuration())
    return np.minimum(rest[0], opened[0]), np.maximum(rest[1], opened[1])


def workspace_box(asset: ArticulatedAsset, margin: float = WORKSPACE_MARGIN, joint: Joint | None = None
                  ) -> np.ndarray:
    """The box holding the object both at rest and fully open, and the part of ``joint`` at every position
    of :data:`SWEEP_FRACTIONS` of its range, grown by ``margin`` on every side.

    :param joint: the joint the task opens (None: rest and open only)
    """
    low, high = _memo("bounds", asset, None, lambda: _rest_and_open_bounds(asset))
    if joint is not None and joint.is_rotational:
        links = asset.part_of_joint(joint.name)
        for fraction in SWEEP_FRACTIONS[1:-1]:
            value = joint.rest_value + fraction * (joint.open_value - joint.rest_value)
            meshes = asset.link_meshes({joint.name: value}, links=links)
            points = [mesh.vertices for mesh in meshes.values() if len(mesh.vertices)]
            if points:
                points = np.concatenate(points)
                low, high = np.minimum(low, points.min(0)), np.maximum(high, points.max(0))
    return np.stack([low - margin, high + margin])


def fitted_gripper(grasp: GraspTarget, gripper: GripperConfig | None = None) -> GripperConfig:
    """The gripper fitted to ``grasp``: pads lowered to enter a notch with room to spare, or thinned to fit
    into the gaps beside the handle (:func:`~spark_bench.manipulation.pads.plan_pads` planned them for ``gripper``).

    :param gripper: the gripper to fit (default: :class:`GripperConfig`'s defaults)
    """
    base = gripper or GripperConfig()
    if grasp.inside_grip and grasp.notch_size is not None:
        height = max(grasp.notch_size[0] - NOTCH_CLEARANCE, NOTCH_MIN_PAD_HEIGHT)
        return replace(base, pad_height=float(min(base.pad_height, height)))
    if grasp.pad_thickness is not None:
        return replace(base, pad_thickness=min(base.pad_thickness, grasp.pad_thickness), pad_solref=THIN_PAD_SOLREF)
    return base


#: Grasp plans, prepared objects (collision shapes, masses), the object's meshes at rest and its bounds,
#: kept for the last :data:`MEMO_SIZE` assets (every entry of each), so that the environments of one
#: object's joints (the opening score opens each) share them.
MEMO_SIZE = 4
_MEMO: OrderedDict = OrderedDict()


def _fingerprint(asset: ArticulatedAsset) -> tuple:
    """What the memo's entries depend on: the joints and every link's geometry (vertex count and sum), so
    an asset changed in place is not served a stale entry."""
    joints = tuple((j.name, j.type, j.parent, j.child, float(j.lower), float(j.upper),
                    np.asarray(j.origin, float).tobytes(), np.asarray(j.axis, float).tobytes())
                   for j in asset.joints.values())
    links = []
    for name, link in asset.links.items():
        for visual in link.visuals:
            vertices = np.asarray(visual.mesh.vertices)
            links.append((name, len(vertices), float(vertices.sum())))
        for collision in link.collisions:
            mesh = np.asarray(collision.mesh.vertices) if collision.mesh is not None else np.zeros((0, 3))
            links.append((name, collision.kind, np.asarray(collision.origin, float).tobytes(),
                          np.asarray(collision.size, float).tobytes(), len(mesh), float(mesh.sum())))
    return joints, tuple(links)


def _memo(what: str, asset: ArticulatedAsset, extra, compute):
    key = (what, id(asset), extra)
    fingerprint = _fingerprint(asset)
    hit = _MEMO.get(key)
    if hit is not None and hit[0]() is asset and hit[1] == fingerprint:
        _MEMO.move_to_end(key)
        return hit[2]
    value = compute()
    _MEMO[key] = (weakref.ref(asset), fingerprint, value)
    while len({k[1] for k in _MEMO}) > MEMO_SIZE:  # the least recently used asset's entries go
        _MEMO.popitem(last=False)
    return value


def collision_mesh(asset: ArticulatedAsset, links: list[str]):
    """The simulated collision shapes of ``links`` (:func:`prepared_object`), one mesh in the world frame at
    rest, or None when they have none."""
    import trimesh

    from spark_bench.asset.mesh import merge_meshes

    shapes = prepared_object(asset).shapes
    poses = asset.link_poses()
    meshes = []
    for name in links:
        for shape in shapes.get(name, []):
            mesh = shape.to_trimesh()
            meshes.append(trimesh.Trimesh(mesh.vertices @ poses[name][:3, :3].T + poses[name][:3, 3], mesh.faces,
                                          process=False))
    return merge_meshes(meshes) if meshes else None


def plan_grasp(asset: ArticulatedAsset, joint: str, gripper: GripperConfig | None = None) -> GraspTarget:
    """The grasp on the part moved by ``joint`` (:func:`~spark_bench.manipulation.grasp.find_grasp`), memoized per
    asset; its ``reason`` says why the scripted opener cannot open the part, if it cannot. Handle candidates
    are judged on the part's simulated collision shapes too (:func:`collision_mesh`, the object prepared for
    MuJoCo as its scenes are: :func:`prepared_object`): the pads squeeze those, not the visual surface.

    :raises InputError: the part has no geometry, or no outward direction
    """
    def compute():
        try:  # an object that cannot be prepared is reported by its scene, as before: the visual surface only
            collision = collision_mesh(asset, asset.moving_links(joint))
        except (InputError, ValueError):
            collision = None
        try:  # the object at rest, its link meshes shared by its joints' plans
            return find_grasp(_memo("rest", asset, None, lambda: RestMeshes(asset)), joint, gripper=gripper,
                              collision=collision)
        except ValueError as exc:
            raise InputError(asset.source or asset.name, str(exc)) from None

    return _memo("grasp", asset, (joint, repr(gripper)), compute)


def part_points(asset: ArticulatedAsset, joint: str, n: int = N_SAMPLES) -> np.ndarray:
    """``n`` points sampled (seed 0) on the visual surface of the part moved by ``joint``, world frame at rest,
    memoized per asset (read-only: shared by the joint's environments): what a policy reads of the part's
    shape (a door's width and thickness, :func:`~spark_bench.opening.door_geometry.door_edge`); by default the
    grasp planner's own samples of the part. Empty when the part has no faces.

    :param asset: the object
    :param joint: a movable joint's name
    :param n: number of samples
    """
    from spark_bench.asset.mesh import sample_surface

    def compute():
        part = _memo("rest", asset, None, lambda: RestMeshes(asset)).mesh(links=asset.part_of_joint(joint))
        points = sample_surface(part, n, seed=0) if len(part.faces) else np.zeros((0, 3))
        points.setflags(write=False)
        return points

    return _memo("part", asset, (joint, n), compute)


def plan_cup(asset: ArticulatedAsset, joint: str, config: SuctionConfig | None = None,
             outward: np.ndarray | None = None) -> GraspTarget:
    """The suction cup's place on the part moved by ``joint`` (:func:`~spark_bench.manipulation.suction.plan_suction`),
    memoized per asset as :func:`plan_grasp` is.

    :param outward: the face to plan on, where the gripper's planner took another than the part's front (a
        sliding plate's broad face); None: the front
    :raises InputError: the part has no geometry, or no outward direction
    """
    def compute():
        try:
            return plan_suction(_memo("rest", asset, None, lambda: RestMeshes(asset)), joint, config, outward=outward)
        except ValueError as exc:
            raise InputError(asset.source or asset.name, str(exc)) from None

    key = None if outward is None else tuple(np.round(outward, 9))
    return _memo("cup", asset, (joint, repr(config), key), compute)


def prepared_object(asset: ArticulatedAsset):
    """The object as prepared for MuJoCo (:func:`spark_bench.sim.prepare`: collision shapes, masses, joint
    dynamics), memoized per asset: the same for every joint's environment."""
    from spark_bench.sim import prepare

    return _memo("prepared", asset, None, lambda: prepare(asset))


def hold_hinged_parts(spec, asset: ArticulatedAsset, joint: str) -> list[str]:
    """Hold the parts hinged to the opened part (a safe's wheel or lever, a knob) at rest, in place in
    ``spec``: their joints get a range of :data:`HELD_RANGE` about their rest value. They move with the
    part, and a real one resists turning (a latch, friction); free, a pulled wheel spins out of the
    fingers. Returns the held joints' names."""
    held = []
    for name in asset.moving_links(joint):
        parent = next((j for j in asset.joints.values() if j.child == name), None)
        if parent is None or not parent.is_movable or parent.name == joint:
            continue
        mj_joint = spec.joint(parent.name)
        if mj_joint is None:
            continue
        rest = parent.rest_value
        mj_joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        mj_joint.range = [rest - HELD_RANGE, rest + HELD_RANGE]
        held.append(parent.name)
    return held
