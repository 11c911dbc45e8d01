"""The joints of a USD articulation for :mod:`spark_bench.asset.usd_model`: their types, limits and drives as the
UsdPhysics schema and the writers of :mod:`.usd_model` write them, and the names of the prims read.

- **Types**: ``PhysicsRevoluteJoint``, ``PhysicsPrismaticJoint`` and ``PhysicsFixedJoint``; any other joint (a D6
  ``PhysicsJoint``, spherical, distance) is an :class:`~spark_bench.errors.InputError` naming the prim.
- **Limits**: revolute in degrees, prismatic in stage units (``pxr/usd/usdPhysics/schema.usda``); a revolute joint
  without limits (unauthored, or infinite: Isaac's files hold ``-inf``/``inf``) is continuous.
- **Drives**: a drive that actuates (a stiffness, or a target velocity) on a joint without limits is a motor, not
  a part's articulation: refused. One case is not: Isaac Sim's URDF importer gives every revolute, continuous
  and prismatic joint its default position drive (``isaac-sim/urdf-importer-extension`` ``UrdfImporter.cpp``
  ``AddSingleJoint``, "continuous and revolute are identical except for setting limits", with ``PhysxJointAPI``
  and ``PhysicsJointStateAPI`` applied), so a URDF ``continuous`` joint arrives as an unlimited revolute joint
  with a stiff drive holding it at 0. Such a drive (``PhysxJointAPI`` on the joint, target position and target
  velocity 0 or unauthored) is read as the importer's, and the joint as the continuous joint it was.
- **Names**: a prim's name (``spark:name`` where spark-bench wrote one); prims whose names repeat get their paths
  from the first segment that tells them apart, ``/`` written ``:`` (a link's name becomes file names); a prim
  named ``world`` (MuJoCo's world body) is read as ``world_prim``.
"""

from __future__ import annotations

import math
from pathlib import Path

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.naming import unique_name
from spark_bench.errors import InputError

#: The PhysX joint schema Isaac Sim's URDF importer applies to every joint it gives a drive; usd-core does not
#: know it, so it is looked for in the prim's ``apiSchemas`` as written.
PHYSX_JOINT_API = "PhysxJointAPI"
#: Names a link or joint cannot take in the models spark-bench builds (MuJoCo's world body): a prim so named is
#: read as ``<name>_prim``.
RESERVED = frozenset({"world"})


def written_name(prim) -> str:
    """The prim's name as spark-bench wrote it (``spark:name``) or its USD name."""
    attribute = prim.GetAttribute("spark:name")
    return str(attribute.Get()) if attribute and attribute.HasAuthoredValue() else prim.GetName()


def prim_names(prims: list) -> dict:
    """Prim path -> name for ``prims`` (see the module docstring): each prim's own name where it is the only one
    so named, its path from the first segment that tells it from the others so named where names repeat."""
    by_name: dict[str, list] = {}
    for prim in prims:
        by_name.setdefault(written_name(prim), []).append(prim)
    out, used = {}, set()
    for name, same in by_name.items():
        if len(same) == 1:
            out[same[0].GetPath()] = name
            continue
        segments = {p.GetPath(): [*str(p.GetPath().GetParentPath()).strip("/").split("/"), name] for p in same}
        depth = 1
        while depth < max(len(s) for s in segments.values()) and \
                len({tuple(s[-depth:]) for s in segments.values()}) < len(segments):
            depth += 1
        for path, parts in segments.items():
            out[path] = ":".join(part for part in parts[-depth:] if part)
    for path, name in list(out.items()):  # a path name equal to another prim's own name: numbered
        out[path] = unique_name(f"{name}_prim" if name in RESERVED else name, used)
    return out


