"""USD in: stages written the way Infinigen-Sim's exporter (``princeton-vl/infinigen``
``infinigen/core/sim/exporters/usd_exporter.py``) and the URDF -> USD converter (``newton-physics/urdf-usd-converter``
``urdf_usd_converter/_impl/link.py``) write them, read back into the object they were made from; a corrupt set
(D6 joint, a drive without limits, an instanced prim, missing meshes), each an error naming the prim; and
``spark-bench import usd``.

The writers here follow those exporters' layouts (made by the tests, nothing copied):

- Infinigen-Sim: ``/Asset`` (Z up, metres), flat ``/Asset/link_<k>`` Xforms translated to their parts' box
  centres with ``RigidBodyAPI``, ``visual/`` meshes and an invisible ``collision/`` scope of ``CollisionAPI``
  meshes, ``/Asset/Joints/root_joint`` (fixed, ``body0`` ``/Asset``), ``ArticulationRootAPI`` on the root link,
  revolute/prismatic joints with an angular ``DriveAPI``, the axis token of an axis-aligned axis, a negative
  axis written as the positive one with the range negated (its local rotations half a turn about the axis
  itself), ``localPos0 = child centre - parent centre + pivot``, ``localPos1 = pivot``, limits in degrees;
- the URDF -> USD converter: links nested under their parents (the child's transform the joint's origin),
  ``RigidBodyAPI`` + ``MassAPI`` on each, ``ArticulationRootAPI`` on the first, joints in a ``Physics`` scope with
  their frame in body 1's space (``localPos1`` 0, ``localRot1`` the axis alignment), an axis not along X, Y or Z
  carried by ``localRot0/1`` with the token X; here in centimetres (``metersPerUnit`` 0.01) and Y up.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.transforms import make_transform
from spark_bench.data.readers import load_object
from spark_bench.errors import InputError
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.runs import import_runs
from spark_bench.formats.usd import read_run

pytest.importorskip("pxr")
from helpers_boxes import box_between
from helpers_formats import refused
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, Vt  # noqa: E402

FLIP = {"X": Gf.Quatf(0, 1, 0, 0), "Y": Gf.Quatf(0, 0, 1, 0), "Z": Gf.Quatf(0, 0, 0, 1)}  # Infinigen's


def infinigen_cabinet() -> ArticulatedAsset:
    """A carcass, a door hinged about -Z (axis-aligned, as Infinigen-Sim's joints are) and a drawer along -X."""
    links = {
        "body": Link("body", [Visual(box_between((0, -0.5, 0), (0.5, 0.5, 1.0)))]),
        "door": Link("door", [Visual(box_between((-0.02, -0.48, 0.5), (0.0, 0.0, 0.98)))]),
        "drawer": Link("drawer", [Visual(box_between((-0.02, -0.45, 0.05), (0.45, 0.45, 0.4)))]),
    }
    joints = {
        "door_hinge": Joint("door_hinge", "revolute", "body", "door", make_transform(translation=(0, 0, 0)),
                            np.array([0.0, 0, -1.0]), 0.0, 1.4),
        "drawer_slide": Joint("drawer_slide", "prismatic", "body", "drawer", np.eye(4), np.array([-1.0, 0, 0]),
                              0.0, 0.35),
    }
    return ArticulatedAsset("cabinet", links, joints)


def _mesh(stage, path: str, mesh: trimesh.Trimesh, offset=(0.0, 0.0, 0.0)):
    geom = UsdGeom.Mesh.Define(stage, path)
    points = np.asarray(mesh.vertices, float) - np.asarray(offset, float)
    geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    geom.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(mesh.faces)))
    geom.CreateFaceVertexIndicesAttr(Vt.IntArray(mesh.faces.ravel().tolist()))
    return geom


