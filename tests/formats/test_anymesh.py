"""Articulate AnyMesh output (``mobility.json`` and ``mesh_parts/<part>.glb``) read into our frame.

The runs are written here the way Articulate AnyMesh's code writes them
(``UMass-Embodied-AGI/ArticulateAnymesh``): the object in ``render_object``'s frame (the mesh centred,
box diagonal 2, Y up; here the ground truth turned by ``YAW_DEG`` about the up axis, as an input mesh
comes), each part a trimesh GLB ``mesh_parts/<link>@<k>.glb`` (``postprocess_segmentation``), and
``mobility.json`` as ``get_mobility_json`` dumps it (one line, moving parts first, ``base`` last, parents
by name, no limits): a revolute axis through some point on the hinge (the mean of the chosen label
points) with a direction of arbitrary sign, a prismatic axis at ``[0, 0, 0]`` with a direction that is
not unit (an arrow).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_boxes import box_mesh
from helpers_formats import assert_matches_ground_truth, refused

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.readers import load_object
from spark_bench.formats.anymesh import read_run
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.runs import import_runs
from spark_bench.metrics.evaluate import compute_metrics

# GLB keeps float32 vertices (about 1e-7 at unit size): the footprint turn found from them is off by
# about that much, which moves points by less than 1e-6; 1e-5 still catches any frame or sign error.
TOL = 1e-5
YAW_DEG = 31.0
PARTNET_ROOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # Y up, front +Z -> ours
NAMES = {"link_0": "drawer@1", "link_1": "door@1"}  # the cabinet's parts as the segmentation names them


class AnyMeshFrame:
    """Ours (benchmark frame) -> Articulate AnyMesh's: turned by YAW_DEG, Y up, box centred, diagonal 2."""

    def __init__(self, points: np.ndarray):
        self.rotation = PARTNET_ROOT.T @ axis_angle_matrix([0, 0, 1], math.radians(YAW_DEG))
        turned = points @ self.rotation.T
        lo, hi = turned.min(0), turned.max(0)
        self.center, self.scale = (lo + hi) / 2, 2.0 / float(np.linalg.norm(hi - lo))

    def point(self, p: np.ndarray) -> np.ndarray:
        return (np.asarray(p) @ self.rotation.T - self.center) * self.scale

    def direction(self, d: np.ndarray) -> np.ndarray:
        return np.asarray(d) @ self.rotation.T


def write_mobility(run: Path, entries: list[dict]) -> None:
    """``json.dump(mobility_json, open(..., 'w'))``: one line."""
    with open(run / "mobility.json", "w") as f:
        json.dump(entries, f)


def write_anymesh(run: Path, gt) -> list[dict]:
    """``gt`` written as Articulate AnyMesh's run folder; returns the ``mobility.json`` entries."""
    meshes = gt.link_meshes(gt.rest_configuration())
    frame = AnyMeshFrame(np.concatenate([m.vertices for m in meshes.values()]))
    (run / "mesh_parts").mkdir(parents=True, exist_ok=True)
    for link, mesh in meshes.items():
        name = NAMES.get(link, "base")
        trimesh.Trimesh(frame.point(mesh.vertices), mesh.faces).export(run / "mesh_parts" / f"{name}.glb")
    trimesh.Trimesh(frame.point(gt.mesh().vertices), gt.mesh().faces).export(run / "mesh_normalized.glb")
    frames = gt.joint_frames()
    entries = []
    for k, joint in enumerate(gt.movable_joints()):
        point, direction = frames[joint.name]
        if joint.type == "prismatic":  # an arrow: not unit
            data = {"axis": {"origin": [0, 0, 0], "direction": (0.37 * frame.direction(direction)).tolist()}}
        else:  # another point of the hinge, the direction's sign as the SVD gives it
            data = {"axis": {"origin": frame.point(point + 0.2 * direction).tolist(),
                             "direction": (-frame.direction(direction)).tolist()}}
        entries.append({"id": k, "parent": "base", "joint": joint.type, "name": NAMES[joint.child],
                        "jointData": data})
    entries.append({"id": len(entries), "parent": None, "joint": "fixed", "name": "base", "jointData": {}})
    write_mobility(run, entries)
    return entries


