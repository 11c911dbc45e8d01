"""Any method's URDF read into our frame (``spark_bench.formats.urdf``).

The runs are written here the way each method's code writes them:

- PhysX-Anything (``4_simready_gen.py``): ``basic.urdf`` with ``l_world``, ``l_<i>`` links meshing
  ``./objs/<i>/<i>.obj`` in the object frame, ``abstract_*`` links, a revolute joint at the pivot with
  the child moved back by a fixed joint, limits ``range / 180 * pi`` and ``range / 32``, an inertial on
  every link, ``floating`` for a free part; TRELLIS's Z-up unit cube;
- URDFormer (``utils.py`` ``write_urdfs``): ``output/<name>.urdf`` naming ``../meshes/cabinet.obj`` and
  ``../meshes/parts/<template>.obj`` with ``<mesh scale>``, fixed limits (0.4 m, 1.57 rad), front +X;
- Articulate-Anything (``odio_urdf.py``): ``mobility.urdf`` with absolute paths into the PartNet-Mobility
  dataset (the meshes copied beside it as ``textured_objs/``), the turned root joint ``rpy="1.5708 0
  1.5708"``, joints and pivots in the parent's frame, visual origins;
- a ROS package (``package://``) with STL, PLY, GLB and DAE meshes and no inertials;
- FreeArt3D's ``output.urdf`` (with ``tests/formats/test_freeart3d.py``'s writer).
"""

from __future__ import annotations

import importlib.util
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_edits import edit_text
from helpers_formats import refused, write_runs

from spark_bench.asset.transforms import axis_angle_matrix, rpy_to_matrix
from spark_bench.data.case import Benchmark
from spark_bench.data.readers import load_object
from spark_bench.formats import urdf as urdf_format
from spark_bench.formats.foreign import read_import_record, to_benchmark
from spark_bench.formats.runs import import_runs
from spark_bench.formats.urdf import read_run

# OBJ keeps 8 significant digits and GLB float32: 1e-5 leaves margin and still catches any frame, sign or
# scale error (those are of order 0.1).
TOL = 1e-5
QUARTER = axis_angle_matrix([0, 0, 1], math.pi / 2)  # TRELLIS's front (-Y) from ours (-X)
HALF = axis_angle_matrix([0, 0, 1], math.pi)  # front +X (URDFormer, Articulate-Anything) from ours (-X)
AA_ROOT_RPY = "1.570796326794897 0 1.570796326794897"  # articulate-anything README "Rotate meshes"


def _text(values) -> str:
    return " ".join(str(float(v)) for v in values)


def _export(mesh: trimesh.Trimesh, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)


def _moved(mesh: trimesh.Trimesh, rotation: np.ndarray, scale: float = 1.0, shift=(0.0, 0.0, 0.0)):
    return trimesh.Trimesh(scale * mesh.vertices @ rotation.T - np.asarray(shift), mesh.faces, process=False)