def write_infinigen_style(path: Path, asset: ArticulatedAsset) -> Path:
    """``asset`` (axis-aligned joints, links without rotation) written as Infinigen-Sim's USD exporter does."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/Asset").GetPrim())
    UsdGeom.Scope.Define(stage, "/Asset/Joints")
    poses = asset.link_poses()
    centers, paths = {}, {}
    for k, (name, link) in enumerate(asset.links.items()):
        world = link.merged_mesh().copy()
        world.apply_transform(poses[name])
        centers[name] = world.bounds.mean(axis=0)
        paths[name] = f"/Asset/link_{k}"
        xform = UsdGeom.Xform.Define(stage, paths[name])
        UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
        xform.AddTranslateOp().Set(Gf.Vec3d(*centers[name].tolist()))
        UsdGeom.Scope.Define(stage, f"{paths[name]}/visual")
        _mesh(stage, f"{paths[name]}/visual/{name}_0", world, centers[name])
        UsdGeom.Scope.Define(stage, f"{paths[name]}/collision").GetVisibilityAttr().Set("invisible")
        hull = _mesh(stage, f"{paths[name]}/collision/{name}_0_col0", world.convex_hull, centers[name])
        UsdPhysics.CollisionAPI.Apply(hull.GetPrim())
    root = UsdPhysics.FixedJoint(stage.DefinePrim("/Asset/Joints/root_joint", "PhysicsFixedJoint"))
    root.CreateBody0Rel().SetTargets(["/Asset"])
    root.CreateBody1Rel().SetTargets([paths[asset.root]])
    root.CreateLocalPos0Attr().Set(Gf.Vec3f(*centers[asset.root].tolist()))
    root.CreateLocalPos1Attr().Set(Gf.Vec3f(0, 0, 0))
    UsdPhysics.ArticulationRootAPI.Apply(stage.GetPrimAtPath(paths[asset.root]))
    frames = asset.joint_frames()
    for joint in asset.movable_joints():
        pivot, direction = frames[joint.name]
        k = int(np.argmax(np.abs(direction)))
        token, flip = "XYZ"[k], direction[k] < 0
        kind = "PhysicsRevoluteJoint" if joint.is_rotational else "PhysicsPrismaticJoint"
        prim = stage.DefinePrim(f"/Asset/Joints/{joint.name}_0", kind)
        usd = UsdPhysics.RevoluteJoint(prim) if joint.is_rotational else UsdPhysics.PrismaticJoint(prim)
        drive = UsdPhysics.DriveAPI.Apply(prim, "angular")
        drive.CreateStiffnessAttr().Set(5.0)  # Infinigen-Sim samples a stiffness and a damping per joint
        drive.CreateDampingAttr().Set(1.0)
        usd.CreateBody0Rel().SetTargets([paths[joint.parent]])
        usd.CreateBody1Rel().SetTargets([paths[joint.child]])
        usd.CreateAxisAttr().Set(token)
        quat = FLIP[token] if flip else Gf.Quatf(1, 0, 0, 0)
        position = pivot - centers[joint.child]
        usd.CreateLocalPos0Attr().Set(Gf.Vec3f(*(centers[joint.child] - centers[joint.parent] + position).tolist()))
        usd.CreateLocalRot0Attr().Set(quat)
        usd.CreateLocalPos1Attr().Set(Gf.Vec3f(*position.tolist()))
        usd.CreateLocalRot1Attr().Set(quat)
        lower, upper = (-joint.upper, -joint.lower) if flip else (joint.lower, joint.upper)
        scale = 180.0 / math.pi if joint.is_rotational else 1.0
        usd.CreateLowerLimitAttr().Set(lower * scale)
        usd.CreateUpperLimitAttr().Set(upper * scale)
    stage.GetRootLayer().Save()
    return path


def _quat(rotation: np.ndarray) -> Gf.Quatf:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return Gf.Quatf(w, x, y, z)


def write_converter_style(path: Path, asset: ArticulatedAsset, units: float = 0.01) -> Path:
    """``asset`` written as the URDF -> USD converter nests it, in ``units`` metres per unit, Y up."""
    from spark_bench.sim.export_usd import align_token

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, units)
    y_up = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # Z-up metres -> this stage's Y-up axes
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, f"/{asset.name}").GetPrim())
    UsdGeom.Scope.Define(stage, f"/{asset.name}/Physics")
    paths = {asset.root: f"/{asset.name}/Geometry/{asset.root}"}
    UsdGeom.Scope.Define(stage, f"/{asset.name}/Geometry")
    top = UsdGeom.Xform.Define(stage, paths[asset.root])
    top.AddOrientOp().Set(_quat(y_up))  # the root link turned into the stage's Y up (a converter's root)
    for joint in asset.topological_joints():
        paths[joint.child] = f"{paths[joint.parent]}/{joint.child}"
        xform = UsdGeom.Xform.Define(stage, paths[joint.child])
        xform.AddTranslateOp().Set(Gf.Vec3d(*(joint.origin[:3, 3] / units).tolist()))
        xform.AddOrientOp().Set(_quat(joint.origin[:3, :3]))
    for name, link in asset.links.items():
        prim = stage.GetPrimAtPath(paths[name])
        UsdPhysics.RigidBodyAPI.Apply(prim)
        UsdPhysics.MassAPI.Apply(prim).CreateMassAttr(2.5)
        mesh = link.merged_mesh()
        _mesh(stage, f"{paths[name]}/visual", trimesh.Trimesh(mesh.vertices / units, mesh.faces))
        collision = _mesh(stage, f"{paths[name]}/collision", trimesh.Trimesh(mesh.vertices / units, mesh.faces))
        UsdPhysics.CollisionAPI.Apply(collision.GetPrim())
    UsdPhysics.ArticulationRootAPI.Apply(stage.GetPrimAtPath(paths[asset.root]))
    for joint in asset.joints.values():
        token, align = align_token(joint.axis)
        kind = {"revolute": UsdPhysics.RevoluteJoint, "prismatic": UsdPhysics.PrismaticJoint}.get(joint.type)
        usd = (kind or UsdPhysics.FixedJoint).Define(stage, f"/{asset.name}/Physics/{joint.name}")
        usd.CreateBody0Rel().SetTargets([paths[joint.parent]])
        usd.CreateBody1Rel().SetTargets([paths[joint.child]])
        usd.CreateLocalPos0Attr().Set(Gf.Vec3f(*(joint.origin[:3, 3] / units).tolist()))
        usd.CreateLocalRot0Attr().Set(_quat(joint.origin[:3, :3] @ align))
        usd.CreateLocalPos1Attr().Set(Gf.Vec3f(0, 0, 0))
        usd.CreateLocalRot1Attr().Set(_quat(align))
        if kind is not None:
            usd.CreateAxisAttr().Set(token)
            scale = 180.0 / math.pi if joint.type == "revolute" else 1.0 / units
            usd.CreateLowerLimitAttr().Set(joint.lower * scale)
            usd.CreateUpperLimitAttr().Set(joint.upper * scale)
    stage.GetRootLayer().Save()
    return path


def assert_moves_as(back: ArticulatedAsset, asset: ArticulatedAsset, pairs: dict[str, str],
                    tol: float) -> None:
    """``back`` moves as ``asset``: each joint (by ``pairs``: ours -> theirs) on the same line, the same range,
    every part where the original's is, at rest and open."""
    for ours, theirs in pairs.items():
        a, b = asset.joints[ours], back.joints[theirs]
        assert (b.type, b.lower, b.upper) == (a.type, pytest.approx(a.lower, abs=tol), pytest.approx(a.upper, abs=tol))
    q_back = {pairs[k]: v for k, v in asset.open_configuration().items()}
    for q_a, q_b in ((asset.rest_configuration(), {}), (asset.open_configuration(), q_back)):
        frames_a, frames_b = asset.joint_frames(q_a), back.joint_frames(q_b)
        for ours, theirs in pairs.items():
            assert frames_b[theirs][1] == pytest.approx(frames_a[ours][1], abs=tol)
            assert np.linalg.norm(np.cross(frames_b[theirs][0] - frames_a[ours][0], frames_a[ours][1])) < tol
        assert back.mesh(q_b).bounds == pytest.approx(asset.mesh(q_a).bounds, abs=tol)
        for ours, theirs in pairs.items():
            child_a, child_b = asset.joints[ours].child, back.joints[theirs].child
            assert back.mesh(q_b, links=[child_b]).bounds == pytest.approx(asset.mesh(q_a, links=[child_a]).bounds,
                                                                            abs=tol)


