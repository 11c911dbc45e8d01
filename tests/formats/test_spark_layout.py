"""SPARK's folder layout: run names, the frame map, and telling a failed stage from the files present."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_fake_spark import STAMP, write_fake_run

from spark_bench.asset.transforms import rpy_to_matrix
from spark_bench.formats.spark import layout


def test_run_names_split_at_the_trailing_timestamp():
    assert layout.parse_run_name("cab_0_20250101_120000") == ("cab_0", "20250101_120000")
    assert layout.parse_run_name("45162_20251203_091500") == ("45162", "20251203_091500")
    assert layout.parse_run_name("cab_0") is None
    assert layout.parse_run_name("cab0_2025_1200") is None
    assert layout.run_folder_name("a_b", STAMP) == f"a_b_{STAMP}"


def test_spark_to_partnet_is_the_partnet_mobility_root_joint():
    # the matrix is written with exact zeros and ones; the root joint's rpy is pi/2, 0, -pi/2, so the two
    # agree to the rounding of sin/cos (1e-15), not exactly
    assert np.allclose(layout.SPARK_TO_PARTNET, rpy_to_matrix((np.pi / 2, 0.0, -np.pi / 2)), atol=1e-12)
    right, up, front = layout.SPARK_TO_PARTNET.T  # the images of SPARK's +x, +y, +z
    assert right.tolist() == [0.0, -1.0, 0.0]  # image right -> -Y (the object's right, seen from its front)
    assert up.tolist() == [0.0, 0.0, 1.0]      # up -> +Z
    assert front.tolist() == [-1.0, 0.0, 0.0]  # towards the camera -> the front, -X


def test_mesh_names_and_indices_follow_sparks_code():
    assert layout.part_stem(3) == "part_03"
    assert layout.base_stem("part_03_cleaned_textured_aligned.glb") == "part_03"
    assert layout.base_stem("part_03_cleaned.glb") == "part_03"
    assert layout.base_stem("glb/part_0_geometry_0.glb") == "part_0_geometry_0"
    assert layout.link_index("link7", 2) == 7 and layout.link_index("door", 2) == 2
    assert layout.joint_name("link0", "link2") == "link0_to_link2"


@pytest.mark.parametrize(("stages", "failed"), [
    (layout.RUN_PY_STAGES, None),
    (tuple(s for s in layout.RUN_PY_STAGES if s not in ("retexture", "align_texture")), "retexture"),
    (("structure", "urdf", "part_prompts", "part_images"), "inference"),
    (("structure",), "urdf"),
    ((), "structure"),
])
def test_diagnose_names_the_first_stage_without_its_output(tmp_path, gt, stages, failed):
    run = write_fake_run(tmp_path, "cab0", gt, stages=stages, optimized=False)
    diagnosis = layout.diagnose(run)
    assert diagnosis.failed_stage == failed
    assert "axes" not in diagnosis.missing  # it edits metadata.json in place: nothing to check


def test_diagnose_sees_one_missing_glb_of_a_run_that_exited_0(tmp_path, gt):
    run = write_fake_run(tmp_path, "cab0", gt, delete=("inference/FT5_G1_0/part_02_cleaned.glb",))
    diagnosis = layout.diagnose(run)
    assert diagnosis.failed_stage == "clean"
    assert diagnosis.missing == {"clean": ["inference/FT5_G1_0/part_02_cleaned.glb"]}
    assert "inference" in diagnosis.done and "align_texture" in diagnosis.done
