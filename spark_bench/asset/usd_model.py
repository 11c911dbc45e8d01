"""A USD stage's UsdPhysics articulation as an :class:`~spark_bench.asset.model.ArticulatedAsset`, read with
``usd-core`` (no Isaac Sim).

What is read, and the facts of the format it relies on (UsdPhysics schema, ``pxr/usd/usdPhysics``):

- units and frame: the stage's ``metersPerUnit`` scales every length (limits of prismatic joints included);
  ``upAxis`` Y is turned to spark-bench's Z up (+90 degrees about X); ``kilogramsPerUnit`` scales masses;
- bodies: every prim with ``RigidBodyAPI``; its geometry is the ``UsdGeom.Mesh`` (and Cube, Sphere,
  Cylinder, Capsule) prims below it, down to the next rigid body (the URDF -> USD converter nests child
  links under their parents; Infinigen-Sim writes them side by side); a prim with ``CollisionAPI`` is a
  collision shape, any other (purpose not ``guide``) a visual; ``MassAPI``'s ``physics:mass`` where
  authored is kept in the link's ``annotations["mass"]`` (kg);
- joints: ``PhysicsRevoluteJoint``, ``PhysicsPrismaticJoint`` and ``PhysicsFixedJoint``, ``body0`` the
  parent, ``body1`` the child; the frame of the joint on each body is ``localPos``/``localRot`` in that
  body's space; the axis is the token X, Y or Z of that frame (so its direction is carried by the local
  rotations); revolute limits are **degrees**, prismatic limits stage units; a revolute joint without
  limits is continuous; a joint with no rigid body on one side welds to the world (a fixed base);
- the articulation: the root is the body no joint hangs from (the one carrying ``ArticulationRootAPI``
  when several are);
- the child's link frame is its joint frame at the pose as authored, so forward kinematics at the authored
  joint value puts every mesh where the stage draws it; a joint whose range ends at 0 (``[-a, 0]``: how
  Infinigen-Sim writes a joint about a negative axis) is read as ``[0, a]`` about the opposite axis (the
  same motion), so that its rest, spark-bench's lower limit, is the pose as authored.

What it cannot map is an :class:`~spark_bench.errors.InputError` naming the prim: a D6 (generic
``PhysicsJoint``), spherical or distance joint; a joint drive that actuates (a stiffness or a target
velocity) on a joint without limits; a prismatic joint
without limits; an instanced prim (its geometry lives in a prototype the articulation does not own); a mesh
with no points or faces, or a referenced file that does not resolve.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.errors import InputError

AXES = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
#: Y-up stages are turned +90 degrees about X: their +Y becomes +Z.
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
GRAY = (0.7, 0.7, 0.7, 1.0)


def _pxr():
    try:
        from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdUtils
    except ImportError:  # declared in pyproject; a trimmed install may lack it
        raise InputError(None, "reading USD needs usd-core (pip install usd-core)") from None
    return Gf, Usd, UsdGeom, UsdPhysics, UsdUtils


class StageFrame:
    """Stage units and up axis -> metres, Z up.

    :param meters: the stage's ``metersPerUnit``
    :param turn: 3x3 rotation to Z up
    """

    def __init__(self, meters: float, turn: np.ndarray):
        self.meters, self.turn = meters, turn

    def matrix(self, prim) -> np.ndarray:
        """The prim's local-to-world 4x4 (column vectors), in metres, Z up (scale kept)."""
        _, Usd, UsdGeom, _, _ = _pxr()
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


def open_stage(path: Path):
    """The stage of ``path``, after checking that every file it references resolves.

    :raises InputError: unreadable, or a referenced layer or asset is missing
    """
    _, Usd, _, _, UsdUtils = _pxr()
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "no such USD file")
    try:
        stage = Usd.Stage.Open(str(path))
    except Exception as exc:  # pxr raises Tf errors of its own type
        raise InputError(path, f"cannot open USD: {' '.join(str(exc).split())[:300]}") from None
    if stage is None:
        raise InputError(path, "cannot open USD")
    _, _, unresolved = UsdUtils.ComputeAllDependencies(str(path))
    if unresolved:
        raise InputError(path, f"referenced file(s) not found: {', '.join(sorted(map(str, unresolved))[:5])}")
    return stage


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


