"""A USD stage's UsdPhysics articulation as an :class:`~spark_bench.asset.model.ArticulatedAsset`, read with
``usd-core`` (no Isaac Sim).

Three writers' layouts are read as they ship: spark-bench's own export (:mod:`spark_bench.sim.export_usd`),
Infinigen-Sim's (``princeton-vl/infinigen`` ``usd_exporter.py``: flat links, ``visual/`` and ``collision/``
scopes, joints in ``/Asset/Joints``) and Isaac Sim's URDF importer's (``isaac-sim/urdf-importer-extension``
``UrdfImporter.cpp``, GenSim2's ``mobility.usd``: binary crate 0.7.0, ``PhysxSchema`` alongside UsdPhysics, a
``PhysicsDriveAPI`` on every joint, one joint prim under each parent link, ``root_joint`` to the world,
``Looks`` with MDL shaders); the URDF -> USD converter's nested layout too. What is read, and the facts of the
format it relies on (UsdPhysics schema, ``pxr/usd/usdPhysics``):

- opening the stage (:mod:`.usd_stage`): usd-core's messages are kept out of the terminal (the crate deprecation
  of Isaac's 0.7.0 files recorded as ``meta["usd"]["crate_version"]``); ``metersPerUnit`` and
  ``kilogramsPerUnit`` must be positive and finite; a material's, shader's or texture's file that does not
  resolve (Isaac's ``OmniPBR.mdl``) is a warning (``asset.warnings``), never a refusal; a sublayer, reference or
  payload that cannot be composed (missing, not USD, a cycle) is a warning, or an error where what it held is
  needed: an arc on a rigid body or below it, on a joint, on (or above) a prim a joint names as its body that
  is no rigid body, or above a rigid body without geometry; and any error the reading runs into names the arcs
  that could not be composed;
- units and frame: the stage's ``metersPerUnit`` scales every length (limits of prismatic joints included);
  ``upAxis`` Y is turned to spark-bench's Z up (+90 degrees about X); ``kilogramsPerUnit`` scales masses;
- bodies: every prim with ``RigidBodyAPI``; its geometry is the ``UsdGeom.Mesh`` (and Cube, Sphere,
  Cylinder, Capsule) prims below it, down to the next rigid body (the URDF -> USD converter nests child
  links under their parents; Infinigen-Sim writes them side by side); a prim with ``CollisionAPI`` is a
  collision shape, any other (purpose not ``guide``) a visual; ``MassAPI``'s ``physics:mass`` where
  authored is kept in the link's ``annotations["mass"]`` (kg); materials and ``PhysxSchema`` attributes are
  not read;
- names: a link or joint is named as its prim (``spark:name`` where spark-bench wrote one); prims whose names
  repeat are named by their paths from the first segment that tells them apart, ``/`` written ``:`` (link
  names become file names);
- joints: ``PhysicsRevoluteJoint``, ``PhysicsPrismaticJoint`` and ``PhysicsFixedJoint``, ``body0`` the
  parent, ``body1`` the child; the frame of the joint on each body is ``localPos``/``localRot`` in that
  body's space; the axis is the token X, Y or Z of that frame (so its direction is carried by the local
  rotations); revolute limits are **degrees**, prismatic limits stage units; a revolute joint without
  limits is continuous, and so is one whose only drive is the position drive Isaac Sim's URDF importer puts on
  every joint it writes (``PhysxJointAPI`` applied, targets 0: how the importer writes a URDF ``continuous``
  joint, "continuous and revolute are identical except for setting limits"); a joint with no rigid body on one
  side welds to the world (a fixed base, Isaac's and Infinigen's ``root_joint``);
- the articulation: the root is the body no joint hangs from (the one carrying ``ArticulationRootAPI``
  when several are);
- the child's link frame is its joint frame at the pose as authored, so forward kinematics at the authored
  joint value puts every mesh where the stage draws it; which way each joint opens is read from where the
  authored pose sits in its range (:mod:`spark_bench.asset.opening_direction`: a range ending at 0, ``[-a, 0]``,
  as Infinigen-Sim writes a joint about a negative axis and Isaac's importer a PartNet-Mobility door, is read as
  ``[0, a]`` about the opposite axis, the same motion, so that its rest, spark-bench's lower limit, is the pose
  as authored).

What it cannot map is an :class:`~spark_bench.errors.InputError` naming the prim: a D6 (generic
``PhysicsJoint``), spherical or distance joint; a joint drive that actuates (a stiffness or a target
velocity) on a joint without limits, other than Isaac's importer's; a prismatic joint without limits; an
instanced prim (its geometry lives in a prototype the articulation does not own); a mesh with no points or
faces; an arc whose content is needed (above).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.asset.opening_direction import orient_joints
from spark_bench.asset.usd_joints import body_target, joint_kind, joint_limits, prim_names, written_name
from spark_bench.asset.usd_stage import (
    StageReading,
    needed_arcs,
    pxr_modules,
    quiet_usd,
    read_stage,
    usd_core_warnings,
)
from spark_bench.errors import InputError

logger = logging.getLogger(__name__)
AXES = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
#: Y-up stages are turned +90 degrees about X: their +Y becomes +Z.
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
GRAY = (0.7, 0.7, 0.7, 1.0)
#: ``(file, warning)`` pairs already logged in this process: an object is read once per episode.
_LOGGED: set[tuple[str, str]] = set()


class StageFrame:
    """Stage units and up axis -> metres, Z up.

    :param meters: the stage's ``metersPerUnit``
    :param turn: 3x3 rotation to Z up
    """

    def __init__(self, meters: float, turn: np.ndarray):
        self.meters, self.turn = meters, turn

    def matrix(self, prim) -> np.ndarray:
        """The prim's local-to-world 4x4 (column vectors), in metres, Z up (scale kept)."""
        _, Usd, UsdGeom, _, _ = pxr_modules()
        gf = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        matrix = np.array(gf, dtype=float).T
        out = np.eye(4)
        out[:3, :3] = self.meters * self.turn @ matrix[:3, :3]
        out[:3, 3] = self.meters * self.turn @ matrix[:3, 3]
        return out

    def pose(self, prim) -> np.ndarray:
        """The prim's rigid pose (rotation without its scale), metres, Z up."""
        matrix = self.matrix(prim)
        u, _, vt = np.linalg.svd(matrix[:3, :3])
        rotation = u @ vt
        if np.linalg.det(rotation) < 0:
            rotation = -rotation
        out = np.eye(4)
        out[:3, :3], out[:3, 3] = rotation, matrix[:3, 3]
        return out


