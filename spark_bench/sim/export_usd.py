"""The sim-ready USD: the prepared object as a UsdPhysics articulation (``usd-core``; Isaac Sim, Isaac Lab,
Newton read it).

Written as Infinigen-Sim's USD exporter (``princeton-vl/infinigen``,
``infinigen/core/sim/exporters/usd_exporter.py``) and the URDF -> USD converter
(``newton-physics/urdf-usd-converter``, ``urdf_usd_converter/_impl/link.py``) write theirs:

- the stage: ``upAxis`` Z, ``metersPerUnit`` 1, ``kilogramsPerUnit`` 1; the default prim ``/<object>``;
- one ``Xform`` per link directly under it (flat, as Infinigen), placed at the link's pose at rest, with
  ``RigidBodyAPI`` and ``MassAPI`` (``physics:mass``, ``centerOfMass``, ``diagonalInertia``,
  ``principalAxes``: the masses and inertias of :mod:`spark_bench.sim.physical`); the root link carries
  ``ArticulationRootAPI`` and is welded to the world by the fixed joint ``joints/root_joint`` (no
  ``body0``): a fixed base;
- per link a ``visual`` mesh and a ``collisions`` scope (purpose ``guide``) of convex hull meshes with
  ``CollisionAPI`` and ``MeshCollisionAPI`` ``physics:approximation = "convexHull"`` (primitives as
  ``Cube``/``Sphere``/``Cylinder``): the very hulls of ``model.xml`` (``hull_<k>``), but for a hull over PhysX's
  255 vertices or 255 polygons, written as the pieces :func:`spark_bench.sim.physx.hulls.physx_shapes` splits it
  into (``hull_<k>_<j>``, covering it exactly), which PhysX cooks as they are; a physics material of the
  options' friction bound to them;
- per joint a ``PhysicsRevoluteJoint``, ``PhysicsPrismaticJoint`` or ``PhysicsFixedJoint`` under ``joints/``:
  ``body0`` the parent link, ``body1`` the child; the axis one of the tokens X/Y/Z (the one nearest the
  joint's axis) with the joint's direction carried by ``localRot0``/``localRot1`` (the rotation taking the
  token's axis onto the joint's), ``localPos0`` the joint's origin in the parent; ``localPos1`` 0 in the
  child, so that the joint reads the asset's joint value (its rest value as written); revolute limits in
  **degrees**, prismatic in metres; a continuous joint has none;
- joint dynamics: a ``DriveAPI`` (``angular`` or ``linear``) of stiffness 0 and the joint's damping
  (UsdPhysics gives an angular drive's damping per degree: the N m s/rad value times pi/180), PhysX's
  ``physxJoint:armature``, and ``spark:damping``, ``spark:frictionloss``, ``spark:armature`` in
  spark-bench's own units (SI, radians).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.naming import unique_name
from spark_bench.sim.mjcf import base_rotation
from spark_bench.sim.physical import principal_inertia
from spark_bench.sim.physx.hulls import physx_shapes, piece_names
from spark_bench.sim.prepared import PreparedObject
from spark_bench.sim.shapes import CollisionShape

SIM_USD = "object.usda"
TOKENS = ("X", "Y", "Z")


def prim_names(names: list[str]) -> dict[str, str]:
    """A valid, unique USD prim name for each name (``Tf.MakeValidIdentifier``, numbered on a clash)."""
    from pxr import Tf

    out: dict[str, str] = {}
    used: set[str] = set()
    for name in names:
        out[name] = unique_name(Tf.MakeValidIdentifier(name) or "prim", used, first=1)
    return out


def align_token(axis: np.ndarray) -> tuple[str, np.ndarray]:
    """The axis token nearest ``axis`` and the rotation (3x3) taking that token's unit axis onto ``axis``."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = int(np.argmax(np.abs(axis)))
    unit = np.eye(3)[k]
    cross, dot = np.cross(unit, axis), float(np.dot(unit, axis))
    if np.linalg.norm(cross) < 1e-12:
        if dot > 0:
            return TOKENS[k], np.eye(3)
        other = np.eye(3)[(k + 1) % 3]  # half a turn about a perpendicular axis
        return TOKENS[k], 2.0 * np.outer(other, other) - np.eye(3)
    skew = np.array([[0, -cross[2], cross[1]], [cross[2], 0, -cross[0]], [-cross[1], cross[0], 0]])
    return TOKENS[k], np.eye(3) + skew + skew @ skew / (1.0 + dot)