def test_infinigen_style_stage_reads_as_the_object(tmp_path):
    asset = infinigen_cabinet()
    back = load_object(write_infinigen_style(tmp_path / "cabinet.usda", asset))
    assert len(back.links) == 3 and {j.type for j in back.joints.values()} == {"revolute", "prismatic"}
    # the door about -Z written as +Z with the range negated: read as [0, 1.4] about -Z again
    assert_moves_as(back, asset, {"door_hinge": "door_hinge_0", "drawer_slide": "drawer_slide_0"}, 1e-5)


def test_converter_style_stage_in_centimetres_and_y_up(tmp_path):
    asset = infinigen_cabinet()
    tilted = asset.joints["door_hinge"]
    tilted.axis = np.array([0.0, 0.6, -0.8])  # off the X/Y/Z axes: carried by localRot0/1 with the token X
    tilted.origin = make_transform(translation=(0.0, 0.0, 0.5))
    back = load_object(write_converter_style(tmp_path / "cabinet.usd", asset))
    assert back.meta["usd"]["up_axis"] == "Y" and back.meta["usd"]["meters_per_unit"] == pytest.approx(0.01)
    assert back.links["door"].annotations["mass"] == pytest.approx(2.5)
    assert_moves_as(back, asset, {"door_hinge": "door_hinge", "drawer_slide": "drawer_slide"}, 1e-5)


