"""FreeArt3D output (``sds_output/joint_info.json``, ``sds_output/part_meshes/*.glb``) read into our frame.

The runs are written here the way FreeArt3D's code writes them (``pipelines/sds.py`` ``recon``;
``pipelines/urdf.py`` ``write_urdf``): the parts at the open (last input) state, exported by TRELLIS's
``to_glb`` turn (Z up -> Y up, ``v @ [[1, 0, 0], [0, 0, -1], [0, 1, 0]]``) as GLB; ``joint_info.json``
in TRELLIS's Z-up unit cube with ``range`` ``[0, s]`` (radians for a revolute joint), indent 4. The
closed state is checked against a copy of ``recon``'s own state export.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_edits import edit_json
from helpers_formats import refused, write_runs

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.case import Benchmark
from spark_bench.data.readers import load_object
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.freeart3d import read_run
from spark_bench.formats.runs import import_runs

# GLB stores float32 vertices: about 1e-7 at unit size; 1e-5 leaves margin and still catches any frame,
# sign or scale error (those are of order 0.1).
GLB_TOL = 1e-5
TO_GLB = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # TRELLIS postprocessing_utils.to_glb
YAW_DEG = 90.0  # TRELLIS's front is -Y: our -X turned a quarter turn
SIZE = 0.45  # the benchmark's [-1, 1] into TRELLIS's [-0.5, 0.5]
JOINT_INFO = "sds_output/joint_info.json"  # the run file of the joints


def _yaw_turn() -> np.ndarray:
    return axis_angle_matrix([0, 0, 1], math.radians(YAW_DEG))


def _write_glb(path: Path, vertices_trellis: np.ndarray, faces: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.Trimesh(vertices_trellis @ TO_GLB, faces, process=False).export(path)


def _write_urdf(run: Path, info: list[dict]) -> None:
    """``output.urdf`` as ``write_urdf`` writes it (not read by the reader, there for the layout)."""
    robot = ET.Element("robot", name=run.name)
    link = ET.SubElement(robot, "link", name="base_link")
    ET.SubElement(ET.SubElement(ET.SubElement(link, "visual"), "geometry"), "mesh",
                  filename="sds_output/part_meshes/fixed.glb")
    for i, entry in enumerate(info):
        d, o = entry["axis"]["direction"], entry["axis"]["origin"]
        axis = [d[0], d[2], -d[1]]
        axis = [abs(v) for v in axis] if entry["type"] == "prismatic" else axis
        link = ET.SubElement(robot, "link", name=f"link_articulated_{i:02d}")
        ET.SubElement(ET.SubElement(ET.SubElement(link, "visual"), "geometry"), "mesh",
                      filename=f"sds_output/part_meshes/articulated_{i:02d}.glb")
        joint = ET.SubElement(robot, "joint", name=f"joint_articulated_{i:02d}", type=entry["type"])
        ET.SubElement(joint, "parent", link="base_link")
        ET.SubElement(joint, "child", link=f"link_articulated_{i:02d}")
        ET.SubElement(joint, "origin", xyz=f"{o[0]} {o[2]} {-o[1]}", rpy="0 0 0")
        ET.SubElement(joint, "axis", xyz=" ".join(map(str, axis)))
        ET.SubElement(joint, "limit", lower=str(entry["range"][1]), upper="0.0", effort="1000", velocity="1000")
    ET.ElementTree(robot).write(run / "output.urdf", encoding="utf-8", xml_declaration=True)


def write_run(run: Path, gt, negative: bool = True) -> Path:
    """``gt`` (benchmark frame) written as FreeArt3D writes its output: turned into TRELLIS's frame, parts
    at the open state, ``joint_info.json`` with ``s`` of the sign ``negative`` asks (both occur)."""
    to_trellis = SIZE * _yaw_turn()
    frames = gt.joint_frames()
    opened = gt.link_meshes(gt.open_configuration())
    sds = run / "sds_output"
    _write_glb(sds / "part_meshes" / "fixed.glb", opened[gt.root].vertices @ to_trellis.T, opened[gt.root].faces)
    info = []
    for i, joint in enumerate(gt.movable_joints()):
        mesh = opened[joint.child]
        _write_glb(sds / "part_meshes" / f"articulated_{i:02d}.glb", mesh.vertices @ to_trellis.T, mesh.faces)
        point, axis = frames[joint.name]
        axis, travel = _yaw_turn() @ axis, joint.upper - joint.lower
        if joint.type == "revolute":  # closed = turned by +s about d: d = a, s = -travel (or both negated)
            d, s = (axis, -travel) if negative else (-axis, travel)
            origin = (to_trellis @ point).tolist()
        else:  # closed = moved by -s * d: d = a, s = travel (or both negated)
            d, s = (-axis, -travel * SIZE) if negative else (axis, travel * SIZE)
            origin = [0.0, 0.0, 0.0]
        info.append({"type": joint.type, "range": [0, float(s)], "axis": {"origin": origin,
                                                                         "direction": d.tolist()}})
    (sds / "joint_info.json").write_text(json.dumps(info, indent=4))
    _write_urdf(run, info)
    return run


def recon_closed_state(glb: Path, entry: dict) -> np.ndarray:
    """``pipelines/sds.py`` ``recon``'s state export at ``j = 5`` (``states/qpos_00.glb``, closed) for one
    part, in TRELLIS's frame, from ``joint_info.json``'s entry (``joint_axes`` rebuilt from it)."""
    vertices = trimesh.load(glb, force="mesh").vertices.copy()
    vertices[:, [1, 2]] = vertices[:, [2, 1]]
    vertices[:, 1] = -vertices[:, 1]
    s, d = entry["range"][1], np.asarray(entry["axis"]["direction"])
    if entry["type"] == "prismatic":
        joint_axes = -d[::-1]  # recon: direction = -joint_axes[::-1]
        return vertices + joint_axes * s
    pivot = np.asarray(entry["axis"]["origin"])
    return (vertices - pivot) @ axis_angle_matrix(d, s).T + pivot


# ----- the round trip --------------------------------------------------------------------------------------
@pytest.mark.parametrize("negative", [True, False])
def test_a_ground_truth_written_as_freeart3d_comes_back(bench, tmp_path, negative):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    benchmark = write_runs(bench, runs, lambda run, gt: write_run(run, gt, negative=negative))
    report = import_runs("freeart3d", runs, bench, out, reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0", "cab1"], report.lines()
    turn = _yaw_turn()
    for case in benchmark.cases():
        gt, imported = case.load_gt(), load_object(out / case.id)
        record = read_import_record(out / case.id)
        assert abs(record["frame"]["yaw_deg"]) < 1e-4  # already square: TRELLIS's quarter turn is left
        for q_gt, q_imported in [(None, None), (gt.open_configuration(), imported.open_configuration())]:
            expected = np.sort(gt.mesh(q_gt).vertices @ turn.T, axis=0)[[0, -1]]
            assert np.allclose(imported.bounds(q_imported), expected, atol=GLB_TOL)
        gt_frames, frames = gt.joint_frames(), imported.joint_frames()
        assert [j.type for j in imported.movable_joints()] == [j.type for j in gt.movable_joints()]
        for joint, mine in zip(gt.movable_joints(), imported.movable_joints()):
            (p, a), (q, b) = gt_frames[joint.name], frames[mine.name]
            p, a = turn @ p, turn @ a
            assert min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < 1e-6
            if joint.type == "revolute":
                assert np.linalg.norm(np.cross(q - p, a)) < GLB_TOL  # the pivot on the ground truth's line
            assert mine.lower == 0.0 and math.isclose(mine.upper, joint.upper - joint.lower, rel_tol=1e-4)
        assert set(record["frame"]["open"]) == {"yaw", "scale"} and record["format"] == "freeart3d"
        assert record["files"] == ["sds_output/joint_info.json", "sds_output/part_meshes/fixed.glb",
                                   "sds_output/part_meshes/articulated_00.glb",
                                   "sds_output/part_meshes/articulated_01.glb"]
        assert record["not_read"][0] == "output.urdf (present; see facts)"
        assert record["format_frame"].startswith("TRELLIS voxel frame: Z up")


def test_the_closed_state_is_recon_s_own(bench, tmp_path):
    run = write_run(tmp_path / "run", Benchmark(bench).case("cab0").load_gt())
    found = read_run(run)
    info = json.loads((run / "sds_output" / "joint_info.json").read_text())
    rest = found.asset.link_meshes()
    for i, entry in enumerate(info):
        closed = recon_closed_state(run / "sds_output" / "part_meshes" / f"articulated_{i:02d}.glb", entry)
        assert np.allclose(rest[f"link_{i}"].vertices, closed, atol=GLB_TOL), entry["type"]
    opened = found.asset.link_meshes(found.asset.open_configuration())
    written = trimesh.load(run / "sds_output" / "part_meshes" / "articulated_01.glb", force="mesh").vertices
    assert np.allclose(opened["link_1"].vertices, written @ TO_GLB.T, atol=GLB_TOL)  # open = as written
    assert all(f["source"].startswith("PeterZs/FreeArt3D") for f in found.record["facts"])


def test_the_sds_output_folder_itself_is_a_run(bench, tmp_path):
    run = write_run(tmp_path / "run", Benchmark(bench).case("cab1").load_gt())
    found = read_run(run / "sds_output")
    assert found.record["files"][0] == "joint_info.json"
    assert found.record["not_read"][0] == "output.urdf (absent)"


# ----- bad inputs ---------------------------------------------------------------------------------------
@pytest.fixture
def run(bench, tmp_path) -> Path:
    return write_run(tmp_path / "cab0", Benchmark(bench).case("cab0").load_gt())


def test_a_truncated_glb_is_refused(run):
    glb = run / "sds_output" / "part_meshes" / "articulated_00.glb"
    glb.write_bytes(glb.read_bytes()[:200])
    refused(read_run, run, "cannot read mesh", file="articulated_00.glb")


def test_a_missing_part_file_is_refused(run):
    (run / "sds_output" / "part_meshes" / "articulated_01.glb").unlink()
    refused(read_run, run, "joint 1's part mesh file is missing", file="articulated_01.glb")
    (run / "sds_output" / "part_meshes" / "fixed.glb").unlink()
    refused(read_run, run, "the base mesh file is missing", file="fixed.glb")


def test_nan_in_an_axis_is_refused(run):
    edit_json(run / JOINT_INFO, lambda d: d[1]["axis"].update(origin=[0.1, float("nan"), 0.0]), indent=4)
    refused(read_run, run, "joint 1: axis origin is not 3 finite numbers", file="joint_info.json")


def test_a_zero_axis_is_refused(run):
    edit_json(run / JOINT_INFO, lambda d: d[0]["axis"].update(direction=[0, 0, 0]), indent=4)
    refused(read_run, run, "joint 0: axis direction [0.0, 0.0, 0.0] is zero", file="joint_info.json")


def test_degrees_where_radians_are_written_are_refused(run):
    edit_json(run / JOINT_INFO, lambda d: d[1].update(range=[0, -90.0]), indent=4)
    refused(read_run, run, "joint 1: revolute range -90.0 is beyond 2 pi", "radians", file="joint_info.json")


def test_a_range_not_from_zero_or_an_unknown_type_is_refused(run):
    edit_json(run / JOINT_INFO, lambda d: d[0].update(range=[0.1, 0.3]), indent=4)
    refused(read_run, run, "joint 0: range starts at 0.1, not 0", file="joint_info.json")
    edit_json(run / JOINT_INFO, lambda d: d[0].update(range=[0, 0.3], type="continuous"), indent=4)
    refused(read_run, run, "joint 0: type 'continuous' is not prismatic or revolute", file="joint_info.json")


def test_a_file_that_is_not_the_format_is_refused(run, tmp_path):
    info = run / "sds_output" / "joint_info.json"
    info.write_text(json.dumps({"joint_type": "Revolute"}))  # run_estimate's info_dict, not recon's list
    refused(read_run, run, "expected a non-empty list of joints", file="joint_info.json")
    info.write_text("[{")
    refused(read_run, run, "malformed JSON", file="joint_info.json")
    empty = tmp_path / "empty"
    empty.mkdir()
    refused(read_run, empty, "no FreeArt3D joint_info.json", file="sds_output/joint_info.json")


def test_the_import_lists_a_refused_run_with_its_reason(bench, tmp_path):
    runs = tmp_path / "runs"
    write_runs(bench, runs, write_run)
    (runs / "cab1" / "sds_output" / "part_meshes" / "fixed.glb").unlink()
    report = import_runs("freeart3d", runs, bench, tmp_path / "pred", reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"]
    assert "cab1/sds_output/part_meshes/fixed.glb" in report.skipped[0].reason