def _quat(rotation: np.ndarray, kind: str = "f"):
    """A ``Gf.Quatf`` (``kind`` f) or ``Gf.Quatd`` of a rotation matrix."""
    from pxr import Gf
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(rotation, float)).as_quat()  # the same rotation in USD
    return Gf.Quatf(w, x, y, z) if kind == "f" else Gf.Quatd(w, x, y, z)


def _place(prim, transform: np.ndarray) -> None:
    """Author ``translate`` and ``orient`` ops of a 4x4 rigid transform."""
    from pxr import Gf, UsdGeom

    xform = UsdGeom.Xformable(prim)
    xform.AddTranslateOp().Set(Gf.Vec3d(*np.asarray(transform[:3, 3], float).tolist()))
    xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(_quat(transform[:3, :3], "d"))


def _mesh(stage, path: str, vertices: np.ndarray, faces: np.ndarray):
    from pxr import UsdGeom, Vt

    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(vertices, np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(np.asarray(faces, np.int32).ravel().tolist()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh


def _collision(stage, path: str, shape, material) -> None:
    """One collision shape (link frame) with the collision APIs and the physics material."""
    from pxr import Gf, UsdGeom, UsdPhysics, UsdShade

    if shape.kind == "mesh":
        geom = _mesh(stage, path, shape.vertices, shape.faces)
        UsdPhysics.MeshCollisionAPI.Apply(geom.GetPrim()).CreateApproximationAttr(
            UsdPhysics.Tokens.convexHull)
    elif shape.kind == "box":
        geom = UsdGeom.Cube.Define(stage, path)
        geom.CreateSizeAttr(1.0)
    elif shape.kind == "sphere":
        geom = UsdGeom.Sphere.Define(stage, path)
        geom.CreateRadiusAttr(float(shape.size[0]))
    else:
        geom = UsdGeom.Cylinder.Define(stage, path)
        geom.CreateRadiusAttr(float(shape.size[0]))
        geom.CreateHeightAttr(float(shape.size[1]))
        geom.CreateAxisAttr(UsdGeom.Tokens.z)
    if shape.kind != "mesh":
        _place(geom.GetPrim(), shape.origin)
        if shape.kind == "box":
            UsdGeom.Xformable(geom).AddScaleOp().Set(Gf.Vec3f(*np.asarray(shape.size, float).tolist()))
    UsdPhysics.CollisionAPI.Apply(geom.GetPrim())
    UsdShade.MaterialBindingAPI.Apply(geom.GetPrim()).Bind(
        material, UsdShade.Tokens.weakerThanDescendants, "physics")


def _link(stage, root_path: str, prim: str, name: str, prepared: PreparedObject, pose: np.ndarray,
          material, pieces: list[tuple[int, CollisionShape]]) -> str:
    """The link's rigid body, mass, visual mesh and collision shapes (``pieces``: its hulls as PhysX takes them);
    returns its prim path."""
    from pxr import Gf, Sdf, UsdGeom, UsdPhysics

    path = f"{root_path}/{prim}"
    body = UsdGeom.Xform.Define(stage, path).GetPrim()
    _place(body, pose)
    body.CreateAttribute("spark:name", Sdf.ValueTypeNames.String, custom=True).Set(name)
    UsdPhysics.RigidBodyAPI.Apply(body)
    props = prepared.mass[name]
    moments, axes = principal_inertia(props.inertia)
    mass = UsdPhysics.MassAPI.Apply(body)
    mass.CreateMassAttr(float(props.mass))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(*np.asarray(props.com, float).tolist()))
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(*moments.tolist()))
    mass.CreatePrincipalAxesAttr(_quat(axes))
    visual = prepared.visual(name)
    if visual is not None:
        mesh = _mesh(stage, f"{path}/visual", visual[0], visual[1])
        mesh.CreateDisplayColorAttr([Gf.Vec3f(*visual[2][:3])])
    if pieces:
        scope = UsdGeom.Scope.Define(stage, f"{path}/collisions")
        scope.CreatePurposeAttr(UsdGeom.Tokens.guide)  # hulls are not drawn with the visuals
        for suffix, (_, shape) in zip(piece_names(pieces), pieces):
            _collision(stage, f"{path}/collisions/hull_{suffix}", shape, material)
    return path