def _check_instances(stage, path: Path) -> None:
    for prim in stage.Traverse():
        if prim.IsInstance():
            raise InputError(path, f"prim {prim.GetPath()} is instanced: its geometry lives in a shared prototype "
                                   "the articulation does not own (make it uninstanceable)")


def _faces(prim, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A mesh prim's points and triangles (polygons fanned)."""
    from pxr import UsdGeom

    mesh = UsdGeom.Mesh(prim)
    points = mesh.GetPointsAttr().Get()
    counts = mesh.GetFaceVertexCountsAttr().Get()
    indices = mesh.GetFaceVertexIndicesAttr().Get()
    if points is None or len(points) == 0 or counts is None or len(counts) == 0 or indices is None:
        raise InputError(path, f"mesh prim {prim.GetPath()} has no points or faces")
    points, counts, indices = np.asarray(points, float), np.asarray(counts, int), np.asarray(indices, int)
    if counts.sum() != len(indices) or (len(indices) and (indices.min() < 0 or indices.max() >= len(points))):
        raise InputError(path, f"mesh prim {prim.GetPath()}: face indices do not match its points")
    triangles, start = [], 0
    for count in counts:
        triangles.extend((indices[start], indices[start + k], indices[start + k + 1]) for k in range(1, count - 1))
        start += count
    if not triangles:
        raise InputError(path, f"mesh prim {prim.GetPath()} has no faces with three or more vertices")
    return points, np.asarray(triangles, int)


def _gprim_mesh(prim, path: Path) -> trimesh.Trimesh | None:
    """A mesh or primitive gprim in its own frame, None for a prim that is not geometry."""
    from pxr import UsdGeom

    if prim.IsA(UsdGeom.Mesh):
        points, faces = _faces(prim, path)
        return trimesh.Trimesh(points, faces, process=False)
    if prim.IsA(UsdGeom.Cube):
        return trimesh.creation.box(extents=[float(UsdGeom.Cube(prim).GetSizeAttr().Get())] * 3)
    if prim.IsA(UsdGeom.Sphere):
        return trimesh.creation.icosphere(subdivisions=2, radius=float(UsdGeom.Sphere(prim).GetRadiusAttr().Get()))
    for kind, make in ((UsdGeom.Cylinder, trimesh.creation.cylinder), (UsdGeom.Capsule, trimesh.creation.capsule)):
        if prim.IsA(kind):
            shape = kind(prim)
            radius, height = float(shape.GetRadiusAttr().Get()), float(shape.GetHeightAttr().Get())
            mesh = make(radius=radius, height=height)
            axis = str(shape.GetAxisAttr().Get())
            if axis != "Z":  # trimesh builds along Z
                turn = {"X": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], "Y": [[1, 0, 0], [0, 0, 1], [0, -1, 0]]}[axis]
                mesh.vertices = mesh.vertices @ np.asarray(turn, float).T
            return mesh
    return None


