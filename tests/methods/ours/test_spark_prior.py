"""Coarse-URDF parsing, the annotation noise model, the file prior and the pipeline config."""

import json
from dataclasses import replace

import numpy as np
import pytest
from helpers_toy import toy_cabinet

from spark_bench.errors import InputError
from spark_bench.methods.ours.config import SparkConfig
from spark_bench.methods.ours.diagnostics import PAPER_PRIOR_ERRORS, calibrate_noise
from spark_bench.methods.ours.prior import (
    NoiseModel,
    annotation_prior,
    assemble_prior,
    camera_axis_frame,
    file_axis_frame,
    file_prior,
    file_prior_with_frame,
    ground_truth_structure,
    prior_document,
)
from spark_bench.methods.ours.structure import parse_structure


def test_ground_truth_structure_of_the_toy():
    structure = ground_truth_structure(toy_cabinet())
    assert [link.name for link in structure.links] == ["body", "door", "drawer"]
    door, drawer = structure.joints
    assert (door.type, door.axis, drawer.type, drawer.axis) == ("revolute", "down", "prismatic", "front")
    np.testing.assert_allclose(door.origin, [-0.6, 0.45, 0.4], atol=1e-9)


def test_noise_model_is_seeded_per_case_and_hits_its_rates():
    gt = toy_cabinet()
    noise = NoiseModel(p_axis=0.2)
    a = annotation_prior(gt, "case_a", noise).to_dict()
    assert a == annotation_prior(gt, "case_a", noise).to_dict()
    assert a != annotation_prior(gt, "case_b", noise).to_dict() or a != annotation_prior(
        gt, "case_c", noise).to_dict()
    truth = ground_truth_structure(gt)
    flips = axes = 0
    offsets = []
    n = 400
    for k in range(n):
        for pj, tj in zip(annotation_prior(gt, f"c{k}", noise).joints, truth.joints):
            flips += pj.type != tj.type
            axes += abs(float(np.dot(pj.axis_vector, tj.axis_vector))) < 0.5
            offsets.append(np.subtract(pj.origin, tj.origin))
    assert flips / (2 * n) == pytest.approx(noise.p_type, abs=0.04)
    assert axes / (2 * n) == pytest.approx(noise.p_axis, abs=0.04)
    assert np.std(np.concatenate(offsets)) == pytest.approx(noise.sigma_origin, abs=0.02)


def test_calibration_moves_towards_the_targets():
    gts = [(f"toy{k}", toy_cabinet()) for k in range(3)]
    target = {"axis_err": 0.6, "pivot_err": 0.1, "type_err": 0.4}
    noise, measured = calibrate_noise(gts, NoiseModel(), target, iterations=3, seeds=range(8))
    assert noise.p_axis > 0.25 and noise.p_type > 0.25 and noise.sigma_origin < 0.15
    assert set(measured) == set(PAPER_PRIOR_ERRORS)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["joints"][0].update(type="screw"), "type 'screw'"),
    (lambda d: d["joints"][0].update(axis=[0.5, 0.5, 0]), "not a canonical direction"),
    (lambda d: d["joints"][0].update(child="ghost"), "not a declared link"),
    (lambda d: d["joints"][0].update(origin=[0, 0]), "origin must be 3"),
    (lambda d: d["joints"][0].update(lower=0.3), "lower limit must be 0"),
    (lambda d: d["joints"][1].update(child="door"), "child of two joints"),
    (lambda d: d.pop("links"), '"links" and "joints"'),
])
def test_parse_structure_rejects_bad_answers(edit, message):
    data = json.loads(json.dumps(ground_truth_structure(toy_cabinet()).to_dict()))
    edit(data)
    with pytest.raises(InputError, match=message):
        parse_structure(data, "answer.json")


def test_vector_axes_and_continuous_are_accepted():
    data = ground_truth_structure(toy_cabinet()).to_dict()
    data["joints"][0].update(axis=[0, -1, 0], type="continuous")
    assert parse_structure(data).joints[0].axis == "down"
    assert parse_structure(data).joints[0].type == "revolute"