def _joint(stage, path: str, joint, prepared: PreparedObject, bodies: dict[str, str]) -> None:
    """One joint (see the module docstring for its frames, units and dynamics)."""
    from pxr import Gf, Sdf, UsdPhysics

    if joint.type == JointType.FIXED:
        usd = UsdPhysics.FixedJoint.Define(stage, path)
        token, align = "X", np.eye(3)
    else:
        token, align = align_token(joint.axis)
        usd = (UsdPhysics.PrismaticJoint if joint.type == JointType.PRISMATIC else UsdPhysics.RevoluteJoint).Define(stage, path)
        usd.CreateAxisAttr(token)
        if joint.type != JointType.CONTINUOUS:
            scale = 1.0 if joint.type == JointType.PRISMATIC else 180.0 / math.pi
            usd.CreateLowerLimitAttr(float(joint.lower) * scale)
            usd.CreateUpperLimitAttr(float(joint.upper) * scale)
    prim = usd.GetPrim()
    prim.CreateAttribute("spark:name", Sdf.ValueTypeNames.String, custom=True).Set(joint.name)
    usd.CreateBody0Rel().SetTargets([bodies[joint.parent]])
    usd.CreateBody1Rel().SetTargets([bodies[joint.child]])
    usd.CreateLocalPos0Attr(Gf.Vec3f(*np.asarray(joint.origin[:3, 3], float).tolist()))
    usd.CreateLocalRot0Attr(_quat(joint.origin[:3, :3] @ align))
    usd.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
    usd.CreateLocalRot1Attr(_quat(align))
    if joint.is_movable:
        dyn = prepared.dynamics[joint.name]
        angular = joint.is_rotational
        drive = UsdPhysics.DriveAPI.Apply(prim, "angular" if angular else "linear")
        drive.CreateStiffnessAttr(0.0)
        drive.CreateDampingAttr(float(dyn.damping) * (math.pi / 180.0 if angular else 1.0))
        prim.AddAppliedSchema("PhysxJointAPI")
        prim.CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(float(dyn.armature))
        for key, value in (("damping", dyn.damping), ("frictionloss", dyn.frictionloss), ("armature", dyn.armature)):
            prim.CreateAttribute(f"spark:{key}", Sdf.ValueTypeNames.Double, custom=True).Set(float(value))


def write_usd(prepared: PreparedObject, path: Path,
              pieces: dict[str, list[tuple[int, CollisionShape]]] | None = None) -> Path:
    """Write the prepared object as a USD stage (``.usda`` text, ``.usd``/``.usdc`` binary) at ``path``.

    :param prepared: output of :func:`spark_bench.sim.mjcf.prepare`
    :param path: the file to write (its folder is created)
    :param pieces: the hulls as PhysX takes them (:func:`spark_bench.sim.physx.hulls.physx_shapes`), when the
        caller has them
    """
    from pxr import Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

    asset, options = prepared.asset, prepared.options
    pieces = physx_shapes(prepared.shapes)[0] if pieces is None else pieces
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root_path = "/" + prim_names([asset.name or "object"])[asset.name or "object"]
    top = UsdGeom.Xform.Define(stage, root_path).GetPrim()
    top.CreateAttribute("spark:name", Sdf.ValueTypeNames.String, custom=True).Set(asset.name or "object")
    stage.SetDefaultPrim(top)
    material = UsdShade.Material.Define(stage, f"{root_path}/physics_material")
    friction = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
    friction.CreateStaticFrictionAttr(float(options.friction))
    friction.CreateDynamicFrictionAttr(float(options.friction))
    base = np.eye(4)
    base[:3, :3], base[:3, 3] = base_rotation(options), np.asarray(options.base_pos, float)
    poses = asset.link_poses()
    link_prims = prim_names(list(asset.links))
    bodies = {name: _link(stage, root_path, link_prims[name], name, prepared, base @ poses[name], material,
                          pieces.get(name, [])) for name in asset.links}
    UsdPhysics.ArticulationRootAPI.Apply(stage.GetPrimAtPath(bodies[asset.root]))
    UsdGeom.Scope.Define(stage, f"{root_path}/joints")
    weld = UsdPhysics.FixedJoint.Define(stage, f"{root_path}/joints/root_joint")
    weld.CreateBody1Rel().SetTargets([Sdf.Path(bodies[asset.root])])  # no body0: welded to the world
    weld.CreateLocalPos0Attr().Set(tuple(float(v) for v in base[:3, 3]))
    weld.CreateLocalRot0Attr(_quat(base[:3, :3]))
    joint_prims = prim_names(["root_joint"] + list(asset.joints))
    for joint in asset.joints.values():
        _joint(stage, f"{root_path}/joints/{joint_prims[joint.name]}", joint, prepared, bodies)
    stage.GetRootLayer().Export(str(path))
    return path
