"""The real URDFs of SPARK's joint optimizer (YumengHe/PartCrafter, outputs/test*): read as they are."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_fake_spark import optimize_joint, write_glb

from spark_bench.asset.urdf import load_urdf
from spark_bench.errors import InputError
from spark_bench.formats.spark import layout
from spark_bench.formats.spark.reader import frame_rotation, read_spark_run

OPTIMIZER_OUTPUTS = Path(__file__).parent / "fixtures" / "partcrafter_urdfoptimizer"
URDFS = sorted(OPTIMIZER_OUTPUTS.glob("test*/*.urdf"))


def _run_copy(tmp_path, test: str):
    """The fixture folder copied as a SPARK run folder (``<name>_<timestamp>``)."""
    return shutil.copytree(OPTIMIZER_OUTPUTS / test, tmp_path / f"{test}_20251017_135023")


def _stand_in_meshes(run) -> None:
    """Boxes where a URDF points (the repository lacks most of these GLBs), each of another size."""
    for k, mesh in enumerate(sorted({m.get("filename") for u in run.glob("*.urdf")
                                     for m in ET.parse(u).getroot().iter("mesh")})):
        write_glb(run / mesh, trimesh.creation.box(extents=(0.5 + 0.1 * k, 0.8, 0.1)))


def test_there_are_six_real_urdfs():
    assert [f"{p.parent.name}/{p.name}" for p in URDFS] == [
        "test1/mobility.urdf", "test1/mobility_optimized.urdf", "test2/mobility.urdf",
        "test2/mobility_optimized.urdf", "test3/mobility.urdf", "test4/mobility.urdf"]


@pytest.mark.parametrize("urdf", URDFS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_partnet_mobility_style_urdfs_need_no_rotation(urdf):
    asset = load_urdf(urdf, load_meshes=False)
    assert asset.root == "base"
    assert all(name.startswith("link_") for name in asset.links if name != "base")
    assert all(name.startswith("joint_") for name in asset.joints)
    rotation, style = frame_rotation(asset)
    assert style == "partnet-mobility"
    # the root joint's rpy is written with 16 digits of pi/2: equal to that rounding
    assert np.allclose(rotation, np.eye(3), atol=1e-12)


@pytest.mark.parametrize(("test", "pivot"), [("test1", (0.18202803, 0.0, 0.20976162)),
                                             ("test2", (-0.36871713, 0.07864190, 0.51754802))])
def test_the_fake_optimizer_writes_the_real_optimizer_bytes(tmp_path, test, pivot):
    """fake_spark.optimize_joint (what the fake SPARK writes) reproduces optimize_urdf_joint_v4.py's files."""
    out = tmp_path / "mobility_optimized.urdf"
    optimize_joint(OPTIMIZER_OUTPUTS / test / "mobility.urdf", "joint_0", pivot, out)
    assert out.read_bytes() == (OPTIMIZER_OUTPUTS / test / "mobility_optimized.urdf").read_bytes()


def test_optimized_pivot_is_read_and_the_rest_pose_kept(tmp_path):
    run = _run_copy(tmp_path, "test1")
    _stand_in_meshes(run)
    optimized = read_spark_run(run)
    assert (optimized.record["urdf"], optimized.record["urdf_kind"]) == ("mobility_optimized.urdf", "optimized")
    assert optimized.record["frame"]["root_joint"] == "partnet-mobility"
    assert [m["file"] for m in optimized.record["meshes"]] == ["part_01.glb", "part_00.glb"]  # beside the URDF
    (run / "mobility_optimized.urdf").unlink()
    plain = read_spark_run(run)
    assert plain.record["urdf_kind"] == "vlm"
    # the optimizer moves the joint by t and the child's visual by -t: the same rest pose
    rest_a, rest_b = optimized.asset.mesh(), plain.asset.mesh()
    assert np.allclose(rest_a.vertices, rest_b.vertices, atol=1e-6)  # origins have 8 decimals
    to_bench = np.asarray(optimized.record["frame"]["urdf_world_to_benchmark"])
    t = np.array([0.18202803, 0.0, 0.20976162])  # in the body's (mesh) frame
    expected = to_bench[:3, :3] @ (layout.SPARK_TO_PARTNET @ t) + to_bench[:3, 3]
    assert np.allclose(optimized.asset.joint_frames()["joint_0"][0], expected, atol=1e-9)
    # the axis "0 -1 0" of the mesh frame (down) comes out as -Z in ours
    assert np.allclose(optimized.asset.joint_frames()["joint_0"][1], [0.0, 0.0, -1.0], atol=1e-12)


def test_prismatic_front_axis_of_test3_is_our_minus_x(tmp_path):
    run = _run_copy(tmp_path, "test3")
    _stand_in_meshes(run)
    result = read_spark_run(run)
    directions = [d for _, d in result.asset.joint_frames().values()]
    assert len(directions) == 3
    for direction in directions:  # <axis xyz="0 0 1"/>: the drawers slide out of the front
        assert np.allclose(direction, [-1.0, 0.0, 0.0], atol=1e-12)


def test_test4_visual_origins_and_four_doors(tmp_path):
    run = _run_copy(tmp_path, "test4")
    _stand_in_meshes(run)
    result = read_spark_run(run)
    assert [j.type for j in result.asset.movable_joints()] == ["revolute"] * 4
    assert len(result.record["meshes"]) == 5


def test_missing_glbs_of_the_repository_are_an_error_naming_what_was_looked_for(tmp_path):
    run = _run_copy(tmp_path, "test3")  # the repository has none of test3's GLBs
    with pytest.raises(InputError) as err:
        read_spark_run(run)
    message = str(err.value)
    assert "'glb/part_0_geometry_0.glb'" in message
    assert str(run / "glb" / "part_0_geometry_0_cleaned_textured_aligned.glb") in message
    assert str(run / "glb" / "part_0_geometry_0.glb") in message
