"""``convert --to mjcf|urdf|usd`` and ``check --export``: the sim-ready asset in three formats, each read back
with the joints, limits, masses and shapes spark-bench checked (small convex parts: no CoACD run)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pybullet
import pytest
from helpers_assets import tiny_cabinet

from spark_bench.asset.urdf import write_object_folder
from spark_bench.data.readers import load_object
from spark_bench.sim.export import export
from spark_bench.sim.mjcf import prepare
from spark_bench.sim.options import ConvertOptions

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom, UsdPhysics  # noqa: E402

MOVABLE = ("joint_drawer", "joint_door")


def _options() -> ConvertOptions:
    return ConvertOptions(workers=1)


@pytest.fixture(scope="module")
def urdf_export(tmp_path_factory):
    return export(tiny_cabinet(), tmp_path_factory.mktemp("urdf_out"), "urdf", _options())


def test_urdf_export_has_relative_paths_and_a_fixed_base_in_pybullet(urdf_export):
    urdf = urdf_export.model
    for mesh in ET.parse(urdf).getroot().iter("mesh"):
        name = mesh.get("filename")
        assert not Path(name).is_absolute() and (urdf.parent / name).is_file()
    client = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(str(urdf), physicsClientId=client, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        infos = [pybullet.getJointInfo(body, i, physicsClientId=client) for i in range(pybullet.getNumJoints(body))]
        kinds = (pybullet.JOINT_REVOLUTE, pybullet.JOINT_PRISMATIC)
        movable = {i[1].decode(): (i[8], i[9]) for i in infos if i[2] in kinds}
        assert set(movable) == set(MOVABLE)
        asset = tiny_cabinet()
        for name, (lower, upper) in movable.items():
            assert (lower, upper) == pytest.approx((asset.joints[name].lower, asset.joints[name].upper), abs=1e-8)
        assert pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[0] == 0.0  # a static base
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        before = pybullet.getLinkState(body, 0, physicsClientId=client)[0]
        for _ in range(60):
            pybullet.stepSimulation(physicsClientId=client)
        assert np.allclose(pybullet.getLinkState(body, 0, physicsClientId=client)[0], before, atol=1e-9)
    finally:
        pybullet.disconnect(client)


def test_urdf_export_loads_in_mujoco_with_the_joints_of_model_xml(urdf_export):
    from_urdf = mujoco.MjModel.from_xml_path(str(urdf_export.model))
    from_xml = mujoco.MjModel.from_xml_path(str(urdf_export.mjcf))
    assert 0 not in set(from_urdf.jnt_type.tolist())  # no free joint: the base is welded

    def joints(model):
        return {model.joint(j).name: (int(model.jnt_type[j]), model.jnt_range[j].copy(),
                                      float(model.dof_damping[model.jnt_dofadr[j]]),
                                      float(model.dof_frictionloss[model.jnt_dofadr[j]]))
                for j in range(model.njnt)}

    mine, theirs = joints(from_urdf), joints(from_xml)
    assert set(mine) == set(theirs) == set(MOVABLE)
    for name in MOVABLE:
        assert mine[name][0] == theirs[name][0]
        # MuJoCo's XML writer keeps 6 significant digits of a range (pi/2 -> 1.5708): model.xml is that close
        assert mine[name][1] == pytest.approx(theirs[name][1], abs=1e-5)
        assert mine[name][2:] == pytest.approx(theirs[name][2:], rel=1e-5)  # URDF <dynamics> keeps 6 digits


@pytest.fixture(scope="module")
def usd_export(tmp_path_factory):
    return export(tiny_cabinet(), tmp_path_factory.mktemp("usd_out"), "usd", _options())


def _bodies(stage) -> dict[str, Usd.Prim]:
    return {p.GetAttribute("spark:name").Get(): p for p in stage.Traverse() if p.HasAPI(UsdPhysics.RigidBodyAPI)}


def test_usd_export_carries_what_isaac_sim_needs(usd_export):
    stage = Usd.Stage.Open(str(usd_export.model))
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    asset = tiny_cabinet()
    prepared = prepare(asset, _options())  # the cache convert filled: the same hulls
    bodies = _bodies(stage)
    assert set(bodies) == set(asset.links)
    roots = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.ArticulationRootAPI)]
    assert roots == [bodies[asset.root]]
    for name, prim in bodies.items():
        mass = UsdPhysics.MassAPI(prim).GetMassAttr().Get()
        assert mass == pytest.approx(prepared.mass[name].mass, rel=1e-6)  # physics:mass is a float
        hulls = [p for p in Usd.PrimRange(prim) if p.HasAPI(UsdPhysics.CollisionAPI)]
        assert len(hulls) == len(prepared.shapes.get(name, []))
        for hull in hulls:
            if hull.IsA(UsdGeom.Mesh):
                assert UsdPhysics.MeshCollisionAPI(hull).GetApproximationAttr().Get() == "convexHull"
    weld = UsdPhysics.FixedJoint(stage.GetPrimAtPath(f"{stage.GetDefaultPrim().GetPath()}/joints/root_joint"))
    assert not weld.GetBody0Rel().GetTargets() and weld.GetBody1Rel().GetTargets() == [bodies[asset.root].GetPath()]
    door = next(p for p in stage.Traverse() if p.IsA(UsdPhysics.RevoluteJoint))
    revolute = UsdPhysics.RevoluteJoint(door)
    assert revolute.GetAxisAttr().Get() == "Z"
    assert (revolute.GetLowerLimitAttr().Get(), revolute.GetUpperLimitAttr().Get()) == pytest.approx((0.0, 90.0))
    assert door.HasAPI(UsdPhysics.DriveAPI, "angular")
    assert door.GetAttribute("spark:damping").Get() == pytest.approx(prepared.dynamics["joint_door"].damping, rel=1e-9)


def test_usd_export_reads_back_with_the_same_joints_and_shapes(usd_export):
    asset, back = tiny_cabinet(), load_object(usd_export.model)
    assert set(back.links) == set(asset.links) and set(back.joints) == set(asset.joints)
    for name in MOVABLE:
        mine, theirs = asset.joints[name], back.joints[name]
        assert (theirs.type, theirs.lower, theirs.upper) == (mine.type, pytest.approx(mine.lower, abs=1e-6),
                                                             pytest.approx(mine.upper, abs=1e-6))
    for q in (asset.rest_configuration(), asset.open_configuration()):
        for name, (point, direction) in asset.joint_frames(q).items():
            other_point, other_direction = back.joint_frames(q)[name]
            assert other_direction == pytest.approx(direction, abs=1e-6)
            assert other_point == pytest.approx(point, abs=1e-6)
        mine_bounds, back_bounds = asset.link_meshes(q), back.link_meshes(q)
        for name, mesh in mine_bounds.items():
            assert back_bounds[name].bounds == pytest.approx(mesh.bounds, abs=1e-6)


def test_mjcf_export_reads_back_through_the_mjcf_reader(tmp_path):
    asset = tiny_cabinet()
    xml = export(asset, tmp_path, "mjcf", _options()).model
    back = load_object(xml)  # MuJoCo's names are kept as labels; links and joints are numbered in body order
    mine = [j for j in asset.topological_joints() if j.is_movable]
    theirs = [j for j in back.topological_joints() if j.is_movable]
    assert [j.type for j in theirs] == [j.type for j in mine]
    for a, b in zip(mine, theirs):  # model.xml keeps 6 significant digits (MuJoCo's XML writer)
        assert (b.lower, b.upper) == pytest.approx((a.lower, a.upper), abs=1e-5)
        q_a, q_b = {a.name: a.upper}, {b.name: b.upper}
        point_a, direction_a = asset.joint_frames(q_a)[a.name]
        point_b, direction_b = back.joint_frames(q_b)[b.name]
        assert direction_b == pytest.approx(direction_a, abs=1e-5)
        assert np.linalg.norm(np.cross(point_b - point_a, direction_a)) < 1e-5  # the same line
        moved_a = asset.mesh(q_a, links=asset.moving_links(a.name)).bounds
        moved_b = back.mesh(q_b, links=back.moving_links(b.name)).bounds
        assert moved_b == pytest.approx(moved_a, abs=1e-5)


def test_check_export_writes_after_a_passing_check(tmp_path, capsys):
    from spark_bench import cli

    urdf = write_object_folder(tiny_cabinet(), tmp_path / "cabinet")
    out = tmp_path / "sim"
    code = cli.main(["check", str(urdf), "--export", str(out), "--to", "usd", "--workers", "1", "--no-progress"])
    assert code == 0 and (out / "object.usda").is_file() and (out / "model.xml").is_file()
    back = load_object(out / "object.usda")
    assert math.degrees(back.joints["joint_door"].upper) == pytest.approx(90.0, abs=1e-4)


MJCF_AS_WRITTEN = """<mujoco model="crate">
  <compiler angle="radian"/>
  <worldbody>
    <body name="carcass">
      <geom name="carcass_look" type="box" size="0.25 0.3 0.4" pos="0 0 0.4" group="2" contype="0" conaffinity="0"/>
      <geom name="carcass_hit" type="box" size="0.25 0.3 0.4" pos="0 0 0.4" group="3"/>
      <body name="lid" pos="-0.26 -0.3 0.4">
        <joint name="lid_hinge" type="hinge" axis="0 0 1" range="0 1.5" damping="0.3" frictionloss="0.05"/>
        <geom name="lid_geom" type="box" size="0.01 0.28 0.35" pos="0 0.29 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_in_keeps_its_own_collision_geoms_and_dynamics(tmp_path):
    from spark_bench.sim.checks import run_checks

    xml = tmp_path / "crate.xml"
    xml.write_text(MJCF_AS_WRITTEN)
    asset = load_object(xml)
    carcass = next(link for link in asset.links.values() if link.label == "carcass")
    lid = next(link for link in asset.links.values() if link.label == "lid")
    # the group-3 box is the carcass's collision (its group-2 twin only a visual); the lid's one box is both
    assert [c.kind for c in carcass.collisions] == ["box"] and [c.kind for c in lid.collisions] == ["box"]
    assert carcass.collisions[0].size == pytest.approx([0.5, 0.6, 0.8])
    hinge = next(iter(asset.movable_joints()))
    assert (hinge.damping, hinge.friction, hinge.upper) == pytest.approx((0.3, 0.05, 1.5))
    prepared = prepare(asset, _options())
    assert prepared.report.coacd.calls == 0  # no hull made: the file's own shapes are used
    assert [s.kind for s in prepared.shapes[carcass.name]] == ["box"]
    assert prepared.dynamics[hinge.name].damping == pytest.approx(0.3)
    report = run_checks(asset, _options())
    assert report.checks["mjcf_compiles"].passed and report.checks["joint_sweep"].passed, report.to_dict()
