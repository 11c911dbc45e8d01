"""SINGAPO / DIPO / CAGE output (``object.json`` + ``plys/part_<i>.ply``) read into our frame.

The runs are written here the way the methods' code writes them: ``object.json``'s ``diffuse_tree``
(``data/utils.py`` ``parse_tree``: ids, parents, children, names, ``aabb``, joints with ``range`` [0, r]
in degrees for revolute joints and ``axis`` origin/direction in the object frame) and one PLY per part
already placed in the object frame (``scripts/mesh_retrieval/retrieve.py``: ``plys/part_<i>.ply``,
``json.dump`` without indent), in PartNet-Mobility's raw mesh frame (Y up, front +Z). The open state is
checked against a copy of SINGAPO's own ``objects/motions.py`` ``transform_all_parts``.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_edits import edit_json
from helpers_formats import refused, write_runs

from spark_bench.data.case import Benchmark
from spark_bench.data.readers import load_object
from spark_bench.formats.foreign import read_import_record, to_benchmark
from spark_bench.formats.runs import import_runs
from spark_bench.formats.singapo import RAW_TO_OURS, read_run

# PLY written by trimesh keeps float64 vertices; normalizing by a box of them is exact to rounding.
TOL = 1e-6
OURS_TO_RAW = RAW_TO_OURS.T
OBJECT_JSON = "object.json"  # the run file of the parts and joints (``diffuse_tree``)


# ----- writing runs as SINGAPO does ------------------------------------------------------------------------
def _box_ply(path: Path, center, size) -> None:
    """A part as ``retrieve.py`` leaves it: a mesh scaled to the box size and moved to the box centre."""
    mesh = trimesh.creation.box(extents=np.asarray(size, float))
    mesh.apply_translation(np.asarray(center, float))
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)


def write_json_run(run: Path, tree: list[dict], meta: dict | None = None, name: str = "object.json",
                   mesh_dir: str = "plys") -> Path:
    """``tree`` (nodes with ``aabb``) as ``retrieve.py`` writes it: box PLYs and ``plys`` entries."""
    run.mkdir(parents=True, exist_ok=True)
    for node in tree:
        _box_ply(run / mesh_dir / f"part_{node['id']}.ply", node["aabb"]["center"], node["aabb"]["size"])
        node["plys"] = [f"{mesh_dir}/part_{node['id']}.ply"]
    (run / name).write_text(json.dumps({"meta": meta or {"obj_cat": "StorageFurniture"}, "diffuse_tree": tree}))
    return run


def write_gt_run(run: Path, gt) -> Path:
    """A ground-truth object written as SINGAPO writes a generated one (raw frame, degrees, parts at rest)."""
    (run / "plys").mkdir(parents=True, exist_ok=True)
    names = list(gt.links)
    meshes = gt.link_meshes()
    frames = gt.joint_frames()
    tree, scene = [], trimesh.Scene()
    for index, link_name in enumerate(names):
        joint = gt.joint_of_child(link_name)
        raw = trimesh.Trimesh(meshes[link_name].vertices @ OURS_TO_RAW.T, meshes[link_name].faces)
        raw.export(run / "plys" / f"part_{index}.ply")
        scene.add_geometry(raw)
        lo, hi = raw.bounds
        node = {"id": index, "name": "base" if joint is None else gt.links[link_name].label,
                "parent": -1 if joint is None else names.index(joint.parent),
                "children": [names.index(j.child) for j in gt.joints.values() if j.parent == link_name],
                "aabb": {"center": ((lo + hi) / 2).tolist(), "size": (hi - lo).tolist()},
                "plys": [f"plys/part_{index}.ply"]}
        if joint is None or not joint.is_movable:
            node["joint"] = {"type": "fixed", "range": [0.0, 0.0],
                             "axis": {"direction": [0.0, 0.0, 0.0], "origin": [0.0, 0.0, 0.0]}}
        else:
            point, direction = frames[joint.name]
            span = joint.upper - joint.lower
            node["joint"] = {"type": joint.type,
                             "range": [0.0, math.degrees(span) if joint.type == "revolute" else span],
                             "axis": {"direction": (OURS_TO_RAW @ direction).tolist(),
                                      "origin": (OURS_TO_RAW @ point).tolist()}}
        tree.append(node)
    scene.export(run / "object.ply")
    (run / "object.json").write_text(json.dumps({"meta": {"obj_cat": gt.category}, "diffuse_tree": tree}))
    return run


def generated_tree() -> list[dict]:
    """An object as SINGAPO generates it (keys and values of ``parse_tree``; DIPO's ``results/0``
    drawers): a base, a door (negative range, as ``range * 360`` can be) with a handle, a drawer."""
    return [
        {"id": 0, "name": "base", "parent": -1, "children": [1, 3],
         "aabb": {"center": [-0.0103, -0.0458, -0.0235], "size": [0.6330, 1.6899, 0.7636]},
         "joint": {"type": "fixed", "range": [0.0, 0.0],
                   "axis": {"direction": [0.0, 0.0, 0.0], "origin": [0.0, 0.0, 0.0]}}},
        {"id": 1, "name": "door", "parent": 0, "children": [2],
         "aabb": {"center": [-0.0164, 0.3704, 0.3608], "size": [0.6260, 0.8247, 0.0400]},
         "joint": {"type": "revolute", "range": [0.0, -75.3],
                   "axis": {"direction": [0.0, 1.0, 0.0], "origin": [0.2966, 0.3704, 0.3608]}}},
        {"id": 2, "name": "handle", "parent": 1, "children": [],
         "aabb": {"center": [-0.2105, 0.3704, 0.3925], "size": [0.0392, 0.2165, 0.0407]},
         "joint": {"type": "fixed", "range": [0.0, 0.0],
                   "axis": {"direction": [0.0, 0.0, 0.0], "origin": [0.0, 0.0, 0.0]}}},
        {"id": 3, "name": "drawer", "parent": 0, "children": [],
         "aabb": {"center": [-0.0168, -0.4147, 0.0138], "size": [0.5987, 0.7065, 0.7051]},
         "joint": {"type": "prismatic", "range": [0.0, 0.43554750084877014],
                   "axis": {"direction": [0.00042564640170894563, -0.0023120748810470104, 0.9999973],
                            "origin": [-0.0168, -0.4147, 0.0138]}}},
    ]


def singapo_open(vertices: list[np.ndarray], tree: list[dict]) -> list[np.ndarray]:
    """SINGAPO's ``objects/motions.py`` ``transform_all_parts`` at joint state 1 with
    ``rotation_fix_range=False`` (the range as written), ``dry_run=False``: children first, each part
    and its children moved by its joint (radians of the degrees written; Rodrigues about the direction
    through the origin)."""
    from scipy.spatial.transform import Rotation

    out = [v.copy() for v in vertices]
    order, todo = [], [next(n["id"] for n in tree if n["parent"] == -1)]
    while todo:
        current = todo.pop(0)
        order.append(current)
        todo += tree[current]["children"]
    for i in reversed(order):
        joint, moved = tree[i]["joint"], [i] + tree[i]["children"]
        if joint["type"] == "prismatic":
            for k in moved:
                out[k] = out[k] + np.asarray(joint["axis"]["direction"]) * joint["range"][1]
        elif joint["type"] in ("revolute", "continuous"):
            angle = np.radians(joint["range"][1] if joint["type"] == "revolute" else 360.0)
            d = np.asarray(joint["axis"]["direction"], float)
            rot = Rotation.from_rotvec(angle * d / np.linalg.norm(d)).as_matrix()
            o = np.asarray(joint["axis"]["origin"], float)
            for k in moved:
                out[k] = (out[k] - o) @ rot.T + o
    return out


# ----- the round trip --------------------------------------------------------------------------------------
def test_the_raw_frame_is_partnet_mobility_s_mesh_frame():
    assert np.allclose(RAW_TO_OURS @ [0, 1, 0], [0, 0, 1])  # Y up -> Z up
    assert np.allclose(RAW_TO_OURS @ [0, 0, 1], [-1, 0, 0])  # front +Z -> front -X
    assert np.isclose(np.linalg.det(RAW_TO_OURS), 1.0)


def test_a_ground_truth_written_as_singapo_comes_back(bench, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    benchmark = write_runs(bench, runs, write_gt_run)
    report = import_runs("singapo", runs, bench, out, reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0", "cab1"], report.lines()
    for case in benchmark.cases():
        gt, imported = case.load_gt(), load_object(out / case.id)
        assert np.allclose(imported.bounds(), gt.bounds(), atol=TOL)
        assert np.allclose(imported.bounds(imported.open_configuration()), gt.bounds(gt.open_configuration()),
                           atol=TOL)
        gt_frames, frames = gt.joint_frames(), imported.joint_frames()
        by_label = {imported.links[j.child].label: j for j in imported.movable_joints()}
        for joint in gt.movable_joints():
            mine = by_label[gt.links[joint.child].label]
            assert mine.type == joint.type
            assert math.isclose(mine.upper - mine.lower, joint.upper - joint.lower, abs_tol=TOL)
            (p, a), (q, b) = gt_frames[joint.name], frames[mine.name]
            assert min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < TOL
            assert np.linalg.norm(np.cross(q - p, a)) < 1e-5  # the pivot is on the ground truth's line
        record = read_import_record(out / case.id)
        assert record["format"] == "singapo" and record["frame"]["yaw_deg"] == 0.0
        assert set(record["frame"]["open"]) == {"scale"}
        assert record["format_frame"] == "PartNet-Mobility raw: Y up, front +Z"
        assert record["files"][0] == "object.json" and "plys/part_2.ply" in record["files"]


def test_the_open_state_is_singapo_s_own(tmp_path):
    tree = generated_tree()
    run = write_json_run(tmp_path / "run", json.loads(json.dumps(tree)))
    found = read_run(run)
    asset = found.asset
    assert {n: j.type for n, j in asset.joints.items()} == {"joint_1": "revolute", "joint_2": "fixed",
                                                            "joint_3": "prismatic"}
    door = asset.joints["joint_1"]
    assert math.isclose(door.upper, math.radians(75.3)) and door.lower == 0.0
    rest = [trimesh.load(run / f"plys/part_{i}.ply").vertices for i in range(4)]
    opened = singapo_open(rest, tree)
    meshes = asset.link_meshes(asset.open_configuration())
    for i in range(4):
        assert np.allclose(meshes[f"link_{i}"].vertices, opened[i] @ RAW_TO_OURS.T, atol=1e-9), i
    rest_meshes = asset.link_meshes()
    assert all(np.allclose(rest_meshes[f"link_{i}"].vertices, rest[i] @ RAW_TO_OURS.T, atol=1e-9) for i in range(4))
    assert [asset.links[f"link_{i}"].label for i in range(4)] == ["base", "door", "handle", "drawer"]
    assert asset.category == "StorageFurniture" and found.open_questions == ("scale",)
    assert any("negated axis" in f["fact"] for f in found.record["facts"])
    assert all(f["source"] for f in found.record["facts"])
    normalized, _ = to_benchmark(found, "x")
    assert np.isclose(np.ptp(normalized.bounds(), axis=0).max(), 2.0)


def test_a_screw_is_a_slide_and_a_turn(tmp_path):
    tree = generated_tree()
    tree[3]["joint"]["type"] = "screw"
    asset = read_run(write_json_run(tmp_path / "run", tree)).asset
    slide, turn = asset.joints["joint_3"], asset.joints["joint_3_turn"]
    assert (slide.type, slide.child, turn.type, turn.parent, turn.child) == (
        "prismatic", "link_3_helper", "continuous", "link_3_helper", "link_3")
    assert np.allclose(slide.axis, turn.axis) and not asset.links["link_3_helper"].has_geometry


def test_the_first_sample_and_cage_s_names_are_found(tmp_path):
    demo = tmp_path / "demo_output"
    write_json_run(demo / "1", generated_tree())
    write_json_run(demo / "0", generated_tree()[:2] + [{**generated_tree()[3], "id": 2}])
    demo_tree = json.loads((demo / "0" / "object.json").read_text())["diffuse_tree"]
    demo_tree[0]["children"] = [1, 2]
    demo_tree[1]["children"] = []
    (demo / "0" / "object.json").write_text(json.dumps({"meta": {}, "diffuse_tree": demo_tree}))
    graph = [{k: n[k] for k in ("id", "parent", "name", "children")} for n in generated_tree()]
    (demo / "pred_graph.json").write_text(json.dumps({"diffuse_tree": graph}, indent=4))  # demo.py save_graph
    found = read_run(demo)
    assert found.record["sample"] == "0" and found.record["files"][0] == "0/object.json"
    assert len(found.asset.links) == 3
    cage = write_json_run(tmp_path / "cage", generated_tree(), name="#0.json", mesh_dir="#0_meshes")
    found = read_run(cage)
    assert found.record["files"][:2] == ["#0.json", "#0_meshes/part_0.ply"]


# ----- bad inputs ---------------------------------------------------------------------------------------
@pytest.fixture
def run(tmp_path) -> Path:
    return write_json_run(tmp_path / "cab0", generated_tree())


def test_a_truncated_ply_is_refused(run):
    ply = run / "plys" / "part_1.ply"
    ply.write_bytes(ply.read_bytes()[: len(ply.read_bytes()) // 2])
    refused(read_run, run, "cannot read mesh", file="plys/part_1.ply")


def test_a_mesh_path_leaving_the_run_folder_is_refused(run, tmp_path):
    shutil.copy(run / "plys" / "part_1.ply", tmp_path / "outside.ply")
    edit_json(run / OBJECT_JSON, lambda t: t[1].update(plys=["../outside.ply"]), part="diffuse_tree")
    refused(read_run, run, "node 1", "'../outside.ply' leaves the run folder", file="object.json")
    edit_json(run / OBJECT_JSON, lambda t: t[1].update(plys=[str(tmp_path / "outside.ply")]),
              part="diffuse_tree")
    refused(read_run, run, "leaves the run folder", file="object.json")


def test_nan_in_an_axis_is_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[1]["joint"]["axis"].update(direction=[0.0, float("nan"), 0.0]),
              part="diffuse_tree")
    assert "NaN" in (run / "object.json").read_text()  # json.dump writes NaN, json.load reads it back
    refused(read_run, run, "node 1: revolute joint axis direction is not 3 finite numbers",
            file="object.json")


def test_a_zero_axis_on_a_moving_part_is_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[3]["joint"]["axis"].update(direction=[0.0, 0.0, 0.0]),
              part="diffuse_tree")
    refused(read_run, run, "node 3: prismatic joint axis direction [0.0, 0.0, 0.0] is zero",
            file="object.json")


def test_a_missing_part_file_is_refused(run):
    (run / "plys" / "part_3.ply").unlink()
    refused(read_run, run, "node 3: part mesh file is missing", file="plys/part_3.ply")


def test_a_failed_retrieval_is_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: [n.pop("plys") for n in t], part="diffuse_tree")
    refused(read_run, run, "node 0: no 'plys'", "did not run or failed", file="object.json")


def test_a_cycle_in_the_tree_is_refused(run):
    def loop(tree):  # 1 -> 3 -> 1: both hang from each other, children lists agreeing
        tree[0]["children"] = []
        tree[1].update(parent=3, children=[2, 3])
        tree[3].update(parent=1, children=[1])
    edit_json(run / OBJECT_JSON, loop, part="diffuse_tree")
    refused(read_run, run, "cycle in the tree: nodes 1 -> 3 -> 1", "no path to the root", file="object.json")
    # the base hangs from the loop too: no root at all
    edit_json(run / OBJECT_JSON, lambda t: t[0].update(parent=2), part="diffuse_tree")
    refused(read_run, run, "expected one root (parent -1), found 0", file="object.json")


def test_children_that_disagree_with_parents_are_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[0].update(children=[1, 2, 3]), part="diffuse_tree")
    refused(read_run, run, "node 0 lists child 2, whose parent is not 0", file="object.json")


def test_radians_where_degrees_are_written_are_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[1]["joint"].update(range=[0.0, -1.314]), part="diffuse_tree")
    refused(read_run, run, "look like radians", "node 1: -1.314", "writes degrees", file="object.json")


def test_a_range_beyond_a_full_turn_or_not_from_zero_is_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[1]["joint"].update(range=[0.0, 400.0]), part="diffuse_tree")
    refused(read_run, run, "node 1: revolute range 400.0 is beyond a full turn", file="object.json")
    edit_json(run / OBJECT_JSON, lambda t: t[1]["joint"].update(range=[10.0, 90.0]), part="diffuse_tree")
    refused(read_run, run, "node 1: joint range starts at 10.0, not 0", file="object.json")


def test_an_unknown_joint_type_is_refused(run):
    edit_json(run / OBJECT_JSON, lambda t: t[3]["joint"].update(type="slider"), part="diffuse_tree")
    refused(read_run, run, "node 3: joint type 'slider' is not one of", file="object.json")


def test_a_file_that_is_not_the_format_is_refused(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    refused(read_run, run, "no SINGAPO output", file="run")
    (run / "object.json").write_text("{\"diffuse")
    refused(read_run, run, "malformed JSON", file="object.json")
    (run / "object.json").write_text(json.dumps({"parts": []}))
    refused(read_run, run, "not a SINGAPO object: no 'diffuse_tree'", file="object.json")
    (run / "object.json").write_text(json.dumps({"diffuse_tree": {"0": {}}}))
    refused(read_run, run, "diffuse_tree is not a non-empty list of nodes", file="object.json")


def test_the_import_lists_a_refused_run_with_its_reason(bench, tmp_path):
    runs = tmp_path / "runs"
    write_gt_run(runs / "cab0", Benchmark(bench).case("cab0").load_gt())
    write_json_run(runs / "cab1", generated_tree())
    (runs / "cab1" / "plys" / "part_2.ply").unlink()
    report = import_runs("singapo", runs, bench, tmp_path / "pred", reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"]
    reason = report.skipped[0].reason
    assert "cab1/plys/part_2.ply" in reason and "part mesh file is missing" in reason
