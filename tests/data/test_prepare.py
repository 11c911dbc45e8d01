"""Benchmark-case preparation: files, masks, normalization, joints, failures, resume, CLI, named benchmarks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_assets import tiny_cabinet
from helpers_real import REAL_OBJECTS
from PIL import Image
from scipy.ndimage import binary_dilation, binary_erosion

from spark_bench.asset.model import Collision, Link, Visual
from spark_bench.asset.urdf import write_object_folder
from spark_bench.data import load_object
from spark_bench.data.camera import CameraView
from spark_bench.data.case import Benchmark, BenchmarkCase
from spark_bench.data.prepare import (
    STAGES,
    PrepareOptions,
    ground_truth_asset,
    link_color,
    prepare_benchmark,
    read_segmentation,
)
from spark_bench.data.render import BACKGROUND
from spark_bench.errors import SparkBenchError

#: Small renders and a coarse remesh keep the tests fast; the defaults are exercised by the benchmark.
FAST = PrepareOptions(image_size=96, resolution=24)
REAL_IDS = ("40147", "3763")


def write_tiny_object(folder: Path, shift: float = 0.0) -> Path:
    asset = tiny_cabinet()
    if shift:
        asset.joints["joint_drawer"].upper += shift
    write_object_folder(asset, folder)
    return folder


def read_manifest(bench: Path) -> dict:
    return Benchmark(bench).manifest()


def case_of(bench: Path, case_id: str) -> BenchmarkCase:
    return Benchmark(bench).case(case_id)


def write_broken_objects(src: Path) -> None:
    (src / "broken").mkdir(parents=True)
    (src / "broken" / "mobility.urdf").write_text("<robot name='x'><link name='base'>")
    (src / "empty").mkdir()


@pytest.fixture(scope="module")
def real_bench(tmp_path_factory):
    """The two shared real objects and two broken folders, prepared once for the module."""
    if not all((REAL_OBJECTS / i).is_dir() for i in REAL_IDS):
        pytest.skip(f"shared real objects not available ({REAL_OBJECTS} is absent)")
    src = tmp_path_factory.mktemp("src")
    for object_id in REAL_IDS:
        (src / object_id).symlink_to(REAL_OBJECTS / object_id)
    write_broken_objects(src)
    bench = tmp_path_factory.mktemp("bench")
    results = []
    manifest = prepare_benchmark(src, bench, options=FAST, progress=False, on_result=results.append)
    return src, bench, manifest, results


# ----- ground truth --------------------------------------------------------------------------
def test_ground_truth_keeps_convex_collisions_and_mean_colours():
    asset = tiny_cabinet()
    body = asset.links["body"]
    body.visuals.append(Visual(trimesh.creation.box(extents=(0.1, 0.1, 0.1)), (0.0, 0.0, 1.0, 1.0)))
    torus = trimesh.creation.torus(0.2, 0.05)
    body.collisions.append(Collision("mesh", mesh=torus))
    body.collisions.append(Collision("mesh", mesh=trimesh.creation.box(extents=(0.1, 0.2, 0.3))))
    expected = link_color(body)
    areas = np.array([v.mesh.area for v in body.visuals])
    colors = np.array([v.rgba for v in body.visuals])
    # link_color adds 1e-12 to every weight (areas here are >= 1e-2): a relative difference <= 1e-10
    np.testing.assert_allclose(expected, (areas[:, None] * colors).sum(0) / areas.sum(), rtol=1e-9)
    gt, reports = ground_truth_asset(asset, resolution=24)
    assert [c.kind for c in gt.links["body"].collisions] == ["box", "mesh"]  # the torus is dropped
    assert len(gt.links["body"].visuals) == 1
    assert gt.links["body"].visuals[0].rgba == pytest.approx(expected)
    assert set(reports) == {"body", "drawer", "door"}
    for name in reports:
        assert gt.links[name].visuals[0].mesh.is_watertight
    assert gt.links["base"].visuals == [] and asset.links["body"].collisions[1].mesh is torus  # input untouched


# ----- real objects --------------------------------------------------------------------------
def test_real_objects_prepare_and_failures_are_recorded(real_bench):
    _, bench, manifest, results = real_bench
    assert manifest["cases"] == sorted(REAL_IDS)
    assert set(manifest["failed"]) == {"broken", "empty"}
    assert "mobility.urdf" in manifest["failed"]["broken"] and "malformed XML" in manifest["failed"]["broken"]
    assert "\n" not in manifest["failed"]["broken"]
    assert "no mobility.urdf" in manifest["failed"]["empty"]
    assert read_manifest(bench) == manifest
    assert manifest["options"]["resolution"] == 24 and manifest["convention"]
    timed = {r.case_id: r.seconds for r in results if r.reason is None}
    assert set(timed) == set(REAL_IDS) and all(set(s) == {*STAGES, "render.scene"} for s in timed.values())
    assert not list(Benchmark(bench).cases_dir.glob(".*"))  # no partial folders left behind
    sheet = Image.open(Benchmark(bench).contact_sheet_path)
    assert sheet.width > 2 * 192 and sheet.height > 192


@pytest.mark.parametrize("object_id", REAL_IDS)
def test_real_case_files(real_bench, object_id):
    _, bench, _, _ = real_bench
    files = case_of(bench, object_id)
    case = json.loads(files.record_path.read_text())
    source = load_object(REAL_OBJECTS / object_id)
    assert case["id"] == object_id and case["category"] == source.category
    assert case["links"] == list(source.links) and case["image_size"] == 96
    for state in ("input", "open"):
        rgb_path, seg_path = files.state_files(state)
        rgb = np.asarray(Image.open(rgb_path))
        assert rgb.shape == (96, 96, 3) and rgb.dtype == np.uint8
        with Image.open(seg_path) as image:
            assert image.mode.startswith("I")  # 16-bit, not 8-bit
        seg = read_segmentation(seg_path)
        np.testing.assert_array_equal(files.read_segmentation(state), seg)
        assert seg.shape == (96, 96) and seg.dtype == np.uint16
        labels = set(np.unique(seg).tolist())
        assert 0 in labels and labels <= set(range(len(case["links"]) + 1))
        with_geometry = {k + 1 for k, name in enumerate(case["links"]) if source.links[name].has_geometry}
        assert labels - {0} <= with_geometry and len(labels - {0}) >= 1
        assert seg[0, 0] == 0 and 0.05 < (seg > 0).mean() < 0.9
        # the background is the flat neutral colour; the object is shaded
        background = binary_erosion(seg == 0, np.ones((3, 3), bool))
        np.testing.assert_allclose(rgb[background].mean(0), np.array(BACKGROUND) * 255, atol=1.0)
        assert rgb[seg > 0].astype(float).std() > 5

    assert 'filename="/' not in (files.gt_dir / "mobility.urdf").read_text()  # movable folder
    gt = files.load_gt()
    bounds = gt.bounds()
    assert bounds.min() >= -1.0 - 1e-6 and bounds.max() <= 1.0 + 1e-6
    assert (bounds[1] - bounds[0]).max() == pytest.approx(2.0, abs=1e-5)
    np.testing.assert_allclose(bounds.mean(0), 0.0, atol=1e-5)
    for name, link in gt.links.items():
        assert link.has_geometry == source.links[name].has_geometry
        if link.has_geometry:
            assert link.merged_mesh().is_watertight
            assert all(c.is_convex for c in link.collisions)
    # normalization maps the source box onto the gt box (up to the remesh's voxel)
    center, scale = np.asarray(case["normalization"]["center"]), case["normalization"]["scale"]
    np.testing.assert_allclose((source.bounds() - center) * scale, bounds, atol=0.05)
    # joints: case.json matches the gt asset at rest
    frames = gt.joint_frames()
    assert [j["name"] for j in case["joints"]] == [j.name for j in gt.movable_joints()]
    for record in case["joints"]:
        joint = gt.joints[record["name"]]
        assert (record["type"], record["parent"], record["child"]) == (joint.type, joint.parent, joint.child)
        point, axis = frames[joint.name]
        np.testing.assert_allclose(record["axis"], axis, atol=1e-6)
        offset = np.asarray(record["origin"]) - point  # the same line: the offset runs along the axis
        assert np.linalg.norm(offset - (offset @ axis) * axis) < 1e-5
        assert record["lower"] == pytest.approx(joint.lower, abs=1e-6)
        assert record["upper"] == pytest.approx(joint.upper, abs=1e-6)
        assert record["open"] == pytest.approx(joint.open_value, abs=1e-6)
        if joint.type == "continuous":
            assert record["open"] == pytest.approx(np.pi / 2) and record["upper"] == pytest.approx(2 * np.pi)
        assert record["label"]
    # camera.json projects the gt surface onto the rendered silhouette
    view = CameraView.load(files.camera_path)
    assert view.distance == pytest.approx(4.0) and view.position[0] < 0
    seg = files.read_segmentation("input")
    cols, rows = view.pixel_of(gt.mesh().vertices).T
    inside = (cols >= 0) & (cols < 96) & (rows >= 0) & (rows < 96)
    assert inside.all()
    near = binary_dilation(seg > 0, np.ones((5, 5), bool))
    assert near[rows, cols].mean() > 0.999


def test_prismatic_and_revolute_joints_of_40147(real_bench):
    _, bench, _, _ = real_bench
    case = case_of(bench, "40147").record
    types = {j["type"] for j in case["joints"]}
    assert types == {"revolute", "prismatic"}
    drawer = next(j for j in case["joints"] if j["type"] == "prismatic")
    assert drawer["label"] == "drawer" and drawer["upper"] > 0.1  # in the benchmark frame
    # the front faces -X: a drawer opens towards the camera side
    assert drawer["axis"][0] < -0.9


def test_resume_skips_finished_cases(real_bench):
    src, bench, _, _ = real_bench
    stamps = {i: case_of(bench, i).record_path.stat().st_mtime_ns for i in REAL_IDS}
    results = []
    manifest = prepare_benchmark(src, bench, options=FAST, progress=False, on_result=results.append,
                                 contact_sheet=False)
    by_id = {r.case_id: r for r in results}
    assert all(by_id[i].skipped for i in REAL_IDS)
    assert not by_id["broken"].skipped and by_id["broken"].reason  # failures are retried
    assert {i: case_of(bench, i).record_path.stat().st_mtime_ns for i in REAL_IDS} == stamps
    assert manifest["cases"] == sorted(REAL_IDS)


# ----- in-code objects: resume after a kill, option checks, CLI -------------------------------
def test_killed_run_leftovers_are_rebuilt(tmp_path):
    src = tmp_path / "src"
    write_tiny_object(src / "a")
    write_tiny_object(src / "b", shift=0.05)
    bench = tmp_path / "bench"
    prepare_benchmark(src, bench, options=FAST, progress=False, contact_sheet=False)
    # simulate a kill: b lost its final file, a stale partial folder of a is left
    case_a, case_b = case_of(bench, "a"), case_of(bench, "b")
    case_b.record_path.unlink()
    (Benchmark(bench).cases_dir / ".a.partial").mkdir()
    stamp_a = case_a.record_path.stat().st_mtime_ns
    results = []
    manifest = prepare_benchmark(src, bench, options=FAST, progress=False, on_result=results.append)
    assert {r.case_id: r.skipped for r in results} == {"a": True, "b": False}
    assert manifest["cases"] == ["a", "b"] and manifest["failed"] == {}
    assert case_a.record_path.stat().st_mtime_ns == stamp_a
    assert case_b.is_complete
    assert {j["name"] for j in BenchmarkCase(case_b.folder).record["joints"]} == {"joint_drawer", "joint_door"}
    # other options on a resumed folder are refused rather than mixed
    with pytest.raises(SparkBenchError, match="other options"):
        prepare_benchmark(src, bench, options=PrepareOptions(image_size=64, resolution=24), progress=False)
    # --ids with an unknown id is an input error naming the source
    with pytest.raises(SparkBenchError, match="nope"):
        prepare_benchmark(src, bench, ids=["nope"], options=FAST, progress=False)


def test_process_pool_gives_the_same_cases(tmp_path):
    src = tmp_path / "src"
    write_tiny_object(src / "a")
    write_tiny_object(src / "b", shift=0.05)
    write_broken_objects(src)
    serial = prepare_benchmark(src, tmp_path / "serial", options=FAST, progress=False, contact_sheet=False)
    pooled = prepare_benchmark(src, tmp_path / "pooled", options=FAST, workers=2, progress=False,
                               contact_sheet=False)
    assert pooled["cases"] == serial["cases"] == ["a", "b"]
    assert set(pooled["failed"]) == set(serial["failed"]) == {"broken", "empty"}
    for case_id in ("a", "b"):
        for state in ("input", "open"):  # integer labels from the same renderer: equal, pixel for pixel
            np.testing.assert_array_equal(case_of(tmp_path / "serial", case_id).read_segmentation(state),
                                          case_of(tmp_path / "pooled", case_id).read_segmentation(state))


def test_single_object_folder_and_cli(tmp_path, capsys):
    from spark_bench.cli import main

    obj = write_tiny_object(tmp_path / "objects" / "tiny")
    write_broken_objects(tmp_path / "objects")
    bench = tmp_path / "bench"
    common = ["--image-size", "64", "--resolution", "16", "--no-progress"]
    assert main(["data", "prepare", "--src", str(obj), "--out", str(bench), *common]) == 0
    assert read_manifest(bench)["cases"] == ["tiny"]
    assert main(["data", "prepare", "--src", str(tmp_path / "objects"), "--out", str(bench), *common]) == 1
    out = capsys.readouterr().out
    assert "failed broken" in out and read_manifest(bench)["cases"] == ["tiny"]
    assert main(["data", "sheet", str(bench), "--out", str(tmp_path / "sheet.png"), "--thumb", "32"]) == 0
    assert Image.open(tmp_path / "sheet.png").height > 32
    assert main(["data", "prepare", "--src", str(tmp_path / "nothing"), "--out", str(bench), *common]) == 2


# ----- synthetic objects and the named benchmark ----------------------------------------------
def _synth():
    synth = pytest.importorskip("spark_bench.data.synth", reason="spark_bench.data.synth is not available")
    if not hasattr(synth, "generate_object"):
        pytest.skip("spark_bench.data.synth has no generate_object yet")
    return synth


def test_synth_objects_prepare(tmp_path):
    synth = _synth()
    src = tmp_path / "synth"
    categories = list(synth.CATEGORIES)[:2]
    for k, category in enumerate(categories):
        synth.generate_object(category, seed=k, out=src, object_id=f"synth_{k:03d}")
    manifest = prepare_benchmark(src, tmp_path / "bench", options=FAST, progress=False)
    assert manifest["failed"] == {} and len(manifest["cases"]) == 2
    for case_id in manifest["cases"]:
        files = case_of(tmp_path / "bench", case_id)
        assert files.record["category"] in categories and files.record["joints"]
        bounds = files.load_gt().bounds()
        assert (bounds[1] - bounds[0]).max() == pytest.approx(2.0, abs=1e-5)


def test_named_benchmark_builds_once(isolated_home, monkeypatch):
    _synth()
    from spark_bench.data import benchmarks

    spec = benchmarks.BenchmarkSpec("synth-tiny", n_objects=2, seed=0, min_categories=1, options=FAST)
    monkeypatch.setitem(benchmarks.BENCHMARKS, "synth-tiny", spec)
    folder = benchmarks.ensure_benchmark("synth-tiny", progress=False)
    assert folder == isolated_home / "benchmarks" / "synth-tiny"
    assert benchmarks.is_built(folder) and len(read_manifest(folder)["cases"]) == 2
    stamp = (folder / benchmarks.BUILT_MARKER).stat().st_mtime_ns
    assert benchmarks.ensure_benchmark("synth-tiny", progress=False) == folder
    assert (folder / benchmarks.BUILT_MARKER).stat().st_mtime_ns == stamp
    # a build of other settings is stale: rebuilt, not reused
    marker = json.loads((folder / benchmarks.BUILT_MARKER).read_text())
    (folder / benchmarks.BUILT_MARKER).write_text(json.dumps({**marker, "generator_version": "old"}))
    assert not benchmarks.is_built(folder, spec) and benchmarks.is_built(folder)
    benchmarks.ensure_benchmark("synth-tiny", progress=False)
    assert benchmarks.is_built(folder, spec)
    # a damaged marker (truncated, or JSON of another shape) is a stale build too, never a crash
    good = (folder / benchmarks.BUILT_MARKER).read_text()
    for damaged in ("{", "[1, 2]"):
        (folder / benchmarks.BUILT_MARKER).write_text(damaged)
        assert not benchmarks.is_built(folder, spec) and benchmarks.is_stale(spec, folder)
    (folder / benchmarks.BUILT_MARKER).write_text(good)
    with pytest.raises(SparkBenchError, match="unknown benchmark"):
        benchmarks.ensure_benchmark("nope")
    assert benchmarks.BENCHMARKS["synth-v1"].n_objects == 50


def test_eval_builds_its_benchmark_without_rendering_in_its_own_process(isolated_home, monkeypatch):
    # eval forks its workers after building the benchmark; a worker that renders after a fork from a
    # process that rendered hangs in EGL's set-up (`eval --config ours_retrieval.toml` from an empty home
    # did): the build renders in spawned processes only
    _synth()
    from spark_bench.data import benchmarks, prepare
    from spark_bench.evaluation.runner import resolve_bench

    spec = benchmarks.BenchmarkSpec("synth-tiny", n_objects=2, seed=0, min_categories=1, options=FAST)
    monkeypatch.setitem(benchmarks.BENCHMARKS, "synth-tiny", spec)

    def rendered_here(*args, **kwargs):
        raise RuntimeError("a case was prepared (rendered) in the evaluating process")

    monkeypatch.setattr(prepare, "prepare_case", rendered_here)  # spawned workers import the real one
    name, folder = resolve_bench("synth-tiny")
    assert name == "synth-tiny" and benchmarks.is_built(folder, spec)
    assert len(read_manifest(folder)["cases"]) == 2
    # without isolate, one worker prepares in this process: the patched preparation fails every case
    manifest = prepare.prepare_benchmark(folder / "objects", isolated_home / "other", options=FAST, progress=False)
    assert len(manifest["failed"]) == 2 and all("evaluating process" in r for r in manifest["failed"].values())


def test_link_color_of_a_link_without_visuals():
    assert link_color(Link("empty")) == (0.7, 0.7, 0.7, 1.0)


# ----- rendering from the source meshes -------------------------------------------------------
def _tree_bytes(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_render_from_source_meshes_keeps_ground_truth_and_close_masks(tmp_path):
    from spark_bench.cli import main

    src = write_tiny_object(tmp_path / "objects" / "tiny").parent
    common = ["--image-size", "96", "--resolution", "24", "--no-progress"]
    assert main(["data", "prepare", "--src", str(src), "--out", str(tmp_path / "wt"), *common,
                 "--render-mesh", "watertight"]) == 0
    assert main(["data", "prepare", "--src", str(src), "--out", str(tmp_path / "src"), *common]) == 0
    default, source = case_of(tmp_path / "wt", "tiny"), case_of(tmp_path / "src", "tiny")
    assert _tree_bytes(default.gt_dir) == _tree_bytes(source.gt_dir)  # the ground truth is the remesh either way
    # the remesh render is marked by the key's absence (how builds before the source default read)
    assert "render_mesh" not in default.record and source.record["render_mesh"] == "source"
    assert "render_mesh" not in read_manifest(tmp_path / "wt")["options"]
    assert read_manifest(tmp_path / "src")["options"]["render_mesh"] == "source"
    for state in ("input", "open"):
        a, b = read_segmentation(default.state_files(state)[1]), read_segmentation(source.state_files(state)[1])
        assert set(np.unique(a)) == set(np.unique(b))  # every part seen in both
        iou = ((a > 0) & (b > 0)).sum() / ((a > 0) | (b > 0)).sum()
        assert iou > 0.85  # the same object seen by the same camera (boxes: the remesh is close to them)
        for label in np.unique(a[a > 0]):
            part = ((a == label) & (b == label)).sum() / ((a == label) | (b == label)).sum()
            assert part > 0.7, (state, label, part)


def test_source_render_asset_is_the_source_in_the_benchmark_frame():
    from spark_bench.asset.ops import normalize_asset
    from spark_bench.data.prepare import source_render_asset

    source = tiny_cabinet()
    gt, _ = ground_truth_asset(source, resolution=24)
    normalized, center, scale = normalize_asset(gt)
    shown = source_render_asset(source, center, scale)
    assert list(shown.links) == list(normalized.links)
    for name, link in shown.links.items():
        merged = source.links[name].merged_mesh() if source.links[name].has_geometry else None
        if merged is None:
            assert link.visuals == []
            continue
        (visual,) = link.visuals
        assert np.array_equal(visual.mesh.faces, merged.faces)
        pose = source.link_poses()[name]  # link frames keep their orientation: only the offset is scaled
        assert np.allclose(shown.link_poses()[name][:3, :3], pose[:3, :3])
        assert np.allclose(visual.mesh.vertices, merged.vertices * scale, atol=1e-9)
        assert visual.rgba == normalized.links[name].visuals[0].rgba  # the ground truth's colour
    lo, hi = shown.bounds()
    assert np.allclose(lo, normalized.bounds()[0], atol=0.1) and np.allclose(hi, normalized.bounds()[1], atol=0.1)
    assert np.isclose((hi - lo).max(), 2.0, atol=0.1)


def test_render_mesh_option_is_checked():
    with pytest.raises(SparkBenchError, match="render_mesh"):
        PrepareOptions(render_mesh="decimated")
    assert PrepareOptions().render_mesh == "source"  # as SPARK renders (textured_objs), the default
    assert PrepareOptions().to_json()["render_mesh"] == "source"
    assert "render_mesh" not in PrepareOptions(render_mesh="watertight").to_json()