def _link(robot: ET.Element, name: str, mesh: str | None = None, scale: str | None = None,
          origin: str = "0 0 0", inertial: bool = True, collision: bool = True,
          material: bool = False) -> ET.Element:
    link = ET.SubElement(robot, "link", name=name)
    if inertial:
        block = ET.SubElement(link, "inertial")
        ET.SubElement(block, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(block, "mass", value="1.0")
        ET.SubElement(block, "inertia", ixx="1.0", ixy="0.0", ixz="0.0", iyy="1.0", iyz="0.0", izz="1.0")
    if mesh is not None:
        for role in ("visual", "collision") if collision else ("visual",):
            element = ET.SubElement(link, role)
            if material and role == "visual":  # URDFormer's
                ET.SubElement(ET.SubElement(element, "material", name="white"), "color", rgba="0.8 0.8 0.8 1")
            geometry = ET.SubElement(element, "geometry")
            ET.SubElement(geometry, "mesh", filename=mesh, **({"scale": scale} if scale else {}))
            ET.SubElement(element, "origin", xyz=origin, rpy="0 0 0")
    return link


def _joint(robot: ET.Element, name: str, kind: str, parent: str, child: str, xyz: str = "0 0 0",
           rpy: str = "0 0 0", axis: str | None = None, limits: tuple | None = None) -> ET.Element:
    joint = ET.SubElement(robot, "joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    ET.SubElement(joint, "origin", xyz=xyz, rpy=rpy)
    if axis is not None:
        ET.SubElement(joint, "axis", xyz=axis)
    if limits is not None:
        ET.SubElement(joint, "limit", lower=str(limits[0]), upper=str(limits[1]), effort="2000.0",
                      velocity="2.0")
    return joint


def _save(robot: ET.Element, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    tree = ET.ElementTree(robot)
    ET.indent(tree, space="  ", level=0)
    tree.write(path, encoding="utf-8", xml_declaration=True)
    return path


# ----- the methods' writers ---------------------------------------------------------------------------------
def write_physx_run(run: Path, gt, free_part: bool = False) -> Path:
    """``gt`` (benchmark frame) as PhysX-Anything writes it: TRELLIS's unit cube, ``basic.urdf``."""
    meshes, frames = gt.link_meshes(), gt.joint_frames()
    joints = {j.child: j for j in gt.movable_joints()}
    robot = ET.Element("robot", name="scene")
    _link(robot, "l_world")
    parts = [gt.root, *joints]
    for index, link in enumerate(parts):
        _export(_moved(meshes[link], QUARTER, 0.5), run / "objs" / str(index) / f"{index}.obj")
    _link(robot, "l_0", "./objs/0/0.obj", "1 1 1", collision=False)
    _joint(robot, "joint_fixed_world0", "fixed", "l_world", "l_0")
    for index, link in enumerate(parts[1:], start=1):
        joint, (point, axis) = joints[link], frames[joints[link].name]
        abstract = f"abstract_0_{index}"
        _link(robot, f"l_{index}", f"./objs/{index}/{index}.obj", "1 1 1", collision=False)
        _link(robot, abstract)
        if joint.type == "prismatic":  # group type B: limits range / voxel_define
            _joint(robot, f"joint_fixed_{abstract}", "fixed", abstract, f"l_{index}")
            _joint(robot, f"joint_prismatic_l_0_{abstract}", "prismatic", "l_0", abstract,
                   axis=_text(QUARTER @ axis), limits=(0.5 * joint.lower, 0.5 * joint.upper))
        else:  # group type C: the pivot, the child moved back, limits range / 180 * pi
            pivot = 0.5 * QUARTER @ point
            _joint(robot, f"joint_fixed_{abstract}", "fixed", abstract, f"l_{index}", xyz=_text(-pivot))
            degrees = np.degrees([joint.lower, joint.upper])
            _joint(robot, f"joint_revolute_l_0_{abstract}", "revolute", "l_0", abstract, xyz=_text(pivot),
                   axis=_text(QUARTER @ axis), limits=tuple(degrees / 180 * np.pi))
    if free_part:  # group type A: a free part (a small box on top)
        box = trimesh.creation.box([0.05, 0.05, 0.05])
        box.apply_translation([0.0, 0.0, 0.55])
        _export(box, run / "objs" / "3" / "3.obj")
        _link(robot, "l_3", "./objs/3/3.obj", "1 1 1", collision=False)
        _link(robot, "abstract_0_3")
        _joint(robot, "joint_fixed_abstract_0_3", "fixed", "abstract_0_3", "l_3")
        _joint(robot, "joint_free_l_0_abstract_0_3", "floating", "l_0", "abstract_0_3")
    return _save(robot, run / "basic.urdf").parent


URDFORMER_LIMITS = {"drawer": (0, 0.4), "doorR": (0, 1.57), "doorL": (-1.57, 0)}  # utils.py write_urdfs
URDFORMER_SCALE = np.array([1.0, 2.0, 0.5])


def write_urdformer_run(run: Path, gt, name: str = "label13", door: str = "doorR") -> Path:
    """``gt`` as URDFormer writes it: front +X, ``output/<name>.urdf``, scaled templates in ``meshes/``,
    doors about +Z, its fixed limits (``doorL``: ``[-1.57, 0]``)."""
    meshes, frames = gt.link_meshes(), gt.joint_frames()
    robot = ET.Element("robot", name="my_urdf")
    _export(_moved(meshes[gt.root], HALF), run / "meshes" / "cabinet.obj")
    _link(robot, "base_link", "../meshes/cabinet.obj", "1 1 1", material=True)
    for index, joint in enumerate(gt.movable_joints()):
        template = "drawer" if joint.type == "prismatic" else door
        point, axis = frames[joint.name]
        position = HALF @ point
        local = _moved(meshes[joint.child], HALF, shift=position)
        _export(trimesh.Trimesh(local.vertices / URDFORMER_SCALE, local.faces), run / "meshes" / "parts" /
                f"{template}.obj")
        _link(robot, f"{template}{index}", f"../meshes/parts/{template}.obj", _text(URDFORMER_SCALE),
              material=True)
        element = _joint(robot, f"{template}{index}_to_base_link", joint.type, "base_link",
                         f"{template}{index}", xyz=_text(position), rpy="0.0 0.0 0.0",
                         axis=_text(HALF @ axis),
                         limits=URDFORMER_LIMITS[template])
        element.find("limit").set("effort", "5")
    return _save(robot, run / "output" / f"{name}.urdf").parent.parent


def write_articulate_anything_run(run: Path, gt, copy_meshes: bool = True) -> Path:
    """``gt`` as Articulate-Anything writes it: PartNet-Mobility meshes (Y up) named by absolute paths into
    the dataset, the turned root joint, joints in the parent's frame, visual origins."""
    dataset = "/home/someone/articulate-anything/datasets/partnet-mobility-v0/dataset/46197/textured_objs"
    to_mesh = rpy_to_matrix([float(v) for v in AA_ROOT_RPY.split()]).T @ HALF  # ours -> the mesh frame
    meshes, frames = gt.link_meshes(), gt.joint_frames()
    names = {gt.root: "cabinet_body", **{j.child: ("drawer" if j.type == "prismatic" else "door")
                                         for j in gt.movable_joints()}}
    robot = ET.Element("robot", name="cabinet")
    ET.SubElement(robot, "link", name="base")
    for k, link in enumerate(names):
        if copy_meshes:
            _export(_moved(meshes[link], to_mesh), run / "textured_objs" / f"original-{k}.obj")
    _link(robot, "cabinet_body", f"{dataset}/original-0.obj", inertial=False)
    _joint(robot, "base_to_cabinet_body", "fixed", "base", "cabinet_body", rpy=AA_ROOT_RPY)
    for k, joint in enumerate(gt.movable_joints(), start=1):
        point, axis = frames[joint.name]
        pivot = to_mesh @ point
        _link(robot, names[joint.child], f"{dataset}/original-{k}.obj", origin=_text(-pivot), inertial=False)
        element = _joint(robot, f"cabinet_body_to_{names[joint.child]}", joint.type, "cabinet_body",
                         names[joint.child], xyz=_text(pivot), axis=_text(to_mesh @ axis),
                         limits=(joint.lower, joint.upper))
        element.find("limit").attrib.update(effort="5", velocity="5")
    return _save(robot, run / "mobility.urdf").parent


#: DAE needs pycollada (installed here, not a declared dependency): without it the door is a GLB.
HAS_COLLADA = importlib.util.find_spec("collada") is not None
FORMATS = {"base": ("stl", "glb", "obj", "stl", "glb", "obj"), "link_0": ("ply",),
           "link_1": ("dae",) if HAS_COLLADA else ("glb",)}


def write_package_run(run: Path, gt) -> Path:
    """``gt`` as a ROS package: ``my_pkg/urdf/object.urdf`` with ``package://my_pkg/meshes/...`` in several
    mesh formats, no inertials, link frames at the joints."""
    robot = ET.Element("robot", name="object")
    for link in gt.links.values():
        joint = gt.joint_of_child(link.name)
        offset = np.zeros(3) if joint is None else gt.link_poses()[link.name][:3, 3]
        kinds = FORMATS[link.name]
        element = ET.SubElement(robot, "link", name=link.name)
        for k, visual in enumerate(link.visuals):
            file = f"{link.name}_{k}.{kinds[k % len(kinds)]}"
            mesh = trimesh.Trimesh(visual.mesh.vertices, visual.mesh.faces)
            _export(mesh, run / "my_pkg" / "meshes" / file)
            geometry = ET.SubElement(ET.SubElement(element, "visual"), "geometry")
            ET.SubElement(geometry, "mesh", filename=f"package://my_pkg/meshes/{file}")
        if joint is not None:
            _joint(robot, joint.name, joint.type, joint.parent, link.name, xyz=_text(offset),
                   axis=_text(joint.axis), limits=(joint.lower, joint.upper))
    return _save(robot, run / "my_pkg" / "urdf" / "object.urdf").parent.parent.parent


# ----- the comparison ---------------------------------------------------------------------------------------
def assert_same_object(found, gt, turn: np.ndarray, limits: bool = True) -> dict:
    """``found`` after :func:`to_benchmark` is ``gt`` turned by ``turn``: rest bounds, joint types, axes (up
    to sign), pivots on the line; with ``limits``, the open bounds and the limits too."""
    asset, record = to_benchmark(found, "case")
    assert abs(record["frame"]["yaw_deg"]) < 1e-4  # axis-aligned already: only the quarter turns are left
    expected = np.sort(gt.mesh().vertices @ turn.T, axis=0)[[0, -1]]
    assert np.allclose(asset.bounds(), expected, atol=TOL)
    assert [j.type for j in asset.movable_joints()] == [j.type for j in gt.movable_joints()]
    gt_frames, frames = gt.joint_frames(), asset.joint_frames()
    for joint, mine in zip(gt.movable_joints(), asset.movable_joints()):
        (p, a), (q, b) = gt_frames[joint.name], frames[mine.name]
        p, a = turn @ p, turn @ a
        assert min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < 1e-6
        if joint.type == "revolute":
            assert np.linalg.norm(np.cross(q - p, a)) < TOL
        if limits:  # radians as written; lengths scaled into the benchmark frame, as the ground truth's
            assert math.isclose(mine.lower, joint.lower, abs_tol=1e-9)
            assert math.isclose(mine.upper, joint.upper, rel_tol=1e-6), (mine.name, mine.upper, joint.upper)
    if limits:
        expected = np.sort(gt.mesh(gt.open_configuration()).vertices @ turn.T, axis=0)[[0, -1]]
        assert np.allclose(asset.bounds(asset.open_configuration()), expected, atol=TOL)
    return record


# ----- round trips ------------------------------------------------------------------------------------------
def test_physx_anything_runs_come_back_through_the_import(bench, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    benchmark = write_runs(bench, runs, write_physx_run)
    report = import_runs("urdf", runs, bench, out, reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0", "cab1"], report.lines()
    for case in benchmark.cases():
        gt, imported = case.load_gt(), load_object(out / case.id)
        record = read_import_record(out / case.id)
        rest = np.sort(gt.mesh().vertices @ QUARTER.T, axis=0)[[0, -1]]
        assert np.allclose(imported.bounds(), rest, atol=TOL)
        opened = np.sort(gt.mesh(gt.open_configuration()).vertices @ QUARTER.T, axis=0)[[0, -1]]
        assert np.allclose(imported.bounds(imported.open_configuration()), opened, atol=TOL)
        assert [j.type for j in imported.movable_joints()] == ["prismatic", "revolute"]
        assert record["format"] == "urdf" and record["urdf"] == "basic.urdf"
        assert record["urdf_choice"].startswith("known name (ziangcao0312/PhysX-Anything")
        assert record["files"] == ["basic.urdf", "objs/0/0.obj", "objs/1/1.obj", "objs/2/2.obj"]
        assert record["root_joint"] == "identity"
        assert set(record["frame"]["open"]) == {"yaw", "scale", "front"}
        assert record["not_read"][0] == "0 <collision> elements (the metrics use visuals)"


def test_physx_anything_round_trip_keeps_joints_and_limits(gt, tmp_path):
    found = read_run(write_physx_run(tmp_path / "run", gt))
    assert_same_object(found, gt, QUARTER)
    assert [m["rule"] for m in found.record["meshes"]] == ["relative"] * 3


def test_a_physx_anything_free_part_is_read_as_fixed(gt, tmp_path):
    found = read_run(write_physx_run(tmp_path / "run", gt, free_part=True))
    assert found.record["joints_made_fixed"] == ["joint_free_l_0_abstract_0_3"]
    assert found.asset.joints["joint_free_l_0_abstract_0_3"].type == "fixed"
    assert any("floating / planar" in f["fact"] for f in found.record["facts"])
    top = found.asset.link_meshes()["l_3"].bounds
    assert np.allclose(top, [[-0.025, -0.025, 0.525], [0.025, 0.025, 0.575]], atol=TOL)


@pytest.mark.parametrize("door", ["doorR", "doorL"])
def test_urdformer_round_trip_with_scaled_templates_one_folder_up(gt, tmp_path, door):
    found = read_run(write_urdformer_run(tmp_path / "run", gt, door=door))
    assert_same_object(found, gt, HALF, limits=False)  # the rest: doorL's [-1.57, 0] read as [0, 1.57]
    assert found.record["urdf"] == "output/label13.urdf" and found.record["urdf_choice"] == "the only URDF"
    assert found.record["files"] == ["output/label13.urdf", "meshes/cabinet.obj", "meshes/parts/drawer.obj",
                                     f"meshes/parts/{door}.obj"]
    assert [(j.lower, j.upper) for j in found.asset.movable_joints()] == [(0.0, 0.4), (0.0, 1.57)]
    drawer, hinge = found.asset.movable_joints()
    assert np.allclose(drawer.axis, [1, 0, 0])  # URDFormer's drawers slide along +X
    assert np.allclose(hinge.axis, [0, 0, 1] if door == "doorR" else [0, 0, -1])
    assert found.record["joints_negated"] == ([] if door == "doorR" else ["doorL1_to_base_link"])


def test_articulate_anything_round_trip_with_absolute_dataset_paths(gt, tmp_path):
    found = read_run(write_articulate_anything_run(tmp_path / "run", gt))
    assert_same_object(found, gt, HALF)
    assert found.record["root_joint"] == "articulate-anything"
    assert {m["rule"] for m in found.record["meshes"]} == {"absolute-tail"}
    assert found.record["meshes"][0]["file"] == "textured_objs/original-0.obj"
    assert {f["source"].split()[0] for f in found.record["facts"]} >= {"vlongle/articulate-anything"}


def test_package_paths_and_every_mesh_format_without_inertials(gt, tmp_path):
    found = read_run(write_package_run(tmp_path / "run", gt))
    assert_same_object(found, gt, np.eye(3))
    files = found.record["files"]
    assert files[0] == "my_pkg/urdf/object.urdf"
    kinds = {".stl", ".glb", ".obj", ".ply"} | ({".dae"} if HAS_COLLADA else set())
    assert {Path(f).suffix for f in files[1:]} == kinds
    assert {m["rule"] for m in found.record["meshes"]} == {"package"}


def test_freeart3d_output_urdf_is_read_through_its_joint_info(bench, gt, tmp_path):
    from test_freeart3d import write_run as write_freeart3d_run

    from spark_bench.formats.freeart3d import read_run as read_freeart3d

    run = write_freeart3d_run(tmp_path / "run", gt)
    found, direct = read_run(run), read_freeart3d(run)
    assert found.record["read_through"] == "freeart3d" and found.record["format"] == "urdf"
    assert found.record["files"][:2] == ["output.urdf", "sds_output/joint_info.json"]
    assert found.record["facts"][0]["source"].startswith("PeterZs/FreeArt3D pipelines/urdf.py")
    assert np.allclose(found.asset.bounds(), direct.asset.bounds())
    (run / "sds_output" / "joint_info.json").unlink()
    refused(read_run, run, "FreeArt3D's output.urdf", "joint_info.json", "is missing", file="output.urdf")


def test_an_object_folder_reads_as_the_project_s_loader_reads_it(bench, tmp_path):
    """A PartNet-Mobility-layout folder (a case's ``gt/``: ``mobility.urdf``, ``textured_objs/``) gives what
    :func:`load_object` gives: the mesh paths rewritten here lead to the same files."""
    import shutil

    case = Benchmark(bench).case("cab1")
    run = Path(shutil.copytree(case.gt_dir, tmp_path / "cab1"))
    found, loaded = read_run(run), load_object(case.gt_dir)
    assert found.record["urdf"] == "mobility.urdf" and found.record["root_joint"] == "identity"
    assert [(j.name, j.type, j.parent, j.child) for j in found.asset.joints.values()] == [
        (j.name, j.type, j.parent, j.child) for j in loaded.joints.values()]
    for joint in loaded.joints.values():
        mine = found.asset.joints[joint.name]
        assert np.allclose(mine.origin, joint.origin) and np.allclose(mine.axis, joint.axis)
        assert (mine.lower, mine.upper) == (joint.lower, joint.upper)
    for q in (None, loaded.open_configuration()):
        ours, theirs = found.asset.link_meshes(q), loaded.link_meshes(q)
        assert ours.keys() == theirs.keys()
        # the same files through the same reader: equal to rounding (two code paths: no bit-equality)
        assert all(np.allclose(ours[n].vertices, theirs[n].vertices, rtol=0.0, atol=1e-12) for n in theirs)


# ----- choosing the URDF ------------------------------------------------------------------------------------
def test_the_method_s_name_is_chosen_among_several(gt, tmp_path):
    run = write_physx_run(tmp_path / "run", gt)
    (run / "aaa.urdf").write_text((run / "basic.urdf").read_text())
    (run / "temp_robot.urdf").write_text("<robot name='scratch'/>")
    found = read_run(run)
    assert found.record["urdf"] == "basic.urdf" and found.record["other_urdfs"] == ["aaa.urdf"]
    (run / "basic.urdf").rename(run / "zzz.urdf")
    found = read_run(run)
    assert found.record["urdf"] == "aaa.urdf" and found.record["urdf_choice"].startswith("the first by name")


# ----- bad inputs -------------------------------------------------------------------------------------------
@pytest.fixture
def physx(gt, tmp_path) -> Path:
    return write_physx_run(tmp_path / "cab0", gt)


def test_a_truncated_glb_is_refused(gt, tmp_path):
    run = write_package_run(tmp_path / "run", gt)
    glb = run / "my_pkg" / "meshes" / "base_1.glb"
    glb.write_bytes(glb.read_bytes()[:200])
    refused(read_run, run, "cannot read mesh", file="base_1.glb")


def test_a_mesh_path_leaving_the_run_folder_is_refused(gt, physx, tmp_path):
    run = write_urdformer_run(tmp_path / "urdformer", gt)
    (run / "output" / "label13.urdf").rename(run / "label13.urdf")  # ../meshes now leads out of the run
    # the message names the way out: the URDF named directly is read as ROS reads it
    refused(read_run, run, "mesh path '../meshes/cabinet.obj' leaves the run folder", "name the URDF file",
            "--package-path", file="label13.urdf")
    as_shipped = write_urdformer_run(tmp_path / "as_shipped", gt)
    assert set(load_object(as_shipped / "output" / "label13.urdf").links) == set(read_run(as_shipped).asset.links)
    edit_text(physx / "basic.urdf", "./objs/1/1.obj", "../../outside/1.obj")
    refused(read_run, physx, "'../../outside/1.obj' leaves the run folder", file="basic.urdf")


def test_a_symlinked_mesh_leading_out_is_refused(physx, tmp_path):
    outside = tmp_path / "elsewhere.obj"
    (physx / "objs" / "2" / "2.obj").rename(outside)
    (physx / "objs" / "2" / "2.obj").symlink_to(outside)
    refused(read_run, physx, "'./objs/2/2.obj' leaves the run folder", file="basic.urdf")


def test_absolute_paths_with_no_copy_in_the_run_are_refused(gt, tmp_path):
    run = write_articulate_anything_run(tmp_path / "run", gt, copy_meshes=False)
    refused(read_run, run, "original-0.obj' is absolute, outside the run folder", file="mobility.urdf")


def test_a_missing_part_file_is_refused(physx):
    (physx / "objs" / "2" / "2.obj").unlink()
    refused(read_run, physx, "link 'l_2' has no visual mesh with a surface", "'objs/2/2.obj' not found",
            file="basic.urdf")


def test_nan_in_an_axis_is_refused(physx):
    edit_text(physx / "basic.urdf", '<axis xyz="', '<axis xyz="nan ')
    refused(read_run, physx, "zero or NaN axis", file="basic.urdf")


def test_a_cycle_in_the_tree_is_refused(physx):
    edit_text(physx / "basic.urdf", "</robot>", '<joint name="back" type="fixed"><parent link="l_2"/>'
                                            '<child link="l_world"/></joint></robot>')
    refused(read_run, physx, "kinematic cycle", file="basic.urdf")


def test_degrees_where_radians_are_meant_are_refused(physx):
    text = (physx / "basic.urdf").read_text()
    upper = text.split('type="revolute"')[1].split('upper="')[1].split('"')[0]
    edit_text(physx / "basic.urdf", f'upper="{upper}"', 'upper="90.0"')
    refused(read_run, physx, "revolute limits [0, 90] are beyond 2 pi", "radians", "degrees",
            file="basic.urdf")


def test_a_file_that_is_not_a_urdf_is_refused(physx, tmp_path):
    (physx / "basic.urdf").write_text('<mujoco model="scene"><worldbody/></mujoco>')
    refused(read_run, physx, "root element is <mujoco>, expected <robot>", file="basic.urdf")
    (physx / "basic.urdf").write_text("<robot name='x'><link")
    refused(read_run, physx, "malformed XML", file="basic.urdf")
    empty = tmp_path / "empty"
    empty.mkdir()
    refused(read_run, empty, "no URDF (*.urdf)", file="empty")


@pytest.mark.skipif(not HAS_COLLADA, reason="writing the DAE fixture needs pycollada")
def test_dae_without_pycollada_is_a_clear_error(gt, tmp_path, monkeypatch):
    run = write_package_run(tmp_path / "run", gt)
    real = urdf_format.importlib.util.find_spec
    monkeypatch.setattr(urdf_format.importlib.util, "find_spec", lambda name, *a: None if name == "collada"
                        else real(name, *a))
    refused(read_run, run, "'package://my_pkg/meshes/link_1_0.dae' is COLLADA", "needs pycollada",
            file="object.urdf")


def test_the_import_lists_a_refused_run_with_its_reason(bench, tmp_path):
    runs = tmp_path / "runs"
    write_runs(bench, runs, write_physx_run)
    (runs / "cab1" / "objs" / "0" / "0.obj").unlink()
    report = import_runs("urdf", runs, bench, tmp_path / "pred", reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"]
    assert "cab1/basic.urdf" in report.skipped[0].reason and "objs/0/0.obj" in report.skipped[0].reason
