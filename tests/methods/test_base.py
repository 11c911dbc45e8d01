"""What a method may see of a case (:class:`CaseInput`), and what it gives back (:class:`Generation`)."""

from __future__ import annotations

import json

import pytest
from helpers_bench import case_input, make_tiny_bench

from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError
from spark_bench.methods.base import Generation, GenerationError, regime_of


def test_case_input_refuses_undeclared_inputs(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case = case_input(bench, {"image", "part_meshes"})
    assert case.image == Benchmark(bench).case("cab0").input_image and case.case_id == "cab0"
    for name in ("open_image", "gt_dir", "masks", "camera", "folder", "link_names"):
        with pytest.raises(PermissionError, match="did not declare"):
            getattr(case, name)
    for call in (case.open_part_masks, case.open_labels, case.load_gt):
        with pytest.raises(PermissionError, match="did not declare"):
            call()
    parts = case.part_meshes()
    assert set(parts.movable.values()) == {True} and parts.root == "base"
    assert set(parts.meshes) == {"base", "link_0", "link_1"}
    assert not hasattr(parts, "joints")  # no joint parameters reach the method


def test_open_part_masks_are_an_input_of_their_own(tmp_path):
    """The open image does not bring the open state's part masks with it, nor does the ground truth."""
    bench = make_tiny_bench(tmp_path, n=1)
    for allowed in ({"image", "camera", "open_image"}, {"image", "camera", "open_image", "gt"}):
        case = case_input(bench, allowed)
        with pytest.raises(PermissionError, match="'open_masks'"):
            case.open_part_masks()
        with pytest.raises(PermissionError, match="'open_masks'"):
            case.path("open_masks")
    assert case_input(bench, {"open_masks"}).path("open_masks") == Benchmark(bench).case("cab0").open_seg
    assert "gt open part masks" in regime_of({"image", "open_masks"})


def test_case_camera_is_read_and_a_bad_one_names_its_file(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case = case_input(bench, {"camera"})
    camera_path = Benchmark(bench).case("cab0").camera_path
    assert case.camera["width"] == 64 and len(case.camera["world_to_camera"]) == 4
    assert case.path("camera") == camera_path
    for text, problem in (('{"width": 64,', "malformed JSON"), ("[1, 2]", "expected a JSON object"), (None, "not found")):
        if text is None:
            camera_path.unlink()
        else:
            camera_path.write_text(text)
        with pytest.raises(InputError, match=rf"{camera_path.name}: .*{problem}"):
            _ = case.camera


def test_generation_json_round_trip(tmp_path):
    g = Generation(tmp_path / "x", {"prior": "annotation"}, {"v": tmp_path / "v"}, shape_metrics_valid=False)
    back = Generation.from_json(json.loads(json.dumps(g.to_json())))
    assert back == g
    for bad in ({}, [], {"folder": "x", "variants": 3}):
        with pytest.raises(ValueError, match="not a generation record"):
            Generation.from_json(bad)


def test_generation_from_result(tmp_path):
    assert Generation.from_result(None, tmp_path).folder == tmp_path
    g = Generation.from_result({"folder": str(tmp_path / "x"), "variants": {"v": str(tmp_path / "v")},
                                "shape_metrics_valid": False, "prior": "annotation"}, tmp_path)
    assert g.folder == tmp_path / "x" and g.variants == {"v": tmp_path / "v"}
    assert g.shape_metrics_valid is False and g.info == {"prior": "annotation"}
    with pytest.raises(GenerationError, match="expected a dict"):
        Generation.from_result(42, tmp_path)