def test_file_prior(tmp_path):
    data = ground_truth_structure(toy_cabinet()).to_dict()
    (tmp_path / "c1.json").write_text(json.dumps(data))
    assert file_prior(tmp_path, "c1").joints[1].axis == "front"
    with pytest.raises(InputError, match="no prior answer file"):
        file_prior(tmp_path, "c2")
    (tmp_path / "c3.json").write_text("{oops")
    with pytest.raises(InputError, match="malformed JSON"):
        file_prior(tmp_path, "c3")


def test_config_files_overrides_and_label(tmp_path):
    assert SparkConfig().label() == "prior=annotation,geometry=annotation,open=dataset,opt=spark"
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"prior": {"backend": "file", "file_dir": "x", "noise": {"p_axis": 0.3}},
                                "optimize": {"enabled": False}}))
    config = SparkConfig.from_file(path)
    # a file prior from folder "x": a setting that changes results, so the label names it
    assert config.prior.noise.p_axis == 0.3 and config.label().startswith(
        "prior=file,geometry=annotation,open=dataset,opt=none,settings=")
    assert config.changed_settings() == {"prior.file_dir": "x"}
    config = config.with_overrides(["optimize.enabled=true", "optimize.method=native", "optimize.refine=none",
                                     "vlm.model=my-model"])
    label = config.label()
    assert label.startswith("prior=file,geometry=annotation,open=dataset,opt=fit-only,settings=")
    # the VLM is not used by this config: its model leaves the label alone; an optimization knob does not
    assert config.with_overrides(["vlm.model=other"]).label() == label
    assert config.with_overrides(["optimize.top_k=5"]).label() != label
    assert SparkConfig().with_overrides(["prior.backend=vlm", "vlm.model=my-model"]).label() == \
        "prior=vlm:my-model,geometry=annotation,open=dataset,opt=spark"
    assert config.vlm.model == "my-model"
    assert SparkConfig.from_dict(config.to_dict()) == config
    with pytest.raises(InputError, match="unknown setting"):
        SparkConfig.from_dict({"prior": {"backnd": "vlm"}}, "c.toml")
    with pytest.raises(InputError, match="is not one of"):
        SparkConfig.from_dict({"geometry": {"backend": "dreams"}})
    with pytest.raises(InputError, match="needs prior.file_dir"):
        replace(SparkConfig(), prior=replace(SparkConfig().prior, backend="file")).validate()


@pytest.mark.parametrize(("override", "words"), [
    ("optimize.top_k=true", "optimize.top_k must be a number, got True"),
    ("optimize.screen_local=[0.05, \"x\"]", "optimize.screen_local[1] must be a number, got 'x'"),
    ("optimize.final_sizes=[64, false]", "optimize.final_sizes[1] must be a number"),
    ("optimize.final_steps=7", "optimize.final_steps must be a list"),
])
def test_config_rejects_values_of_the_wrong_kind(override, words):
    with pytest.raises(InputError, match=words.replace("[", r"\[").replace("]", r"\]")):
        SparkConfig().with_overrides([override])
    # numbers of the other kind are converted, in lists as in single settings
    config = SparkConfig().with_overrides(["optimize.top_k=4.0", "optimize.screen_values_prismatic=[1, 2]"])
    assert config.optimize.top_k == 4 and config.optimize.screen_values_prismatic == [1.0, 2.0]


