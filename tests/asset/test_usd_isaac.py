"""Isaac Sim's USD read as it ships (issue 43, item 1): a stage laid out as Isaac Sim's URDF importer writes one
(``isaac-sim/urdf-importer-extension`` ``UrdfImporter.cpp``; GenSim2's ``mobility.usd``), made here, nothing copied:

- binary crate 0.7.0 (written by usd-core with ``USD_WRITE_NEW_USDC_FILES_AS_VERSION=0.7.0``, in a subprocess:
  the setting is read once per process); usd-core's deprecation message for it stays out of the terminal;
- ``PhysxArticulationAPI`` and ``PhysxJointAPI`` (schemas usd-core does not know) beside UsdPhysics;
- ``root_joint`` (fixed, no ``body0``) to the world; each joint prim under its parent link (``addJoint``);
- a ``PhysicsDriveAPI`` position drive (stiffness 1e7, damping 1e5, target 0) on every movable joint
  (``AddSingleJoint``), a URDF ``continuous`` joint written as a revolute joint without limits;
- limits in degrees with a negative range (``[-90, 0]``, a PartNet-Mobility door as GenSim2's ``door/8877``);
- ``visuals/`` and ``collisions/`` under each link, ``Looks/`` holding an MDL shader (``OmniPBR.mdl``, which Isaac
  resolves from its own library) and a texture that is not there.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from spark_bench.data.readers import load_object
from spark_bench.errors import InputError

pytest.importorskip("pxr")
from helpers_formats import refused
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt  # noqa: E402

#: Isaac's importer turns a link's frame so: the root joint's rpy (pi/2, 0, -pi/2) of a PartNet-Mobility URDF.
LINK_TURN = Gf.Quatd(0.5, 0.5, -0.5, -0.5)
DRIVE = {"stiffness": 1e7, "damping": 1e5}


def _mesh(stage, path: str, mesh: trimesh.Trimesh, collision: bool = False):
    geom = UsdGeom.Mesh.Define(stage, path)
    geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(mesh.vertices, np.float32)))
    geom.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(mesh.faces)))
    geom.CreateFaceVertexIndicesAttr(Vt.IntArray(mesh.faces.ravel().tolist()))
    if collision:
        UsdPhysics.CollisionAPI.Apply(geom.GetPrim())
    return geom


def _link(stage, root: str, name: str, box: trimesh.Trimesh, translate=(0.0, 0.0, 0.0)) -> str:
    path = f"{root}/{name}"
    xform = UsdGeom.Xform.Define(stage, path)
    xform.AddTranslateOp().Set(Gf.Vec3d(*translate))
    xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(LINK_TURN)
    UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
    UsdPhysics.MassAPI.Apply(xform.GetPrim())  # no mass authored: PhysX computes it (as the importer leaves it)
    UsdGeom.Scope.Define(stage, f"{path}/visuals")
    _mesh(stage, f"{path}/visuals/{name}_surface", box)
    _mesh(stage, f"{path}/collisions/mesh_0", box, collision=True)
    return path


def _joint(stage, path: str, parent: str, child: str, position, lower: float | None, upper: float | None):
    joint = UsdPhysics.RevoluteJoint.Define(stage, path)
    joint.CreateAxisAttr("Y")
    joint.CreateBody0Rel().SetTargets([parent])
    joint.CreateBody1Rel().SetTargets([child])
    joint.CreateLocalPos0Attr(Gf.Vec3f(*position))
    joint.CreateLocalRot0Attr(Gf.Quatf(1, 0, 0, 0))
    joint.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    joint.CreateLocalRot1Attr(Gf.Quatf(1, 0, 0, 0))
    if lower is not None:
        joint.CreateLowerLimitAttr(lower)
        joint.CreateUpperLimitAttr(upper)
    prim = joint.GetPrim()
    for schema in ("PhysxJointAPI", "PhysicsJointStateAPI:angular"):  # unknown to usd-core: as written
        prim.AddAppliedSchema(schema)
    prim.CreateAttribute("physxJoint:maxJointVelocity", Sdf.ValueTypeNames.Float).Set(float("inf"))
    drive = UsdPhysics.DriveAPI.Apply(prim, "angular")
    drive.CreateTypeAttr("force")
    drive.CreateStiffnessAttr(DRIVE["stiffness"])
    drive.CreateDampingAttr(DRIVE["damping"])
    drive.CreateTargetPositionAttr(0.0)
    return joint


def write_isaac_style(path: Path) -> Path:
    """A cabinet (a carcass, a door hinged as GenSim2's door, a knob on a continuous joint) laid out as Isaac's URDF
    importer writes it, as text at ``path`` (see the module docstring)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = "/partnet_cabinet"
    top = UsdGeom.Xform.Define(stage, root).GetPrim()
    stage.SetDefaultPrim(top)
    UsdPhysics.ArticulationRootAPI.Apply(top)
    top.AddAppliedSchema("PhysxArticulationAPI")
    top.CreateAttribute("physxArticulation:solverPositionIterationCount", Sdf.ValueTypeNames.Int).Set(32)
    base = _link(stage, root, "base", trimesh.creation.box(extents=[0.4, 0.5, 0.6]))
    # in the link frame (turned by LINK_TURN): the door's panel in front of the carcass, hinged on its edge
    door = _link(stage, root, "link_0", trimesh.creation.box(extents=[0.02, 0.6, 0.5]), (-0.21, -0.25, 0.0))
    knob = _link(stage, root, "link_1", trimesh.creation.box(extents=[0.04, 0.04, 0.04]), (0.0, 0.0, 0.32))
    world = UsdPhysics.FixedJoint.Define(stage, f"{root}/root_joint")
    world.CreateBody1Rel().SetTargets([base])
    _joint(stage, f"{base}/joint_0", base, door, (0.25, 0.0, -0.21), -90.0, 0.0)  # as GenSim2's door/8877
    _joint(stage, f"{base}/joint_1", base, knob, (0.0, 0.32, 0.0), None, None)  # a URDF continuous joint
    UsdGeom.Scope.Define(stage, f"{root}/Looks")
    material = UsdShade.Material.Define(stage, f"{root}/Looks/material_0")
    shader = UsdShade.Shader.Define(stage, f"{root}/Looks/material_0/Shader")
    shader.GetPrim().CreateAttribute("info:mdl:sourceAsset", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("OmniPBR.mdl"))
    shader.CreateInput("diffuse_texture", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("./materials/texture_0.jpg"))
    material.CreateSurfaceOutput("mdl").ConnectToSource(shader.ConnectableAPI(), "out")
    stage.GetRootLayer().Save()
    return path


def as_crate_070(usda: Path) -> Path:
    """``usda`` exported as a binary crate file of version 0.7.0 (Isaac Sim's), beside it."""
    out = usda.with_suffix(".usd")
    code = ("import sys; from pxr import Sdf; "
            "assert Sdf.Layer.FindOrOpen(sys.argv[1]).Export(sys.argv[2])")
    env = {"USD_WRITE_NEW_USDC_FILES_AS_VERSION": "0.7.0", "PATH": "/usr/bin:/bin"}
    subprocess.run([sys.executable, "-c", code, str(usda), str(out)], check=True, env=env, capture_output=True)
    assert out.read_bytes()[:11] == b"PXR-USDC\x00\x07\x00"
    return out


@pytest.fixture
def isaac_file(tmp_path) -> Path:
    return as_crate_070(write_isaac_style(tmp_path / "mobility.usda"))


def test_isaac_importer_stage_reads_as_the_object(isaac_file, capfd):
    asset = load_object(isaac_file)
    err = capfd.readouterr().err
    assert "deprecated version" not in err and "Warning: in" not in err  # usd-core's own messages: kept out
    assert asset.meta["usd"]["crate_version"] == "0.7.0"
    assert list(asset.links) == ["base", "link_0", "link_1"] and asset.root == "base"
    door, knob = asset.joints["joint_0"], asset.joints["joint_1"]
    # [-90, 0] degrees drawn at 0: opens toward -90, read as [0, 90] about the opposite axis
    assert (door.type, door.lower, door.upper) == ("revolute", 0.0, pytest.approx(np.pi / 2))
    found = {o["joint"]: o for o in asset.meta["opening_direction"]}["joint_0"]
    assert (found["rule"], found["written"]) == ("rest at upper", [pytest.approx(-np.pi / 2), 0.0])
    assert knob.type == "continuous" and "Isaac Sim's URDF importer" in asset.meta["usd"]["continuous"]["joint_1"]
    # the door's hinge line: the link frame's Y axis (turned by LINK_TURN) through the carcass's front edge
    point, direction = asset.joint_frames()["joint_0"]
    turn = np.array(Gf.Matrix3d(Gf.Rotation(LINK_TURN)), dtype=float).T
    assert direction == pytest.approx(-(turn @ [0, 1.0, 0]), abs=1e-6)
    assert point == pytest.approx(turn @ [0.25, 0.0, -0.21], abs=1e-6)
    opened = asset.mesh({"joint_0": np.pi / 2}, links=["link_0"]).bounds
    assert not np.allclose(opened, asset.mesh(links=["link_0"]).bounds, atol=1e-3)  # it moves


def test_look_only_files_that_do_not_resolve_are_warnings(isaac_file):
    asset = load_object(isaac_file)
    assert len(asset.warnings) == 2
    texture, mdl = sorted(asset.warnings)  # "@." sorts before "@O"
    assert mdl.startswith("@OmniPBR.mdl@ not found") and "/partnet_cabinet/Looks/material_0/Shader" in mdl
    assert texture.startswith("@./materials/texture_0.jpg@ not found") and "look only" in texture


def test_a_drive_that_spins_an_unlimited_joint_is_still_a_motor(tmp_path):
    path = write_isaac_style(tmp_path / "spinning.usda")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/partnet_cabinet/base/joint_1")
    UsdPhysics.DriveAPI(prim, "angular").CreateTargetVelocityAttr(30.0)
    stage.GetRootLayer().Save()
    refused(load_object, path, "/partnet_cabinet/base/joint_1", "drive", "no limits", str(path))


def test_prims_whose_names_repeat_are_named_by_their_paths(tmp_path):
    """Two doors both named ``panel`` (under ``left`` and ``right``) and two joints both named ``hinge``."""
    path = write_isaac_style(tmp_path / "twins.usda")
    stage = Usd.Stage.Open(str(path))
    for side in ("left", "right"):
        UsdGeom.Xform.Define(stage, f"/partnet_cabinet/{side}")
        layer = stage.GetRootLayer()
        Sdf.CopySpec(layer, "/partnet_cabinet/link_0", layer, f"/partnet_cabinet/{side}/panel")
        Sdf.CopySpec(layer, "/partnet_cabinet/base/joint_0", layer, f"/partnet_cabinet/{side}/hinge")
        joint = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath(f"/partnet_cabinet/{side}/hinge"))
        joint.GetBody1Rel().SetTargets([f"/partnet_cabinet/{side}/panel"])
    stage.RemovePrim("/partnet_cabinet/link_0")
    stage.RemovePrim("/partnet_cabinet/base/joint_0")
    stage.GetRootLayer().Save()
    asset = load_object(path)
    assert {"left:panel", "right:panel", "link_1"} <= set(asset.links)
    assert {"left:hinge", "right:hinge", "joint_1"} == set(asset.joints)
    assert asset.joints["left:hinge"].child == "left:panel"


def test_check_gives_an_isaac_file_a_verdict_naming_its_joints(isaac_file):
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.options import ConvertOptions

    report = run_checks(load_object(isaac_file), ConvertOptions(workers=1, use_cache=False))
    assert set(report.checks["joint_sweep"].details["joints"]) == {"joint_0", "joint_1"}
    assert report.checks["mjcf_compiles"].passed and report.checks["pybullet_loads"].passed, report.to_dict()


def test_an_unreadable_crate_file_is_one_line_naming_it(tmp_path):
    path = tmp_path / "broken.usd"
    path.write_bytes(b"PXR-USDC\x00\x07\x00" + b"\x00" * 40)
    with pytest.raises(InputError, match="cannot open USD") as caught:
        load_object(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)