def _name(prim, used: set[str]) -> str:
    """The prim's name as spark-bench wrote it (``spark:name``) or its USD name, unique in ``used``."""
    attribute = prim.GetAttribute("spark:name")
    base = str(attribute.Get()) if attribute and attribute.HasAuthoredValue() else prim.GetName()
    name, k = base, 1
    while name in used:
        name, k = f"{base}_{k}", k + 1
    used.add(name)
    return name


def _target(joint, side: int, bodies: dict, path: Path):
    """The rigid body prim on ``side`` of a joint, or None (the world)."""
    rel = joint.GetBody0Rel() if side == 0 else joint.GetBody1Rel()
    targets = rel.GetTargets()
    if not targets:
        return None
    if len(targets) > 1:
        raise InputError(path, f"joint {joint.GetPath()}: body{side} names {len(targets)} prims")
    return bodies.get(targets[0])  # a target that is no rigid body is a static anchor: the world


def _kind(prim, path: Path) -> str:
    """Our joint type of a UsdPhysics joint prim; an error naming the prim for one we cannot map."""
    from pxr import UsdPhysics

    if prim.IsA(UsdPhysics.RevoluteJoint):
        return "revolute"
    if prim.IsA(UsdPhysics.PrismaticJoint):
        return "prismatic"
    if prim.IsA(UsdPhysics.FixedJoint):
        return "fixed"
    kind = prim.GetTypeName() or "PhysicsJoint"
    what = "a D6 joint (generic PhysicsJoint)" if kind == "PhysicsJoint" else f"a {kind}"
    raise InputError(path, f"joint {prim.GetPath()} is {what}: only revolute, prismatic and fixed joints "
                           "make an articulated object")


def _limits(prim, kind: str, frame: StageFrame, path: Path) -> tuple[str, float, float, bool]:
    """``(type, lower, upper, has_limits)`` in radians or metres."""
    from pxr import UsdPhysics

    if kind == JointType.FIXED:
        return kind, 0.0, 0.0, True
    usd = UsdPhysics.RevoluteJoint(prim) if kind == JointType.REVOLUTE else UsdPhysics.PrismaticJoint(prim)
    lower, upper = usd.GetLowerLimitAttr().Get(), usd.GetUpperLimitAttr().Get()
    bounded = lower is not None and upper is not None and math.isfinite(lower) and math.isfinite(upper)
    if not bounded:
        motor = _motor_drive(prim)
        if motor:
            raise InputError(path, f"joint {prim.GetPath()} has a drive ({motor}) but no limits: a driven "
                                   "joint without range is a motor, not a part's articulation")
        if kind == JointType.PRISMATIC:
            raise InputError(path, f"joint {prim.GetPath()}: a prismatic joint without limits")
        return "continuous", 0.0, 2.0 * math.pi, False
    if upper < lower:
        raise InputError(path, f"joint {prim.GetPath()}: upper limit {upper} below lower {lower}")
    scale = math.pi / 180.0 if kind == JointType.REVOLUTE else frame.meters
    return kind, float(lower) * scale, float(upper) * scale, True


def _motor_drive(prim) -> str:
    """The first drive of a joint that actuates it (a stiffness or a target velocity), "" for none: a drive of
    stiffness 0 and no target velocity is a damper (how spark-bench and the URDF importers write damping)."""
    from pxr import UsdPhysics

    for schema in prim.GetAppliedSchemas():
        if not schema.startswith("PhysicsDriveAPI:"):
            continue
        drive = UsdPhysics.DriveAPI(prim, schema.split(":", 1)[1])
        if (drive.GetStiffnessAttr().Get() or 0.0) != 0.0 or (drive.GetTargetVelocityAttr().Get() or 0.0) != 0.0:
            return schema
    return ""


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
        _kind(prim, path)
        enabled.append(prim)
    return bodies, enabled