def test_optimize_methods_labels_and_inputs():
    spark = SparkConfig()
    native = spark.with_overrides(["optimize.method=native"])
    masks = native.with_overrides(["optimize.part_masks=true"])
    assert native.label() == "prior=annotation,geometry=annotation,open=dataset,opt=native"
    assert masks.label() == "prior=annotation,geometry=annotation,open=dataset,opt=native,sup=part-masks"
    assert native.with_overrides(["optimize.refine=vlm"]).label().endswith("opt=native+vlm")
    # only the whole silhouette by default; the part masks are an input only when asked for
    assert spark.case_inputs() == native.case_inputs() == ("image", "camera", "open_image", "gt")
    assert masks.case_inputs() == ("image", "camera", "open_image", "open_masks", "gt")
    # SPARK's recipe ignores the native refinement; its own knobs change the label, the native ones do not
    assert spark.with_overrides(["optimize.refine=none"]).label() == spark.label()
    assert spark.with_overrides(["optimize.top_k=5"]).label() == spark.label()
    changed = spark.with_overrides(["optimize.spark.iters=50"])
    assert changed.label().startswith(spark.label() + ",settings=")
    assert changed.changed_settings() == {"optimize.spark.iters": 50}
    assert native.with_overrides(["optimize.spark.iters=50"]).label() == native.label()
    with pytest.raises(InputError, match="part_masks applies to method 'native'"):
        spark.with_overrides(["optimize.part_masks=true"])
    with pytest.raises(InputError, match="is not one of"):
        spark.with_overrides(["optimize.method=magic"])
    with pytest.raises(InputError, match="angle_bounds"):
        spark.with_overrides(["optimize.spark.angle_bounds=[90, 35]"])
    # no optimization: the annotation prior still reads the camera (its axes are the camera's)
    assert spark.with_overrides(["optimize.enabled=false"]).case_inputs() == ("image", "camera", "gt")


def test_annotation_prior_axes_are_the_camera_frames_canonical_axes(tmp_path):
    """The simulated VLM names the image's axes (+x right, +y up, +z towards the camera): each axis is the
    camera axis nearest to the true one, mapped back to the object; a frontal camera changes nothing."""
    from spark_bench.asset.transforms import axis_angle_matrix
    from spark_bench.methods.ours.geometry import annotation_geometry
    from spark_bench.methods.ours.structure import OBJECT_TO_WORLD

    gt = toy_cabinet()
    geometry = annotation_geometry(gt)
    truth = {j.name: j for j in ground_truth_structure(gt).joints}
    # a level camera in front of the object (world -X) looking at it: OpenCV x, y, z in world
    frontal = np.column_stack([[0, -1, 0], [0, 0, -1], [1, 0, 0]]).astype(float)
    frame = camera_axis_frame(frontal)
    np.testing.assert_allclose(frame, np.eye(3), atol=1e-6)
    assert [j.axis for j in ground_truth_structure(gt, axis_frame=frame).joints] == [truth["joint_0"].axis,
                                                                                     truth["joint_1"].axis]
    # the same camera 30 degrees higher, looking down: the door's vertical hinge becomes the image's "down"
    # (30 degrees off), the drawer's front the image's "front" (towards the camera, 30 degrees off)
    tilt = axis_angle_matrix(np.array([0.0, 1.0, 0.0]), np.radians(30.0))  # about world y: a pitch
    frame = camera_axis_frame(tilt @ frontal)
    structure = ground_truth_structure(gt, axis_frame=frame)
    door, drawer = structure.joints
    assert (door.axis, drawer.axis) == ("down", "front")
    asset = assemble_prior(structure, geometry, frame)
    for name in ("joint_0", "joint_1"):
        got = OBJECT_TO_WORLD @ asset.joints[name].axis
        true = OBJECT_TO_WORLD @ truth[name].axis_vector
        assert np.degrees(np.arccos(min(1.0, abs(float(got @ true))))) == pytest.approx(30.0, abs=1e-4)
    # the prior file keeps the frame, and the file backend reads it back
    document = prior_document(structure, frame)
    (tmp_path / "c.json").write_text(json.dumps(document))
    np.testing.assert_allclose(file_axis_frame(tmp_path, "c"), frame, atol=1e-9)
    assert file_prior(tmp_path, "c").joints[0].axis == "down"
    read, read_frame = file_prior_with_frame(tmp_path, "c")  # the pipeline's one read of both
    assert read.joints[0].axis == "down" and read.source == "file"
    np.testing.assert_allclose(read_frame, frame, atol=1e-9)
    document["axis_frame"] = [[1, 0, 0], [0, 1, 0]]
    (tmp_path / "c.json").write_text(json.dumps(document))
    with pytest.raises(InputError, match="axis_frame must be a 3x3 rotation"):
        file_axis_frame(tmp_path, "c")