def _body_geometry(body, bodies: set, frame: StageFrame, link_frame: np.ndarray, path: Path) -> Link:
    """The visuals and collisions below ``body`` (down to the next rigid body), in ``link_frame``."""
    from pxr import Usd, UsdGeom, UsdPhysics

    link = Link(name="")
    to_link = np.linalg.inv(link_frame)
    iterator = iter(Usd.PrimRange(body))
    for prim in iterator:
        if prim != body and prim.GetPath() in bodies:
            iterator.PruneChildren()
            continue
        mesh = _gprim_mesh(prim, path)
        if mesh is None:
            continue
        world = frame.matrix(prim)
        mesh.apply_transform(to_link @ world)
        color = UsdGeom.Gprim(prim).GetDisplayColorAttr().Get()
        rgba = (*[float(c) for c in color[0]], 1.0) if color else GRAY
        if prim.HasAPI(UsdPhysics.CollisionAPI):
            link.collisions.append(Collision("mesh", mesh=mesh, source=str(prim.GetPath())))
        elif UsdGeom.Imageable(prim).ComputePurpose() != UsdGeom.Tokens.guide:
            link.visuals.append(Visual(mesh, rgba=rgba, source=str(prim.GetPath())))
    if not link.visuals:  # a body drawn by its collision shapes only
        link.visuals = [Visual(c.mesh.copy(), rgba=GRAY, source=c.source) for c in link.collisions]
    return link


def _joint_frame(joint, side: int, prim, frame: StageFrame) -> np.ndarray:
    """World frame (4x4, metres) of the joint on body ``side`` (0 or 1), the rigid body ``prim``."""
    from pxr import Gf

    position = joint.GetLocalPos0Attr().Get() if side == 0 else joint.GetLocalPos1Attr().Get()
    rotation = joint.GetLocalRot0Attr().Get() if side == 0 else joint.GetLocalRot1Attr().Get()
    position = np.zeros(3) if position is None else np.asarray(position, float)
    quat = Gf.Quatd(rotation) if rotation is not None else Gf.Quatd(1.0)
    local = np.eye(4)
    local[:3, :3] = np.array(Gf.Matrix3d(Gf.Rotation(quat)), dtype=float).T
    local[:3, 3] = position
    matrix, pose = frame.matrix(prim), frame.pose(prim)
    out = np.eye(4)
    out[:3, :3] = pose[:3, :3] @ local[:3, :3]
    out[:3, 3] = matrix[:3, :3] @ position + matrix[:3, 3]  # the body's scale applies to its local position
    return out


def _articulation(stage, path: Path):
    """``(bodies by path, joint prims)`` of the stage."""
    from pxr import UsdPhysics

    bodies = {p.GetPath(): p for p in stage.Traverse() if p.HasAPI(UsdPhysics.RigidBodyAPI)}
    if not bodies:
        raise InputError(path, "no rigid body (no prim has UsdPhysics RigidBodyAPI)")
    joints = [p for p in stage.Traverse() if p.IsA(UsdPhysics.Joint)]
    enabled = []
    for prim in joints:
        flag = UsdPhysics.Joint(prim).GetJointEnabledAttr().Get()
        if flag is False:
            continue
        joint_kind(prim, path)
        enabled.append(prim)
    return bodies, enabled