def read_usd(path: str | Path) -> ArticulatedAsset:
    """Read the articulation of a USD file (see the module docstring).

    :param path: a ``.usd``, ``.usda``, ``.usdc`` or ``.usdz`` file
    :raises InputError: naming the file and the prim for everything it cannot map
    """
    _, _, UsdGeom, UsdPhysics, _ = _pxr()
    path = Path(path)
    stage = open_stage(path)
    _check_instances(stage, path)
    up = str(UsdGeom.GetStageUpAxis(stage))
    frame = StageFrame(float(UsdGeom.GetStageMetersPerUnit(stage)), Y_UP_TO_Z_UP if up == "Y" else np.eye(3))
    bodies, joint_prims = _articulation(stage, path)
    used: set[str] = set()
    names = {p: _name(prim, used) for p, prim in bodies.items()}
    hanging: dict = {}  # child body path -> (joint prim, parent body prim or None)
    for prim in joint_prims:
        joint = UsdPhysics.Joint(prim)
        parent, child = _target(joint, 0, bodies, path), _target(joint, 1, bodies, path)
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
    welded = [p for p, (prim, parent) in hanging.items() if parent is None and _kind(prim, path) == JointType.FIXED]
    for p in welded:  # a fixed base: the body is the articulation's root
        del hanging[p]
    world_joints = [p for p, (_, parent) in hanging.items() if parent is None]
    roots = [p for p in bodies if p not in hanging]
    if world_joints or len(roots) > 1:
        raise InputError(path, "the rigid bodies do not form one articulation hanging from one root: "
                               + (f"joint {hanging[world_joints[0]][0].GetPath()} moves a body against the world"
                                  if world_joints else f"unconnected bodies {[str(r) for r in roots[:4]]}"))
    asset = _assemble(path, stage, frame, bodies, names, hanging, roots[0])
    asset.meta["usd"] = {"up_axis": up, "meters_per_unit": frame.meters,
                         "kilograms_per_unit": float(UsdPhysics.GetStageKilogramsPerUnit(stage))}
    return asset


def _assemble(path: Path, stage, frame: StageFrame, bodies: dict, names: dict, hanging: dict, root) -> ArticulatedAsset:
    """The asset: link frames (the world for the root; a child's joint frame as authored), geometry, joints."""
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
            if _kind(prim, path) == JointType.FIXED:
                link_frames[child] = frame.pose(bodies[child])
            else:
                link_frames[child] = _joint_frame(joint, 1, bodies[child], frame)
            order.append(child)
    links, joints, used = {}, {}, set()
    for p in order:
        link = _body_geometry(bodies[p], set(bodies), frame, link_frames[p], path)
        link.name, link.label = names[p], bodies[p].GetName()
        mass = UsdPhysics.MassAPI(bodies[p]).GetMassAttr().Get() if bodies[p].HasAPI(UsdPhysics.MassAPI) else None
        if mass:
            link.annotations["mass"] = float(mass) * float(UsdPhysics.GetStageKilogramsPerUnit(stage))
        links[link.name] = link
    for p in order[1:]:
        prim, parent = hanging[p]
        kind, lower, upper, has_limits = _limits(prim, _kind(prim, path), frame, path)
        parent_frame = link_frames[parent.GetPath()]
        if kind == JointType.FIXED:
            origin, axis = np.linalg.inv(parent_frame) @ link_frames[p], np.array([1.0, 0, 0])
        else:
            origin = np.linalg.inv(parent_frame) @ _joint_frame(UsdPhysics.Joint(prim), 0, parent, frame)
            token = str((UsdPhysics.RevoluteJoint if kind != JointType.PRISMATIC else UsdPhysics.PrismaticJoint)(prim)
                        .GetAxisAttr().Get())
            axis = AXES[token]
        if kind != JointType.FIXED and has_limits and lower < 0.0 and abs(upper) <= 1e-12:
            # a range ending at 0 (Infinigen-Sim negates the range of a joint about a negative axis): the same
            # motion about the opposite axis, so that its rest (the lower limit) is the pose as authored
            axis, lower, upper = -axis, -upper, -lower
        name = _name(prim, used)
        joints[name] = Joint(name, kind, names[parent.GetPath()], names[p], origin, axis, lower, upper,
                             has_limits=has_limits)
    default = stage.GetDefaultPrim()
    name = _name(default, set()) if default else path.stem
    return ArticulatedAsset(name=name, links=links, joints=joints, source=str(path))
