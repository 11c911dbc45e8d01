"""One SPARK run folder -> one object folder in the benchmark frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from helpers_fake_spark import rotation_z, write_fake_run, write_glb

from spark_bench.data.readers import load_object
from spark_bench.errors import InputError
from spark_bench.formats.foreign import read_import_record, row_fields, write_import
from spark_bench.formats.spark import layout
from spark_bench.formats.spark.reader import choose_urdf, read_spark_run

TAG_DIR = "inference/FT5_G1_0"
# GLB stores vertices as float32: coordinates of about 1 round-trip to within ~1e-7; normalizing
# again (box of those vertices) keeps that order, so 1e-5 leaves a wide margin and still catches any
# real frame or scale error (those are of order 0.1 to 1).
GLB_TOL = 1e-5


def _meshes(result) -> dict[str, dict]:
    return {m["link"]: m for m in result.record["meshes"]}


def test_meshes_are_found_in_inference_when_the_urdf_paths_do_not_resolve(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt)
    assert not (run / "part_00.glb").exists()  # generate_urdf.py points there; SPARK never writes it
    result = read_spark_run(run)
    meshes = _meshes(result)
    assert sorted(meshes) == ["link0", "link1", "link2"]
    for index, link in enumerate(["link0", "link1", "link2"]):
        assert meshes[link]["urdf_filename"] == f"part_{index:02d}.glb"
        assert meshes[link]["file"] == f"{TAG_DIR}/part_{index:02d}_cleaned_textured_aligned.glb"
        assert meshes[link]["variant"] == "textured_aligned"


def test_cleaned_then_raw_when_the_preferred_meshes_are_missing(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt, delete=(
        f"{TAG_DIR}/part_01_cleaned_textured_aligned.glb",
        f"{TAG_DIR}/part_02_cleaned_textured_aligned.glb", f"{TAG_DIR}/part_02_cleaned.glb"))
    meshes = _meshes(read_spark_run(run))
    assert meshes["link0"]["variant"] == "textured_aligned"
    assert (meshes["link1"]["variant"], meshes["link1"]["file"]) == ("cleaned", f"{TAG_DIR}/part_01_cleaned.glb")
    assert (meshes["link2"]["variant"], meshes["link2"]["file"]) == ("raw", f"{TAG_DIR}/part_02.glb")


def test_a_mesh_beside_the_urdf_comes_first(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt)
    write_glb(run / "part_00.glb", trimesh.creation.box(extents=(2.0, 2.0, 2.0)))
    meshes = _meshes(read_spark_run(run))
    assert (meshes["link0"]["file"], meshes["link0"]["variant"]) == ("part_00.glb", "raw")
    assert meshes["link1"]["file"].startswith(TAG_DIR)


def test_meshes_without_a_surface_are_passed_over(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt)
    # PartCrafter's stand-in for a part it could not make: one vertex, one degenerate face
    write_glb(run / TAG_DIR / "part_01_cleaned_textured_aligned.glb",
              trimesh.Trimesh([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], [[0, 1, 2]], process=False))
    (run / TAG_DIR / "part_01_cleaned.glb").write_bytes(b"")
    meshes = _meshes(read_spark_run(run))
    assert meshes["link1"]["variant"] == "raw"
    passed = meshes["link1"]["passed_over"]
    assert len(passed) == 2
    assert "zero area" in passed[0] and "empty (0 bytes)" in passed[1]


def test_an_error_lists_every_path_looked_for(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt, delete=tuple(
        f"{TAG_DIR}/part_02{suffix}.glb" for suffix in ("", "_cleaned", "_cleaned_textured_aligned")))
    with pytest.raises(InputError) as err:
        read_spark_run(run)
    message = str(err.value)
    assert "mobility_optimized.urdf" in message and "'part_02.glb'" in message
    for name in ("part_02_cleaned_textured_aligned.glb", "part_02_cleaned.glb", "part_02.glb"):
        assert str(run / name) in message
        assert str(run / TAG_DIR / name) in message


def test_the_optimized_urdf_is_preferred_and_recorded(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt)
    assert choose_urdf(run) == (run / "mobility_optimized.urdf", "optimized")
    result = read_spark_run(run)
    assert (result.record["urdf"], result.record["urdf_kind"]) == ("mobility_optimized.urdf", "optimized")
    (run / "mobility_optimized.urdf").unlink()
    assert choose_urdf(run) == (run / "mobility.urdf", "vlm")
    (run / "mobility.urdf").unlink()
    with pytest.raises(InputError, match=r"looked for \*_optimized.urdf, mobility_refined.urdf and mobility.urdf"):
        choose_urdf(run)


def test_image_frame_axes_and_y_up_meshes_come_out_in_our_frame(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt, yaw_deg=0.0)
    urdf_text = (run / "mobility.urdf").read_text()
    assert '<axis xyz="0 0 1"/>' in urdf_text  # the drawer slides towards the camera (image +z)
    assert '<axis xyz="0 1 0"/>' in urdf_text  # the door turns about image up
    result = read_spark_run(run)
    asset = result.asset
    frames = asset.joint_frames()
    by_type = {asset.joints[name].type: direction for name, (_, direction) in frames.items()}
    # exact zeros and ones times a positive scale, then normalized: equal to rounding
    assert np.allclose(by_type["prismatic"], [-1.0, 0.0, 0.0], atol=1e-12)  # the front is -X
    assert np.allclose(by_type["revolute"], [0.0, 0.0, 1.0], atol=1e-12)    # up is +Z
    assert result.record["frame"]["root_joint"] == "identity"
    assert np.allclose(asset.bounds(), gt.bounds(), atol=GLB_TOL)  # same object, same box: Z up, front -X
    assert asset.links["link1"].label == "rotation_door" and asset.category == "StorageFurniture"


def test_camera_alignment_turns_sparks_front_towards_the_case_camera(tmp_path, case0, gt):
    camera = case0.read_camera()
    azimuth = math.degrees(math.atan2(camera["position"][1], camera["position"][0]))
    yaw = azimuth - 180.0  # SPARK's +z pointed at the camera that took the image
    run = write_fake_run(tmp_path, "cab0", gt, yaw_deg=yaw)
    result = read_spark_run(run, alignment="camera", camera=camera, camera_source=case0.camera_path)
    assert math.isclose(result.record["frame"]["yaw_deg"], yaw, abs_tol=1e-9)
    assert result.record["alignment"] == "camera"
    assert np.allclose(result.asset.bounds(), gt.bounds(), atol=GLB_TOL)
    rotation = np.asarray(result.record["frame"]["rotation"])
    assert np.allclose(rotation, rotation_z(yaw) @ layout.SPARK_TO_PARTNET, atol=1e-12)
    with pytest.raises(InputError, match="needs the case camera"):
        read_spark_run(run, alignment="camera")


@pytest.mark.parametrize("yaw", [-35.0, 20.0, 90.0, 137.0])
def test_icp_alignment_squares_the_footprint_up_to_a_quarter_turn(tmp_path, gt, yaw):
    """An object turned by an odd angle has a larger box, so the benchmark frame would shrink it: the
    reader turns it back to axis-aligned, and the quarter turns left are on `eval --align icp`'s grid."""
    run = write_fake_run(tmp_path, "cab0", gt, yaw_deg=yaw)
    result = read_spark_run(run)
    frame = result.record["frame"]
    assert frame["yaw_from"] == "footprint" and -45.0 < frame["yaw_deg"] <= 45.0
    left = yaw - frame["yaw_deg"]  # importing turns by -yaw; the reader turned back by yaw_deg
    assert abs((left + 45.0) % 90.0 - 45.0) < 1e-4  # what is left is a multiple of 90 degrees
    quarter = round(left / 90.0) % 4
    extents, truth = np.ptp(result.asset.bounds(), axis=0), np.ptp(gt.bounds(), axis=0)
    expected = truth[[1, 0, 2]] if quarter % 2 else truth  # a quarter turn swaps the box's sides
    assert np.allclose(extents, expected, atol=1e-4)  # the same box: the same benchmark scale