def read_usd(path: str | Path) -> ArticulatedAsset:
    """Read the articulation of a USD file (see the module docstring); usd-core's own messages stay out of the
    terminal, what was left out is ``asset.warnings`` (each also logged once per process).

    :param path: a ``.usd``, ``.usda``, ``.usdc`` or ``.usdz`` file
    :raises InputError: naming the file and the prim for everything it cannot map
    """
    path = Path(path)
    with quiet_usd() as diagnostics:
        reading = read_stage(path)
        try:
            asset = _read_articulation(path, reading)
        except InputError as exc:
            if not reading.broken or any(f"@{arc.target}@" in exc.problem for arc in reading.broken):
                raise
            arcs = "; ".join(arc.describe() for arc in reading.broken[:3])
            raise InputError(path, f"{exc.problem} (the stage was composed without what these held: {arcs})") from None
    asset.warnings.extend(usd_core_warnings(diagnostics))
    for warning in asset.warnings:
        if (str(path), warning) not in _LOGGED:
            _LOGGED.add((str(path), warning))
            logger.warning("%s: %s", path, warning)
    return asset


def _read_articulation(path: Path, reading: StageReading) -> ArticulatedAsset:
    """The articulation of an opened stage: its bodies hung from one root by their joints, then assembled."""
    from pxr import UsdPhysics

    stage = reading.stage
    _check_instances(stage, path)
    frame = StageFrame(reading.meters, Y_UP_TO_Z_UP if reading.up == "Y" else np.eye(3))
    bodies, joint_prims = _articulation(stage, path)
    needed = needed_arcs(reading.broken, bodies, joint_prims, stage)
    if needed:
        arc, why = needed[0]
        raise InputError(path, f"{arc.describe()}: it holds part of {why}, which the articulation needs")
    hanging: dict = {}  # child body path -> (joint prim, parent body prim or None)
    for prim in joint_prims:
        joint = UsdPhysics.Joint(prim)
        parent, child = body_target(joint, 0, bodies, path), body_target(joint, 1, bodies, path)
        if child is None:
            if parent is None:
                raise InputError(path, f"joint {prim.GetPath()} joins no rigid body")
            raise InputError(path, f"joint {prim.GetPath()}: body1 is the world and body0 {parent.GetPath()}: "
                                   "write the world as body0")
        if child.GetPath() in hanging:
            first = hanging[child.GetPath()][0].GetPath()
            raise InputError(path, f"body {child.GetPath()} is body1 of two joints ({first}, {prim.GetPath()}): "
                                   "not a tree")
        hanging[child.GetPath()] = (prim, parent)
    welded = [p for p, (prim, parent) in hanging.items()
              if parent is None and joint_kind(prim, path) == JointType.FIXED]
    for p in welded:  # a fixed base: the body is the articulation's root
        del hanging[p]
    world_joints = [p for p, (_, parent) in hanging.items() if parent is None]
    roots = [p for p in bodies if p not in hanging]
    if world_joints or len(roots) > 1:
        raise InputError(path, "the rigid bodies do not form one articulation hanging from one root: "
                               + (f"joint {hanging[world_joints[0]][0].GetPath()} moves a body against the world"
                                  if world_joints else f"unconnected bodies {[str(r) for r in roots[:4]]}"))
    asset, continuous, drawn = _assemble(path, reading, frame, bodies, hanging, roots[0])
    asset.warnings.extend([arc.describe() + ": what it holds is not read" for arc in reading.broken])
    asset.warnings.extend(reading.warnings)
    opening = orient_joints(asset, drawn)
    asset.meta["usd"] = {"up_axis": reading.up, "meters_per_unit": reading.meters,
                         "kilograms_per_unit": reading.kilograms}
    if reading.crate_version:
        asset.meta["usd"]["crate_version"] = reading.crate_version
    if continuous:
        asset.meta["usd"]["continuous"] = continuous
    asset.meta["opening_direction"] = [o.to_dict() for o in opening]
    return asset