def joint_kind(prim, path: Path) -> str:
    """Our joint type of a UsdPhysics joint prim; an error naming the prim for one we cannot map."""
    from pxr import UsdPhysics

    if prim.IsA(UsdPhysics.RevoluteJoint):
        return JointType.REVOLUTE
    if prim.IsA(UsdPhysics.PrismaticJoint):
        return JointType.PRISMATIC
    if prim.IsA(UsdPhysics.FixedJoint):
        return JointType.FIXED
    kind = prim.GetTypeName() or "PhysicsJoint"
    what = "a D6 joint (generic PhysicsJoint)" if kind == "PhysicsJoint" else f"a {kind}"
    raise InputError(path, f"joint {prim.GetPath()} is {what}: only revolute, prismatic and fixed joints "
                           "make an articulated object")


def applied_schemas_as_written(prim) -> list[str]:
    """Every API schema the prim's ``apiSchemas`` metadata names, those usd-core does not know included
    (``GetAppliedSchemas`` leaves out PhysX's)."""
    listed = prim.GetMetadata("apiSchemas")
    if listed is None:
        return []
    return [str(item) for item in listed.GetAddedOrExplicitItems()]


def motor_drive(prim) -> str:
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


def importer_hold(prim, schema: str) -> bool:
    """Whether the drive ``schema`` of ``prim`` is the default position drive Isaac Sim's URDF importer puts on
    every joint it writes: ``PhysxJointAPI`` applied to the joint, target position and velocity 0 (or unauthored)."""
    from pxr import UsdPhysics

    if PHYSX_JOINT_API not in applied_schemas_as_written(prim):
        return False
    drive = UsdPhysics.DriveAPI(prim, schema.split(":", 1)[1])
    return (drive.GetTargetPositionAttr().Get() or 0.0) == 0.0 and (drive.GetTargetVelocityAttr().Get() or 0.0) == 0.0


def joint_limits(prim, kind: str, meters: float, path: Path) -> tuple[str, float, float, bool, str]:
    """``(type, lower, upper, has_limits, note)`` in radians or metres; ``note`` says why a driven joint without
    limits was still read as continuous ("" otherwise).

    :param prim: the joint prim
    :param kind: its :func:`joint_kind`
    :param meters: the stage's ``metersPerUnit``
    :param path: the file, for messages
    """
    from pxr import UsdPhysics

    if kind == JointType.FIXED:
        return kind, 0.0, 0.0, True, ""
    usd = UsdPhysics.RevoluteJoint(prim) if kind == JointType.REVOLUTE else UsdPhysics.PrismaticJoint(prim)
    lower, upper = usd.GetLowerLimitAttr().Get(), usd.GetUpperLimitAttr().Get()
    bounded = lower is not None and upper is not None and math.isfinite(lower) and math.isfinite(upper)
    if not bounded:
        if kind == JointType.PRISMATIC:
            raise InputError(path, f"joint {prim.GetPath()}: a prismatic joint without limits")
        motor, note = motor_drive(prim), ""
        if motor and not importer_hold(prim, motor):
            raise InputError(path, f"joint {prim.GetPath()} has a drive ({motor}) but no limits: a driven "
                                   "joint without range is a motor, not a part's articulation")
        if motor:
            note = (f"{motor} holds it at 0 as Isaac Sim's URDF importer drives every joint ({PHYSX_JOINT_API}): "
                    "read as the continuous joint the importer wrote")
        return JointType.CONTINUOUS, 0.0, 2.0 * math.pi, False, note
    if upper < lower:
        raise InputError(path, f"joint {prim.GetPath()}: upper limit {upper} below lower {lower}")
    scale = math.pi / 180.0 if kind == JointType.REVOLUTE else meters
    return kind, float(lower) * scale, float(upper) * scale, True, ""


def body_target(joint, side: int, bodies: dict, path: Path):
    """The rigid body prim on ``side`` (0 or 1) of a joint, or None (the world).

    :param joint: the ``UsdPhysics.Joint``
    :param bodies: rigid body prims by path
    :param path: the file, for messages
    """
    rel = joint.GetBody0Rel() if side == 0 else joint.GetBody1Rel()
    targets = rel.GetTargets()
    if not targets:
        return None
    if len(targets) > 1:
        raise InputError(path, f"joint {joint.GetPath()}: body{side} names {len(targets)} prims")
    return bodies.get(targets[0])  # a target that is no rigid body is a static anchor: the world