def test_round_trip_against_the_ground_truth(bench, gt, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    write_anymesh(runs / "cab0", gt)
    report = import_runs("anymesh", runs, bench, out, cases=["cab0"], reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"] and report.imported[0].articulated

    imported = load_object(out / "cab0")
    mine = assert_matches_ground_truth(imported, gt, NAMES, TOL)
    by_label = {imported.links[j.child].label: j for j in mine.values()}
    assert by_label["door@1"].upper == pytest.approx(math.pi) and by_label["drawer@1"].upper == 0.0

    # and as the metrics see it (alignment by ICP, as `eval --align icp` scores an import)
    metrics = compute_metrics(imported, gt, n_samples=3000, n_match_samples=2000, align="icp", workers=1)
    assert metrics.rest.cd < 1e-5 and not metrics.missing_joints and not metrics.extra_joints
    assert all(m.type_match and m.axis_err < 1e-5 for m in metrics.matches)
    assert [m.pivot_err < 1e-4 for m in metrics.matches if m.gt_type == "revolute"] == [True]

    record = read_import_record(out / "cab0")
    assert record["format"] == "anymesh" and set(record["frame"]["open"]) == {"yaw", "scale", "front"}
    assert record["files"] == ["mobility.json", "mesh_parts/drawer@1.glb", "mesh_parts/door@1.glb",
                               "mesh_parts/base.glb"]
    assert record["limits"]["revolute"]["upper"] == pytest.approx(math.pi)
    assert all("source" in f for f in record["facts"])


def test_nested_parts_move_with_their_parent(tmp_path):
    """A handle fixed to a door and a knob turning on it (parents by name, in Articulate AnyMesh's frame:
    Y up): the door's hinge carries both."""
    parts = {"base": box_mesh([0.6, 0.8, 0.2], [0, 0, -0.1]),
             "door@1": box_mesh([0.6, 0.4, 0.02], [0.3, 0.2, 0.01]),
             "handle@1": box_mesh([0.05, 0.2, 0.04], [0.5, 0.2, 0.04]),
             "knob@1": box_mesh([0.04, 0.04, 0.04], [0.1, 0.3, 0.04])}
    (tmp_path / "mesh_parts").mkdir()
    for name, mesh in parts.items():
        mesh.export(tmp_path / "mesh_parts" / f"{name}.glb")
    hinge = {"origin": [0.0, 0.5, 0.0], "direction": [0.0, 2.0, 0.0]}  # the door's left edge, along Y (up)
    write_mobility(tmp_path, [
        {"id": 0, "parent": "base", "joint": "revolute", "name": "door@1", "jointData": {"axis": hinge}},
        {"id": 1, "parent": "door@1", "joint": "fixed", "name": "handle@1", "jointData": {}},
        {"id": 2, "parent": "door@1", "joint": "continuous", "name": "knob@1",
         "jointData": {"axis": {"origin": [0.1, 0.3, 0.04], "direction": [0.0, 0.0, 1.0]}}},
        {"id": 3, "parent": None, "joint": "fixed", "name": "base", "jointData": {}}])
    asset = read_run(tmp_path).asset
    to_ours = PARTNET_ROOT
    rest = asset.link_meshes(asset.rest_configuration())
    for name, mesh in parts.items():
        link = next(n for n, link in asset.links.items() if link.label == name)
        assert np.abs(rest[link].vertices - mesh.vertices @ to_ours.T).max() < 1e-6  # float32 GLB
    door = next(j for j in asset.joints.values() if j.type == "revolute")
    frames = asset.joint_frames()
    assert np.allclose(frames[door.name][1], to_ours @ [0, 1, 0])  # Y up became Z up
    assert np.allclose(frames[door.name][1], [0, 0, 1])
    assert np.linalg.norm(np.cross(frames[door.name][0] - to_ours @ [0, 0.5, 0], [0, 0, 1])) < 1e-9
    knob = next(j for j in asset.joints.values() if j.type == "continuous")
    assert np.allclose(frames[knob.name][0], to_ours @ [0.1, 0.3, 0.04])
    # a quarter turn of the door carries the handle and the knob's axis about the hinge
    turned = asset.joint_frames({door.name: math.pi / 2})
    pivot = frames[door.name][0]
    expected = axis_angle_matrix([0, 0, 1], math.pi / 2) @ (frames[knob.name][0] - pivot) + pivot
    assert np.allclose(turned[knob.name][0], expected)
    handle = next(n for n, link in asset.links.items() if link.label == "handle@1")
    moved = asset.link_meshes({door.name: math.pi / 2})[handle].vertices
    quarter = axis_angle_matrix([0, 0, 1], math.pi / 2)
    assert np.allclose(moved, (rest[handle].vertices - pivot) @ quarter.T + pivot)


# ----- bad input ------------------------------------------------------------------------------------------
@pytest.fixture
def run(gt, tmp_path) -> Path:
    write_anymesh(tmp_path / "run", gt)
    return tmp_path / "run"


def _entries(run: Path) -> list[dict]:
    return json.loads((run / "mobility.json").read_text())


def test_nan_in_an_axis_is_refused(run):
    entries = _entries(run)
    entries[1]["jointData"]["axis"]["direction"][0] = math.nan  # json.dump writes NaN
    write_mobility(run, entries)
    assert refused(read_run, run, "door@1", "direction", "finite").path.endswith("mobility.json")


def test_a_zero_axis_is_refused(run):
    entries = _entries(run)
    entries[0]["jointData"]["axis"]["direction"] = [0, 0, 0]
    write_mobility(run, entries)
    refused(read_run, run, "drawer@1", "is zero")


def test_a_missing_part_file_is_refused(run):
    (run / "mesh_parts" / "door@1.glb").unlink()
    assert refused(read_run, run, "door@1", "mesh is missing").path.endswith("mesh_parts/door@1.glb")


def test_a_truncated_glb_is_refused(run):
    path = run / "mesh_parts" / "base.glb"
    path.write_bytes(path.read_bytes()[:200])
    assert refused(read_run, run, "cannot read mesh").path.endswith("base.glb")


def test_a_cycle_is_refused(run):
    entries = _entries(run)
    entries[0]["parent"], entries[1]["parent"] = "door@1", "drawer@1"
    write_mobility(run, entries)
    refused(read_run, run, "cycle in the part tree", "drawer@1 -> door@1 -> drawer@1")


def test_a_name_leading_out_of_mesh_parts_is_refused(run):
    entries = _entries(run)
    entries[0]["name"] = "../../drawer@1"
    write_mobility(run, entries)
    assert refused(read_run, run, "leaves mesh_parts/").path.endswith("mobility.json")


def test_a_parent_the_segmentation_did_not_find_is_refused(run):
    entries = _entries(run)
    entries[1]["parent"] = "None"  # postprocess_segmentation writes f"{idx}. {None}"
    write_mobility(run, entries)
    refused(read_run, run, "parent 'None' names no part", "found no part of the parent link")


def test_limits_in_degrees_are_refused(run):
    """Articulate AnyMesh writes no limits; PartNet-Mobility's (degrees) mean another file."""
    entries = _entries(run)
    entries[1]["jointData"]["limit"] = {"a": 0.0, "b": 90.0, "noLimit": False}
    write_mobility(run, entries)
    refused(read_run, run, "door@1", "writes none", "degrees")


def test_partnet_mobility_v2_json_is_refused(run):
    write_mobility(run, [
        {"id": 0, "parent": -1, "joint": "heavy", "name": "base_body", "parts": [], "jointData": {}},
        {"id": 1, "parent": 0, "joint": "hinge", "name": "door", "parts": [],
         "jointData": {"axis": {"origin": [0, 0, 0], "direction": [0, 1, 0]},
                       "limit": {"a": 0, "b": 90, "noLimit": False}}}])
    refused(read_run, run, "'heavy' is PartNet-Mobility's mobility_v2.json word")


def test_other_files_are_refused(run):
    entries = _entries(run)
    entries[0]["joint"] = "ball"
    write_mobility(run, entries)
    refused(read_run, run, "joint type 'ball'")
    (run / "mobility.json").write_text('{"parts": []}')
    refused(read_run, run, "expected a non-empty list of parts")
    (run / "mobility.json").write_text("[{")
    refused(read_run, run, "malformed JSON")
    (run / "mobility.json").unlink()
    assert refused(read_run, run, "no Articulate AnyMesh mobility.json").path.endswith("mobility.json")
