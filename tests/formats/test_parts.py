"""PartCrafter and OmniPart output (shape-only part meshes) read into our frame.

The runs are written here the way the methods' code writes them:

- PartCrafter (``wgsxm/PartCrafter`` ``scripts/inference_partcrafter.py``): each part a float32
  ``trimesh.Trimesh`` exported as ``part_{i:02}.glb``, in the object box of largest side 2, Y up with the
  input view's front towards +Z (here: the ground truth turned by ``YAW_DEG`` about the up axis, as a
  view leaves it); ``object.glb`` the same parts as one scene with random vertex colours
  (``get_colored_mesh_composition``); a part it could not decode written as its one-vertex stand-in.
- OmniPart (authors' ``scripts/inference_omnipart.py``, ``merge_parts``): the parts in TRELLIS's cube
  ``[-0.5, 0.5]^3`` (Z up), turned Y up by ``to_glb``, merged into ``mesh_textured.glb`` and
  ``mesh_segment.glb``; ``bboxes_vis.glb`` (boxes) beside them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh
from helpers_formats import refused
from scipy.spatial import cKDTree

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.readers import load_object
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.parts import read_run
from spark_bench.formats.runs import import_runs
from spark_bench.metrics.evaluate import compute_metrics

# GLB keeps float32 vertices (about 1e-7 at unit size) and the OBJ written by the import 9 digits; 1e-5
# leaves margin and still catches any frame, sign or scale error (those are of order 0.1).
TOL = 1e-5
YAW_DEG = 31.0  # the input view's turn about the up axis, left open by the format
PARTNET_ROOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # Y up, front +Z -> ours
TO_GLB = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # TRELLIS to_glb: v @ TO_GLB


def gt_parts(gt) -> list[trimesh.Trimesh]:
    """The ground truth's links with geometry, each at rest in the benchmark frame (ours)."""
    return list(gt.link_meshes(gt.rest_configuration()).values())


def _turned_vertices(parts: list[trimesh.Trimesh], rotation: np.ndarray) -> list[np.ndarray]:
    return [np.asarray(p.vertices) @ rotation.T for p in parts]


def _partcrafter_normalized(vertex_sets: list[np.ndarray], largest_side: float) -> list[np.ndarray]:
    """PartCrafter's ``normalize_mesh`` over the whole object: box centred, largest side ``largest_side``."""
    points = np.concatenate(vertex_sets)
    lo, hi = points.min(0), points.max(0)
    return [(v - (lo + hi) / 2) * (largest_side / (hi - lo).max()) for v in vertex_sets]


def write_partcrafter(run: Path, gt, failed: tuple[int, ...] = (),
                      object_glb: bool = True) -> list[trimesh.Trimesh]:
    """``gt`` written as PartCrafter's ``<output_dir>/<tag>/``; part numbers in ``failed`` are its stand-in
    for a part that did not decode. Returns the meshes written, in part order."""
    to_partcrafter = PARTNET_ROOT.T @ axis_angle_matrix([0, 0, 1], math.radians(YAW_DEG))
    parts = gt_parts(gt)
    vertex_sets = _partcrafter_normalized(_turned_vertices(parts, to_partcrafter), 2.0)
    outputs = [trimesh.Trimesh(v.astype(np.float32), p.faces) for v, p in zip(vertex_sets, parts)]
    for index in failed:
        outputs.insert(index, trimesh.Trimesh(vertices=[[0, 0, 0]], faces=[[0, 0, 0]]))
    run.mkdir(parents=True, exist_ok=True)
    for i, mesh in enumerate(outputs):
        mesh.export(run / f"part_{i:02}.glb")
    if object_glb:
        scene = trimesh.Scene()
        for mesh in outputs:
            colored = mesh.copy()
            colored.visual = trimesh.visual.ColorVisuals(mesh=colored, vertex_colors=(np.random.rand(3) * 256)
                                                         .astype(int))
            scene.add_geometry(colored)
        scene.export(run / "object.glb")
    (run / "rendering.png").write_bytes(b"")  # --render's outputs: not read
    return outputs


def write_omnipart(run: Path, gt) -> None:
    """``gt`` written as OmniPart's ``<output_root>/<image stem>/`` after ``merge_parts``."""
    to_trellis = axis_angle_matrix([0, 0, 1], math.radians(90.0 + YAW_DEG))
    parts = gt_parts(gt)
    # inside TRELLIS's [-0.5, 0.5]^3
    vertex_sets = _partcrafter_normalized(_turned_vertices(parts, to_trellis), 0.98)
    glbs = [trimesh.Trimesh(v @ TO_GLB, p.faces) for v, p in zip(vertex_sets, parts)]
    run.mkdir(parents=True, exist_ok=True)
    trimesh.Scene(glbs).export(run / "mesh_textured.glb")
    colored = []
    for i, mesh in enumerate(glbs):
        mesh = mesh.copy()
        mesh.visual = trimesh.visual.ColorVisuals(mesh=mesh, vertex_colors=[40 * i, 100, 200, 255])
        colored.append(mesh)
    trimesh.Scene(colored).export(run / "mesh_segment.glb")
    trimesh.Scene([trimesh.creation.box(extents=[1, 1, 1])]).export(run / "bboxes_vis.glb")  # not parts
    np.save(run / "bboxes.npy", np.zeros((len(parts), 2, 3)))