def drawn_value(kind: str, side0: np.ndarray, side1: np.ndarray, axis: np.ndarray, lower: float, upper: float) -> float:
    """A joint's value in the pose the stage draws: the turn about (or the slide along) ``axis`` from its frame on
    body 0 to its frame on body 1 as the bodies are placed (0 where they meet, as Isaac Sim's importer and
    Infinigen-Sim write them; the lower limit in spark-bench's own export, whose bodies are placed at rest). An
    angle is taken in the turn nearest the range.

    :param kind: the joint's type
    :param side0: the joint's world frame on body 0 (4x4)
    :param side1: its world frame on body 1 (4x4)
    :param axis: the unit axis in those frames
    :param lower: the lower limit (radians or metres)
    :param upper: the upper limit
    """
    relative = np.linalg.inv(side0) @ side1
    if kind == JointType.PRISMATIC:
        return float(relative[:3, 3] @ axis)
    turn = relative[:3, :3]
    skew = 0.5 * (turn - turn.T)
    sine = float(axis @ np.array([skew[2, 1], skew[0, 2], skew[1, 0]]))
    angle = math.atan2(sine, 0.5 * (float(np.trace(turn)) - 1.0))
    turns = [angle + 2.0 * math.pi * k for k in range(-2, 3)]  # the one in the range, else the nearest to it
    return min(turns, key=lambda a: (max(lower - a, a - upper, 0.0), abs(a)))


def _assemble(path: Path, reading: StageReading, frame: StageFrame, bodies: dict, hanging: dict, root
              ) -> tuple[ArticulatedAsset, dict[str, str], dict[str, float]]:
    """The asset (link frames: the world for the root, a child's joint frame as authored; geometry; joints, each
    with its value 0 where its two frames meet), per joint read as continuous despite a drive why, and each limited
    joint's value in the pose the stage draws (:func:`drawn_value`)."""
    from pxr import UsdPhysics

    link_frames = {root: np.eye(4)}  # the asset's world: the root link is where the stage puts it
    order, pending = [root], dict(hanging)
    while pending:
        ready = [c for c, (_, parent) in pending.items() if parent.GetPath() in link_frames]
        if not ready:
            raise InputError(path, f"joints form a cycle through {[str(c) for c in list(pending)[:4]]}")
        for child in ready:
            prim, _ = pending.pop(child)
            joint = UsdPhysics.Joint(prim)
            if joint_kind(prim, path) == JointType.FIXED:
                link_frames[child] = frame.pose(bodies[child])
            else:
                link_frames[child] = _joint_frame(joint, 1, bodies[child], frame)
            order.append(child)
    names = prim_names([bodies[p] for p in order])
    links = {}
    for p in order:
        link = _body_geometry(bodies[p], set(bodies), frame, link_frames[p], path)
        link.name, link.label = names[p], bodies[p].GetName()
        mass = UsdPhysics.MassAPI(bodies[p]).GetMassAttr().Get() if bodies[p].HasAPI(UsdPhysics.MassAPI) else None
        if mass:
            link.annotations["mass"] = float(mass) * reading.kilograms
        links[link.name] = link
    joint_names = prim_names([hanging[p][0] for p in order[1:]])
    joints, continuous, drawn = {}, {}, {}
    for p in order[1:]:
        prim, parent = hanging[p]
        kind, lower, upper, has_limits, note = joint_limits(prim, joint_kind(prim, path), frame.meters, path)
        parent_frame = link_frames[parent.GetPath()]
        if kind == JointType.FIXED:
            origin, axis = np.linalg.inv(parent_frame) @ link_frames[p], np.array([1.0, 0, 0])
        else:
            side0 = _joint_frame(UsdPhysics.Joint(prim), 0, parent, frame)
            origin = np.linalg.inv(parent_frame) @ side0
            token = str((UsdPhysics.PrismaticJoint if kind == JointType.PRISMATIC else UsdPhysics.RevoluteJoint)(prim)
                        .GetAxisAttr().Get())
            axis = AXES[token]
            if has_limits:
                drawn[joint_names[prim.GetPath()]] = drawn_value(kind, side0, link_frames[p], axis, lower, upper)
        name = joint_names[prim.GetPath()]
        joints[name] = Joint(name, kind, names[parent.GetPath()], names[p], origin, axis, lower, upper,
                             has_limits=has_limits)
        if note:
            continuous[name] = note
    default = reading.stage.GetDefaultPrim()
    name = written_name(default) if default else path.stem
    return ArticulatedAsset(name=name, links=links, joints=joints, source=str(path)), continuous, drawn
