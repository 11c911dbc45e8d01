"""A floating suction cup: the second end-effector, for parts with nothing to pinch (a flush lid, a door or
drawer front without a handle).

Robot-learning benchmarks on PartNet-Mobility open such parts with a suction gripper on the part's
surface: UMPNet (``real-stanford/umpnet``, ``sim.py``) moves a floating cup onto a surface point and joins
it to the part with a PyBullet point-to-point constraint (``maxForce`` 2000), FlowBot3D (``r-pad/pybullet_envs``,
``suction_gripper.py``) with a fixed constraint at the first contact; neither constraint ever lets go. Here
the cup holds by MuJoCo's ``adhesion`` actuator (made for suction cups and gecko pads): while the cup's
face touches the part it adds an attraction of up to :attr:`SuctionConfig.max_force` to its contacts.
A pull along the face's normal stronger than that separates the cup, and a pull along the face is held by
friction only (the adhesion's normal force times the cup's friction): a trajectory planned from a wrong
axis tears the cup off or drags it over a part that does not follow.

The cup is carried like the gripper's hand (:mod:`spark_bench.manipulation.gripper`): three world-aligned slide
joints driven by position servos, gravity compensated, and for doors a passive spring-loaded wrist hinge
parallel to the door's hinge through the cup's face, so that the cup turns with the face it holds. The
hand frame's x is the approach direction; its origin, the *TCP*, is the centre of the cup's face.

Where the cup goes (:func:`plan_suction`): a point of the part's front face (the face the planner pulls
from: the front of a drawer, the outer face of a door or lid) with a flat patch under the whole cup,
nothing standing out of the face beside it, central on a drawer, as far from the hinge as the patch allows
on a door; approached along the face's normal. Where the 40 mm cup finds no such patch, the smaller cups of
the same product line are tried, largest first (:func:`cup_sizes`: 32, 25 and 20 mm, each holding with the
same vacuum over its area); the grasp names the cup chosen (``cup_radius``), and the scene carries that cup
(:func:`fitted_cup`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage

from spark_bench.manipulation.end_effector import END_EFFECTORS, EndEffector
from spark_bench.manipulation.features import LEVEL_BIN, NOTCH_CELL, rasterise_front
from spark_bench.manipulation.gripper import (
    PREFIX,
    GripperConfig,
    add_carriage,
    add_wrist,
    hand_rotation,
    largest_pull,
    rotation_quat,
)
from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

#: Why the grasp planner declined a part (:attr:`~spark_bench.manipulation.grasp_target.GraspTarget.declined`) that
#: ``auto`` opens with the cup instead: nothing to pinch (no handle, knob, notch or tab), a handle wider
#: than the open fingers, or handle candidates none of which the pads can hold (``unholdable``). A part
#: whose approach is blocked, or a push button, is not one.
SUCTION_DECLINES = ("no_handle", "too_wide", "unholdable")
#: A surface point stands out of the face (a handle's foot, a hinge knuckle) when it is this far (m) in front
#: of the face's level; the cup keeps :data:`SIDE_CLEARANCE` (m) from any such point.
PROUD = 0.003
SIDE_CLEARANCE = 0.008
#: Places whose lateral score (:func:`suction_point`) is within this (m) of the best are equally good.
LEVER_TOLERANCE = 0.01


@dataclass
class SuctionConfig:
    """Dimensions and gains of the suction cup.

    :param cup_radius: the cup's radius, m (a 40 mm cup)
    :param cup_length: the cup's and bellows' length along the approach, m
    :param max_force: the largest pull (N) along the face's normal the cup holds: the theoretical holding
        force of a 40 mm cup at 60 kPa below atmospheric pressure, ``F = dp * pi * r^2`` = 60 kPa x
        1.26e-3 m^2 = 75 N (how vacuum-cup makers rate a cup, before their safety factor; 60 kPa is a common
        working vacuum of an ejector). It is the gain of the cup's ``adhesion`` actuator
    :param smaller_cups: radii (m) of the smaller cups tried, largest first, where this cup finds no place
        (:func:`cup_sizes`): SMC's ZP vacuum pads come in 50, 40, 32, 25, 20, 16, 13 and 10 mm (series
        ZPT/ZPR), so a 32, 25 and 20 mm cup; each holds with the same vacuum, its force scaled by its area.
        A part's front too small for the 40 mm cup (a 45 mm drawer front at the real size) takes a smaller
        one, weaker by its area. Empty: the one cup only
    :param friction: sliding friction of the cup's lip (rubber on wood or paint): a pull along the face is
        held up to about ``friction * max_force``
    :param kp: stiffness of the translation servos, N/m (the gripper's: the same largest pull)
    :param dampratio: damping ratio of the translation servos
    :param force_limit: force limit of each translation servo, N
    :param wrist_stiffness: spring of the passive wrist hinge (doors), N m/rad
    :param wrist_damping: damping of the passive wrist hinge, N m s/rad
    :param wrist_range: the wrist hinge turns this far (rad) either way
    :param rgba: display colour
    """

    cup_radius: float = 0.02
    cup_length: float = 0.03
    max_force: float = 75.0
    smaller_cups: tuple[float, ...] = (0.016, 0.0125, 0.010)
    friction: float = 1.0
    # the carriage and the wrist are the gripper's (the same servos, the same largest pull): its defaults
    kp: float = GripperConfig.kp
    dampratio: float = GripperConfig.dampratio
    force_limit: float = GripperConfig.force_limit
    wrist_stiffness: float = GripperConfig.wrist_stiffness
    wrist_damping: float = GripperConfig.wrist_damping
    wrist_range: float = GripperConfig.wrist_range
    rgba: tuple = (0.85, 0.45, 0.1, 1.0)


@dataclass
class SuctionHandles:
    """Names of the cup's elements in the compiled model (the gripper's :class:`GripperHandles` where the two
    share a part: the carriage's slide joints and servos, the hand).

    :param slide_joints: x, y, z translation joints
    :param wrist_joint: the passive wrist hinge, or None
    :param slide_actuators: x, y, z position actuators
    :param suction_actuator: the cup's adhesion actuator (control 0 off to 1: :attr:`SuctionConfig.max_force`)
    :param hand_body: the body whose frame is the TCP (the cup's face centre); the adhesion acts on its
        contacts
    :param cup_geom: the cup's collision geom
    :param touch_sensor: the touch sensor at the cup's face
    :param config: dimensions and gains
    """

    slide_joints: tuple[str, str, str]
    wrist_joint: str | None
    slide_actuators: tuple[str, str, str]
    suction_actuator: str
    hand_body: str
    cup_geom: str
    touch_sensor: str
    config: SuctionConfig = field(default_factory=SuctionConfig)


def cup_sizes(config: SuctionConfig) -> list[SuctionConfig]:
    """The cups the planner tries, largest first: ``config`` and each of its :attr:`~SuctionConfig.smaller_cups`
    smaller than it, holding with the same vacuum (``max_force`` scaled by the cup's area, ``dp * pi * r^2``)."""
    smaller = sorted((r for r in config.smaller_cups if 0 < r < config.cup_radius), reverse=True)
    return [config] + [replace(config, cup_radius=float(r), max_force=config.max_force * (r / config.cup_radius) ** 2,
                               smaller_cups=()) for r in smaller]


def cup_mm(radius: float | None) -> float | None:
    """A cup's diameter in mm as the results write it (``cup_mm``), from its radius in m; None for none."""
    return None if radius is None else round(2000 * radius, 1)


def fitted_cup(grasp, config: SuctionConfig | None = None) -> SuctionConfig:
    """The cup the planner chose for ``grasp`` (:attr:`~spark_bench.manipulation.grasp_target.GraspTarget.cup_radius`) among
    :func:`cup_sizes` of ``config`` (default :class:`SuctionConfig`); ``config`` itself when it chose none.

    :raises ValueError: ``grasp`` names a cup that ``config`` does not offer
    """
    cfg = config or SuctionConfig()
    if grasp.cup_radius is None:
        return cfg
    for cup in cup_sizes(cfg):
        if abs(cup.cup_radius - grasp.cup_radius) < 1e-9:
            return cup
    raise ValueError(f"the grasp's {1000 * 2 * grasp.cup_radius:g} mm cup is not one of the configured cups "
                     f"{[round(1000 * 2 * c.cup_radius, 1) for c in cup_sizes(cfg)]} mm")


def largest_hold(config: SuctionConfig) -> float:
    """The largest steady pull (N) the cup passes on to the part along the face's normal: the carriage's
    largest pull (:func:`~spark_bench.manipulation.gripper.largest_pull`) or the cup's holding force, the smaller."""
    return float(min(largest_pull(config), config.max_force))


def add_suction(spec: mujoco.MjSpec, approach: np.ndarray, closing: np.ndarray,
                wrist_axis: np.ndarray | None = None, workspace: np.ndarray | None = None,
                config: SuctionConfig | None = None) -> SuctionHandles:
    """Add the floating suction cup to ``spec`` (in place) and return the names of its parts.

    :param spec: the scene; the cup's bodies are children of its world body
    :param approach: world direction from the cup's stalk to its face (towards the object)
    :param closing: any world direction across the approach (fixes the hand frame's y)
    :param wrist_axis: world axis of a passive wrist hinge through the cup's face, or None for a rigid wrist
    :param workspace: ``[[min], [max]]`` world box the TCP may reach (the slide joints' ranges)
    :param config: dimensions and holding force
    """
    cfg = config or SuctionConfig()
    rotation = hand_rotation(approach, closing)
    workspace = np.array([[-2.0] * 3, [2.0] * 3]) if workspace is None else workspace
    carriage, slides, servos = add_carriage(spec, workspace, cfg)
    hand = carriage.add_body(name=f"{PREFIX}_hand", quat=rotation_quat(rotation), gravcomp=1.0)
    wrist = add_wrist(hand, rotation, wrist_axis, cfg)
    along_x = rotation_quat(hand_rotation([0, 0, 1], [0, 1, 0]))  # a cylinder's axis (its z) along the hand's x
    half = cfg.cup_length / 2
    cup = hand.add_geom(name=f"{PREFIX}_cup", type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=[-half, 0, 0], quat=along_x,
                        size=[cfg.cup_radius, half, 0], mass=0.1, rgba=list(cfg.rgba), contype=2, conaffinity=1,
                        friction=[cfg.friction, 0.02, 0.001], condim=4, priority=1)
    hand.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=[-cfg.cup_length - 0.04, 0, 0], quat=along_x,
                  size=[0.008, 0.04, 0], mass=0.3, rgba=list(cfg.rgba), contype=0, conaffinity=0)
    hand.add_site(name=f"{PREFIX}_cup_site", type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=[-0.002, 0, 0], quat=along_x,
                  size=[cfg.cup_radius + 0.002, 0.004, 0], rgba=[0, 0, 0, 0])
    sensor = spec.add_sensor(name=f"{PREFIX}_touch_cup", type=mujoco.mjtSensor.mjSENS_TOUCH,
                             objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"{PREFIX}_cup_site")
    act = spec.add_actuator(name=f"{PREFIX}_suction", target=hand.name, trntype=mujoco.mjtTrn.mjTRN_BODY)
    act.set_to_adhesion(gain=cfg.max_force)
    act.ctrlrange = [0.0, 1.0]
    return SuctionHandles(slide_joints=tuple(slides), wrist_joint=wrist, slide_actuators=tuple(servos), suction_actuator=act.name,
                          hand_body=hand.name, cup_geom=cup.name, touch_sensor=sensor.name, config=cfg)


def choose_end_effector(end_effector: str, declined: str | None) -> str:
    """The end-effector that opens a part: ``gripper`` or ``suction`` as asked; for ``auto`` the cup where
    the grasp planner declined the part for lack of something to pinch (:data:`SUCTION_DECLINES`), the
    gripper everywhere else (a handle, a notch, a tab; also a part declined for another reason, so that its
    reason stands).

    :param end_effector: one of :data:`~spark_bench.manipulation.end_effector.END_EFFECTORS`
    :param declined: why the planner declined the part (:attr:`~spark_bench.manipulation.grasp_target.GraspTarget.declined`)
    :raises ValueError: an unknown end-effector
    """
    if end_effector not in END_EFFECTORS:
        raise ValueError(f"end_effector must be one of {END_EFFECTORS}, got {end_effector!r}")
    if end_effector == EndEffector.AUTO:
        return "suction" if declined in SUCTION_DECLINES else "gripper"
    return end_effector


def cup_footprint(front, config: SuctionConfig, cell: float = NOTCH_CELL, level: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Where the cup's centre may go on the front face: cells (:func:`~spark_bench.manipulation.features.rasterise_front`)
    whose whole cup disc lies on the face, at least :data:`SIDE_CLEARANCE` from any of the part's surface
    standing :data:`PROUD` out of it. Returns ``(the cells' centres in the front plane (K, 2), the image)``.

    :param front: the part's :class:`~spark_bench.manipulation.features.Front`
    :param config: the cup (its radius)
    :param cell: the raster's cell, m
    :param level: the level (along the front's outward direction) of the face the cup sits on: the front
        face (default) or a flat face recessed behind it (:func:`recessed_levels`)
    """
    level = front.face if level is None else level
    image, lo = rasterise_front(front.part, front.outward, front.basis, level, cell)
    if image.size == 0:
        return np.zeros((0, 2)), image
    radius = int(np.ceil(config.cup_radius / cell))
    yy, xx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    disc = xx ** 2 + yy ** 2 <= radius ** 2
    # outside the raster is not face: erode with the border counted as empty
    inside = ndimage.binary_erosion(np.pad(image, radius + 1), structure=disc)[radius + 1:-radius - 1, radius + 1:-radius - 1]
    rows, cols = np.nonzero(inside)
    centres = lo + (np.stack([rows, cols], axis=1) + 0.5) * cell
    proud = front.points[front.points @ front.outward > level + PROUD] @ front.basis.T
    if len(proud) and len(centres):
        from scipy.spatial import cKDTree

        near, _ = cKDTree(proud).query(centres, distance_upper_bound=config.cup_radius + SIDE_CLEARANCE)
        centres = centres[~np.isfinite(near)]
    return centres, inside


def recessed_levels(front, config: SuctionConfig) -> list[float]:
    """Levels of flat faces recessed behind the front face, front-most first: a microwave door's glass 15 mm
    behind a frame too narrow for the cup. A level counts when faces facing out cover at least a cup's disc
    there, no deeper than the cup's length (:attr:`SuctionConfig.cup_length`: the bellows reach in; the way
    in is checked as for any place, :func:`~spark_bench.manipulation.pads.approach_blocked`)."""
    part, n = front.part, front.outward
    level = np.asarray(part.triangles).mean(1) @ n
    facing = (part.face_normals @ n > 0.95) & (level < front.face - 2 * LEVEL_BIN) \
        & (level > front.face - config.cup_length)
    if not facing.any():
        return []
    bins = np.arange(front.face - config.cup_length, front.face + LEVEL_BIN, LEVEL_BIN)
    area, edges = np.histogram(level[facing], bins=bins, weights=part.area_faces[facing])
    disc = np.pi * config.cup_radius ** 2
    return [float(0.5 * (edges[k] + edges[k + 1])) for k in np.flatnonzero(area >= disc)[::-1]]


def suction_point(front, config: SuctionConfig) -> np.ndarray | None:
    """The cup's place on the front face (world, at rest), or None when no flat patch holds the cup: of the
    places :func:`cup_footprint` allows, the most central on a drawer, the farthest from the hinge on a door
    or lid (the longest lever; :meth:`~spark_bench.manipulation.features.Front.point_scores`), and of those within
    :data:`LEVER_TOLERANCE` of it the one nearest the middle of the allowed places (a door's free edge is a
    line of equally good places: its middle, not a corner). Where the front face has no such place, the
    flat faces recessed behind it are tried, front-most first (:func:`recessed_levels`)."""
    for level in [front.face] + recessed_levels(front, config):
        centres, _ = cup_footprint(front, config, level=level)
        if len(centres):
            break
    else:
        return None
    points = centres @ front.basis + level * front.outward
    scores = front.point_scores(points)
    near_best = points[scores <= scores.min() + LEVER_TOLERANCE]
    middle = np.linalg.norm(near_best - points.mean(0), axis=1)
    return near_best[int(np.argmin(middle))]


def flat_patch_reason(joint: str, part: str, config: SuctionConfig) -> str:
    """The one-line reason of a part whose front has no place for any of the cups (:func:`cup_sizes`)."""
    smallest = cup_sizes(config)[-1]
    return (f"{joint}: no flat patch {1000 * 2 * smallest.cup_radius:.0f} mm across on the {part}'s front for the "
            f"smallest suction cup (within {1000 * LEVEL_BIN:.0f} mm of its face level or of a flat face up to "
            f"{1000 * config.cup_length:.0f} mm behind it, clear of what stands out of it)")


def approach_config(config: SuctionConfig) -> GripperConfig:
    """The gripper dimensions under which the planner's approach check
    (:func:`~spark_bench.manipulation.pads.approach_blocked`) tests the cup's way in: rays from the cup's rim from its
    face out."""
    return GripperConfig(max_opening=config.cup_radius, finger_length=PROUD + 0.002, tip_beyond_tcp=0.0)


def plan_suction(asset, joint: str, config: SuctionConfig | None = None, seed: int = 0,
                 outward: np.ndarray | None = None):
    """The cup's grasp on the part moved by ``joint``, world frame at rest: a
    :class:`~spark_bench.manipulation.grasp_target.GraspTarget` with ``source="suction"``, ``grip="suction"``, the point
    :func:`suction_point` chose, the front's outward direction and the cup's radius (``cup_radius``: the
    largest of :func:`cup_sizes` with a place and a clear way in, the strongest hold; :func:`fitted_cup`); its
    ``reason`` says why no cup can hold the part (no flat patch for the smallest, or the object in the way in
    of the largest that has a place), else None.

    :param asset: the object (or a :class:`~spark_bench.manipulation.rest_meshes.RestMeshes` of it)
    :param joint: a movable joint's name
    :param config: the cup (default :class:`SuctionConfig`) and its smaller fallbacks
    :param seed: seed of the surface sampling
    :param outward: the front's direction where the gripper's planner took another face than the part's
        front (a plate's broad face, :func:`~spark_bench.manipulation.plate_front.plate_face`); None: the front
    :raises ValueError: the part has no geometry, or its centroid lies on its hinge
    """
    from spark_bench.manipulation.grasp import APPROACH_CLEAR, part_front, part_name
    from spark_bench.manipulation.grasp_target import GraspTarget
    from spark_bench.manipulation.pads import approach_blocked
    from spark_bench.manipulation.rest_meshes import RestMeshes

    cfg = config or SuctionConfig()
    rest = asset if isinstance(asset, RestMeshes) else RestMeshes(asset)
    front = part_front(rest, joint, seed, outward)
    along = front.basis[0] if front.rotational else front.basis[1]
    first_blocked = None
    for cup in cup_sizes(cfg):
        point = suction_point(front, cup)
        if point is None:
            continue
        grasp = GraspTarget(point=point, outward=front.outward, long_axis=along, has_handle=False, source="suction",
                            grip="suction", cup_radius=cup.cup_radius, broad_face=outward is not None)
        blocked = approach_blocked(rest, grasp, approach_config(cup), APPROACH_CLEAR)
        if blocked is None:
            return grasp
        if first_blocked is None:
            link, distance, _ = blocked
            what = (rest.links[link].label or link).replace("_", " ")
            grasp.reason = (f"{joint}: the {what} stands in the {1000 * 2 * cup.cup_radius:.0f} mm suction cup's way "
                            f"to the {part_name(rest, joint)}, {1000 * distance:.0f} mm in front of its face")
            first_blocked = grasp
    if first_blocked is not None:
        return first_blocked
    return GraspTarget(point=front.points.mean(0), outward=front.outward, long_axis=along, has_handle=False,
                       source="suction", grip="suction", broad_face=outward is not None,
                       reason=flat_patch_reason(joint, part_name(rest, joint), cfg))