def _corrupt(tmp_path: Path, edit) -> Path:
    path = write_infinigen_style(tmp_path / "cabinet.usda", infinigen_cabinet())
    stage = Usd.Stage.Open(str(path))
    edit(stage)
    stage.GetRootLayer().Save()
    return path


def test_d6_joint_is_refused_naming_the_prim(tmp_path):
    def d6(stage):
        joint = UsdPhysics.Joint.Define(stage, "/Asset/Joints/lid_d6")
        joint.CreateBody0Rel().SetTargets(["/Asset/link_0"])
        joint.CreateBody1Rel().SetTargets(["/Asset/link_1"])

    source = _corrupt(tmp_path, d6)
    refused(load_object, source, "/Asset/Joints/lid_d6", "D6", str(source))  # naming the file read


def test_drive_without_limits_is_refused(tmp_path):
    def unlimited(stage):
        joint = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath("/Asset/Joints/door_hinge_0"))
        joint.GetLowerLimitAttr().Clear()
        joint.GetUpperLimitAttr().Clear()

    source = _corrupt(tmp_path, unlimited)
    refused(load_object, source, "/Asset/Joints/door_hinge_0", "drive", "no limits", str(source))


def test_unlimited_hinge_without_a_drive_is_continuous(tmp_path):
    def free_spin(stage):
        prim = stage.GetPrimAtPath("/Asset/Joints/door_hinge_0")
        UsdPhysics.RevoluteJoint(prim).GetLowerLimitAttr().Clear()
        UsdPhysics.RevoluteJoint(prim).GetUpperLimitAttr().Clear()
        UsdPhysics.DriveAPI(prim, "angular").GetStiffnessAttr().Set(0.0)  # a damper, not a motor

    assert load_object(_corrupt(tmp_path, free_spin)).joints["door_hinge_0"].type == "continuous"


def test_instanced_prim_is_refused(tmp_path):
    def instanced(stage):
        UsdGeom.Xform.Define(stage, "/Prototypes/knob")
        UsdGeom.Cube.Define(stage, "/Prototypes/knob/shape").CreateSizeAttr(0.02)
        knob = stage.DefinePrim("/Asset/link_1/visual/knob")
        knob.GetReferences().AddInternalReference("/Prototypes/knob")
        knob.SetInstanceable(True)

    source = _corrupt(tmp_path, instanced)
    refused(load_object, source, "/Asset/link_1/visual/knob", "instanced", str(source))


def test_missing_and_empty_meshes_are_refused(tmp_path):
    def missing(stage):
        stage.DefinePrim("/Asset/link_1/visual/handle").GetReferences().AddReference("./parts/handle.usda")

    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
    source = _corrupt(tmp_path / "a", missing)
    refused(load_object, source, "not found", "handle.usda", str(source))

    def empty(stage):
        UsdGeom.Mesh.Define(stage, "/Asset/link_2/visual/front")

    source = _corrupt(tmp_path / "b", empty)
    refused(load_object, source, "/Asset/link_2/visual/front", "no points", str(source))


def test_import_usd_folder_and_file_runs(bench, tmp_path):
    from spark_bench.data.case import Benchmark

    runs, out = tmp_path / "runs", tmp_path / "pred"
    (runs / "cab0").mkdir(parents=True)
    gt = {c: Benchmark(bench).case(c).load_gt() for c in ("cab0", "cab1")}
    write_infinigen_style(runs / "cab0" / "model.usda", gt["cab0"])
    write_infinigen_style(runs / "cab1.usda", gt["cab1"])  # one file per case
    report = import_runs("usd", runs, bench, out, reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0", "cab1"] and not report.unknown
    record = read_import_record(out / "cab0")
    assert record["format"] == "usd" and record["files"] == ["model.usda"]
    for case, asset in gt.items():
        imported = load_object(out / case)
        assert len(imported.movable_joints()) == len(asset.movable_joints())


def test_import_usd_refuses_a_reference_outside_the_run(tmp_path):
    (tmp_path / "run").mkdir()
    outside = write_infinigen_style(tmp_path / "part.usda", infinigen_cabinet())
    path = write_infinigen_style(tmp_path / "run" / "model.usda", infinigen_cabinet())
    stage = Usd.Stage.Open(str(path))
    stage.DefinePrim("/Asset/link_1/visual/extra").GetReferences().AddReference(Sdf.Reference(str(outside)))
    stage.GetRootLayer().Save()
    with pytest.raises(InputError, match="leaves the run folder"):
        read_run(tmp_path / "run")