def test_written_object_folder_and_its_import_record(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt)
    result = read_spark_run(run, name="cab0")
    folder = write_import(result.asset, result.record, tmp_path / "pred" / "cab0")
    assert not (tmp_path / "pred" / ".cab0.partial").exists()
    loaded = load_object(folder)
    assert set(loaded.joints) == {"base_to_link0", "link0_to_link1", "link0_to_link2"}  # SPARK's own joints
    assert np.allclose(loaded.bounds(), result.asset.bounds(), atol=1e-6)  # OBJ text keeps 9 digits
    assert loaded.category == "StorageFurniture"
    record = read_import_record(folder)
    assert record["run"] == str(run.resolve()) and record["run_timestamp"] == "20250101_120000"
    assert record["alignment"] == "icp" and record["frame"]["root_joint"] == "identity"
    assert record["stages"]["failed_stage"] is None
    assert row_fields(record) == {"spark_urdf": "mobility_optimized.urdf", "spark_urdf_kind": "optimized",
                                  "spark_alignment": "icp", "spark_run": str(run.resolve())}
    assert read_import_record(tmp_path) is None and row_fields(None) == {}
    world_to_bench = np.asarray(record["frame"]["urdf_world_to_benchmark"])
    pivot_urdf = np.array([float(v) for v in _joint_origin(run / "mobility_optimized.urdf", "link0_to_link1")])
    pivot_ours = loaded.joint_frames()["link0_to_link1"][0]
    assert np.allclose(world_to_bench[:3, :3] @ pivot_urdf + world_to_bench[:3, 3], pivot_ours, atol=1e-6)


def _joint_origin(urdf, name):
    import xml.etree.ElementTree as ET

    joint = ET.parse(urdf).getroot().find(f"./joint[@name='{name}']")
    return joint.find("origin").get("xyz").split()