def _max_gap(a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance from a vertex of either set to the other set."""
    return max(float(cKDTree(b).query(a)[0].max()), float(cKDTree(a).query(b)[0].max()))


def _assert_same_parts(imported, gt) -> None:
    """Each imported part is the ground truth's part of the same rank, vertex for vertex, up to a quarter
    turn about Z (the footprint squaring leaves one; the cabinet's footprint is not square)."""
    expected = gt_parts(gt)
    names = [n for n in imported.links if imported.links[n].has_geometry]
    assert len(names) == len(expected)
    assert not imported.movable_joints() and all(j.type == "fixed" for j in imported.joints.values())
    got = imported.link_meshes(imported.rest_configuration())
    best = min(range(4), key=lambda k: _max_gap(np.asarray(got[names[0]].vertices) @
                                                axis_angle_matrix([0, 0, 1], k * math.pi / 2).T,
                                                np.asarray(expected[0].vertices)))
    turn = axis_angle_matrix([0, 0, 1], best * math.pi / 2)
    for name, mesh in zip(names, expected):
        assert _max_gap(np.asarray(got[name].vertices) @ turn.T, np.asarray(mesh.vertices)) < TOL


def test_partcrafter_round_trip(bench, gt, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    write_partcrafter(runs / "cab0", gt, failed=(1,))
    report = import_runs("parts", runs, bench, out, cases=["cab0"], reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"] and not report.imported[0].articulated

    imported = load_object(out / "cab0")
    _assert_same_parts(imported, gt)
    metrics = compute_metrics(imported, gt, n_samples=3000, n_match_samples=2000, align="icp", workers=1)
    assert metrics.rest.cd < 1e-5 and not metrics.matches  # the shape scored; no joint to match
    record = read_import_record(out / "cab0")
    assert record["method"] == "PartCrafter" and record["articulated"] is False
    assert record["files"] == ["part_00.glb", "part_01.glb", "part_02.glb", "part_03.glb", "object.glb"]
    assert len(record["failed_parts"]) == 1
    assert record["failed_parts"][0].startswith("part_01.glb: 1 vertices")
    assert [p["source"] for p in record["parts"]] == ["part_00.glb", "part_02.glb", "part_03.glb"]
    turned = (record["frame"]["yaw_deg"] + YAW_DEG) % 90.0
    assert min(turned, 90.0 - turned) < 1e-4  # the view's turn squared away
    assert all("source" in f and "PartCrafter" in f["source"] for f in record["facts"])


def test_partcrafter_scene_alone_gives_one_part_per_node(gt, tmp_path):
    run = tmp_path / "run"
    write_partcrafter(run, gt, failed=(0,))
    for part in run.glob("part_*.glb"):
        part.unlink()
    found = read_run(run)
    assert found.record["files"] == ["object.glb"] and not found.articulated
    assert len(found.record["parts"]) == len(gt_parts(gt)) and len(found.record["failed_parts"]) == 1
    assert all(p["source"].startswith("object.glb#geometry_") for p in found.record["parts"])
    # Z up in our frame: height over footprint diameter (blind to the turn about Z) is the ground truth's
    assert abs(_height_ratio(found.asset.mesh().vertices) - _height_ratio(gt.mesh().vertices)) < TOL


def _height_ratio(vertices: np.ndarray) -> float:
    from scipy.spatial.distance import pdist

    return float(np.ptp(vertices[:, 2]) / pdist(np.unique(vertices[:, :2], axis=0)).max())


def test_the_forks_ordered_scene_is_preferred(gt, tmp_path):
    """SPARK's fork (``YumengHe/PartCrafter`` ``inference_partcrafter_part.py``) also writes
    ``object_scene_ordered.glb``: one node ``{i:02d}_link_{i}`` per part, in part order."""
    outputs = write_partcrafter(tmp_path, gt)
    for part in tmp_path.glob("part_*.glb"):
        part.unlink()
    scene = trimesh.Scene()
    for i, mesh in enumerate(outputs):
        scene.add_geometry(mesh.copy(), node_name=f"{i:02d}_link_{i}", geom_name=f"{i:02d}_link_{i}")
    scene.export(tmp_path / "object_scene_ordered.glb")
    found = read_run(tmp_path)
    assert found.record["files"] == ["object_scene_ordered.glb"]
    assert [p["source"] for p in found.record["parts"]] == [
        f"object_scene_ordered.glb#{i:02d}_link_{i}" for i in range(len(outputs))]


def test_omnipart_round_trip(bench, gt, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    write_omnipart(runs / "cab0", gt)
    report = import_runs("parts", runs, bench, out, cases=["cab0"], reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"]
    _assert_same_parts(load_object(out / "cab0"), gt)
    record = read_import_record(out / "cab0")
    assert record["method"] == "OmniPart" and record["files"] == ["mesh_textured.glb"]
    assert record["not_read"] == ["bboxes_vis.glb (not parts)"] and record["failed_parts"] == []


def test_omnipart_part_files_left_before_merge_parts(gt, tmp_path):
    """A run that stopped before ``merge_parts``: ``part{i}.glb`` for ``i >= 1`` (part 0 is never a part)."""
    run = tmp_path / "run"
    write_omnipart(run, gt)
    scene = trimesh.load(run / "mesh_textured.glb", process=False)
    for path in (run / "mesh_textured.glb", run / "mesh_segment.glb"):
        path.unlink()
    for i, node in enumerate(sorted(scene.graph.nodes_geometry), 1):
        transform, geom = scene.graph[node]
        scene.geometry[geom].copy().apply_transform(transform).export(run / f"part{i}.glb")
    found = read_run(run)
    assert found.record["method"] == "OmniPart"
    assert found.record["files"] == [f"part{i}.glb" for i in range(1, len(gt_parts(gt)) + 1)]


# ----- bad input ------------------------------------------------------------------------------------------
def test_truncated_glb_is_refused_naming_it(gt, tmp_path):
    write_partcrafter(tmp_path, gt)
    data = (tmp_path / "part_01.glb").read_bytes()
    (tmp_path / "part_01.glb").write_bytes(data[: len(data) // 2])
    error = refused(read_run, tmp_path, "part_01.glb")
    assert error.path.endswith("part_01.glb")


def test_truncated_scene_is_refused_naming_it(gt, tmp_path):
    write_omnipart(tmp_path, gt)
    data = (tmp_path / "mesh_textured.glb").read_bytes()
    (tmp_path / "mesh_textured.glb").write_bytes(data[:100])
    assert refused(read_run, tmp_path, "cannot read GLB").path.endswith("mesh_textured.glb")


def test_a_missing_part_file_is_refused(gt, tmp_path):
    write_partcrafter(tmp_path / "gap", gt)
    (tmp_path / "gap" / "part_01.glb").unlink()  # a gap in the numbers
    error = refused(read_run, tmp_path / "gap", "part file missing", "none numbered 1")
    assert error.path.endswith("part_01.glb")
    write_partcrafter(tmp_path / "last", gt)
    (tmp_path / "last" / "part_02.glb").unlink()  # the last one: object.glb counts the parts
    assert refused(read_run, tmp_path / "last", "object.glb holds 3 parts").path.endswith("part_02.glb")


def test_a_part_file_leading_out_of_the_run_is_refused(gt, tmp_path):
    write_partcrafter(tmp_path / "run", gt, object_glb=False)
    outside = tmp_path / "elsewhere.glb"
    (tmp_path / "run" / "part_00.glb").rename(outside)
    (tmp_path / "run" / "part_00.glb").symlink_to(outside)
    assert refused(read_run, tmp_path / "run", "leads out of the run folder").path.endswith("part_00.glb")


def test_only_failed_parts_is_refused(tmp_path):
    dummy = trimesh.Trimesh(vertices=[[0, 0, 0]], faces=[[0, 0, 0]])
    for i in range(2):
        dummy.export(tmp_path / f"part_{i:02}.glb")
    refused(read_run, tmp_path, "no part has a surface", "part_00.glb: 1 vertices", "part_01.glb")


def test_nan_vertices_are_refused(tmp_path):
    box = trimesh.creation.box()
    vertices = np.asarray(box.vertices).copy()
    vertices[0, 0] = np.nan
    trimesh.Trimesh(vertices, box.faces, process=False).export(tmp_path / "part_00.glb")
    assert refused(read_run, tmp_path, "NaN").path.endswith("part_00.glb")


def test_nan_vertices_in_a_scene_are_refused(tmp_path):
    box = trimesh.creation.box()
    vertices = np.asarray(box.vertices).copy()
    vertices[3, 1] = np.inf
    broken = trimesh.Trimesh(vertices, box.faces, process=False)
    trimesh.Scene([box, broken]).export(tmp_path / "mesh_segment.glb")
    assert refused(read_run, tmp_path, "NaN or infinite").path.endswith("mesh_segment.glb")


def test_a_folder_of_another_format_is_refused(tmp_path):
    (tmp_path / "mobility.json").write_text("[]")
    refused(read_run, tmp_path, "no part meshes of PartCrafter or OmniPart", "part_NN.glb",
            "mesh_textured.glb")
    (tmp_path / "part_00.glb").write_text('{"not": "a glb"}')
    assert refused(read_run, tmp_path, "cannot read").path.endswith("part_00.glb")
