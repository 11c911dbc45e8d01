"""``run_ours`` end to end on a toy case: prior and refined objects, report, and the ablation's gain; what
the pipeline reads of the case (through :class:`~spark_bench.methods.base.CaseInput` only)."""

import json
import shutil

import numpy as np
import pytest
from helpers_toy import write_toy_case
from PIL import Image

from spark_bench.data.case import BenchmarkCase
from spark_bench.data.images import RENDER_TOLERANCE, mask_from_image
from spark_bench.errors import InputError
from spark_bench.methods.base import CaseInput
from spark_bench.methods.ours import SparkConfig, run_ours
from spark_bench.methods.ours.method import ours_case
from spark_bench.methods.ours.open_state import dataset_open_state


@pytest.mark.slow
def test_run_ours_offline_end_to_end(tmp_path):
    from spark_bench.data import load_object

    case = tmp_path / "case"
    write_toy_case(case)
    # a prior with a wrong door axis and both types flipped (p = 1), pivots 0.1 off; the native search
    # with the ground truth's part masks
    config = SparkConfig().with_overrides(["prior.noise.p_axis=1.0", "prior.noise.p_type=1.0",
                                           "prior.noise.p_sign=0.0", "prior.noise.sigma_origin=0.1",
                                           "optimize.method=native", "optimize.part_masks=true"])
    report = run_ours(ours_case(case, config), tmp_path / "out", config)
    # a non-default noise model: the label says the settings changed
    assert report["label"] == config.label()
    assert report["label"].startswith("prior=annotation,geometry=annotation,open=dataset,opt=native,"
                                      "sup=part-masks,settings=")
    saved = json.loads((tmp_path / "out" / "spark_report.json").read_text())
    assert saved["loss_curve"] == report["loss_curve"] and len(saved["loss_curve"]) > 20
    assert saved["geometry_is_ground_truth"] is True
    assert saved["part_masks"] == ["body", "door", "drawer"]
    before, after = report["diagnostics"]["prior"], report["diagnostics"]["refined"]
    assert before["type_err"] == 1.0 and before["axis_err"] > 0.7
    assert after["type_err"] == 0.0 and after["axis_err"] < 0.035 and after["pivot_err"] < 0.02
    refined = load_object(tmp_path / "out")
    prior = load_object(tmp_path / "out" / "prior")
    assert refined.joints["joint_0"].type == "revolute" and prior.joints["joint_0"].type == "prismatic"
    assert refined.joints["joint_1"].type == "prismatic"
    # the rest geometry is untouched by the refinement
    assert abs(refined.bounds() - prior.bounds()).max() < 1e-6


def _copy(case: BenchmarkCase, folder) -> BenchmarkCase:
    shutil.copytree(case.folder, folder)
    return BenchmarkCase(folder)


@pytest.mark.parametrize(("camera_text", "words"), [
    ("[1, 2]", "expected a JSON object"),
    ('{"width": 256}', "malformed camera"),
    ("{", "malformed JSON"),
])
def test_bad_camera_files_name_the_file(tmp_path, camera_text, words):
    from spark_bench.methods.ours.camera import load_camera

    path = tmp_path / "camera.json"
    path.write_text(camera_text)
    with pytest.raises(InputError, match=words) as err:
        load_camera(path)
    assert str(path) in str(err.value)
    with pytest.raises(InputError, match="camera file not found"):
        load_camera(tmp_path / "missing.json")


def test_camera_of_zero_size_is_rejected(toy_benchmark_case, tmp_path):
    from spark_bench.methods.ours.camera import load_camera

    data = toy_benchmark_case.read_camera()
    assert load_camera(toy_benchmark_case.camera_path).width == data["width"] == 256
    data["width"] = 0
    (tmp_path / "camera.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="image size must be positive, got 0 x 256"):
        load_camera(tmp_path / "camera.json")


def test_dataset_open_state_reads_the_case_links(toy_benchmark_case, tmp_path):
    with_masks = frozenset({"open_image", "open_masks"})
    state = dataset_open_state(CaseInput(toy_benchmark_case, with_masks), part_masks=True)
    assert sorted(state.part_masks) == ["body", "door", "drawer"]
    assert state.mask.sum() == sum(m.sum() for m in state.part_masks.values())
    # the mask and part masks are the label image's, as they were when the pipeline read the folder
    labels = np.asarray(Image.open(toy_benchmark_case.open_seg))
    assert np.array_equal(state.mask, (labels > 0).astype(np.float64))
    assert state.source == str(toy_benchmark_case.open_seg)
    for k, name in enumerate(toy_benchmark_case.links):  # links out of view ("base": no geometry) have none
        expected = labels == k + 1
        assert np.array_equal(state.part_masks[name], expected) if expected.any() else name not in state.part_masks
    case = _copy(toy_benchmark_case, tmp_path / "case")
    case.write_record({**case.record, "links": "body"})
    with pytest.raises(InputError, match='"links" must be the list'):
        dataset_open_state(CaseInput(BenchmarkCase(case.folder), with_masks), part_masks=True)
    case.record_path.write_text("{")
    with pytest.raises(InputError, match=f"{case.record_path.name}: malformed JSON"):
        dataset_open_state(CaseInput(BenchmarkCase(case.folder), with_masks), part_masks=True)


def test_dataset_open_state_without_the_part_masks_input_never_reads_them(toy_benchmark_case, tmp_path):
    """Without the part masks the mask is the open image's object; the label image is not even opened."""
    case = _copy(toy_benchmark_case, tmp_path / "case")
    case.open_seg.write_bytes(b"not an image")
    state = dataset_open_state(CaseInput(case, frozenset({"open_image"})), part_masks=False)
    with Image.open(case.open_image) as image:
        assert np.array_equal(state.mask, mask_from_image(image, RENDER_TOLERANCE))
    assert state.part_masks == {} and state.source == str(case.open_image)
    # the toy's open image is its label image drawn grey on white: the same object pixels
    labels = np.asarray(Image.open(toy_benchmark_case.open_seg))
    assert np.array_equal(state.mask > 0.5, labels > 0)
    with pytest.raises(PermissionError, match="'open_masks'"):  # asked for, undeclared: the gate says no
        dataset_open_state(CaseInput(case, frozenset({"open_image"})), part_masks=True)


def test_the_pipeline_reads_only_what_its_config_declares(toy_benchmark_case, tmp_path):
    """Part masks off (the default): ``ours`` does not declare them, and the pipeline runs without them,
    with either method; handed a case that lacks an input its configuration needs, it stops at the gate."""
    native = SparkConfig().with_overrides(["optimize.method=native", "optimize.refine=none",
                                           "optimize.final_sizes=[32]", "optimize.final_taus=[0.7]",
                                           "optimize.final_steps=[4]", "optimize.short_fine_steps=0"])
    spark = SparkConfig().with_overrides(["optimize.spark.iters=3", "optimize.spark.size=32"])
    case = _copy(toy_benchmark_case, tmp_path / "case")
    case.open_seg.unlink()
    for k, config in enumerate((native, spark)):
        report = run_ours(ours_case(case.folder, config), tmp_path / f"out{k}", config)
        assert report["part_masks"] == [] and report["open_state_source"] == str(case.open_image)
    masks = native.with_overrides(["optimize.part_masks=true"])
    with pytest.raises(PermissionError, match="'open_masks'"):
        run_ours(CaseInput(toy_benchmark_case, frozenset(native.case_inputs())), tmp_path / "out2", masks)
    with pytest.raises(PermissionError, match="'gt'"):
        run_ours(CaseInput(toy_benchmark_case, frozenset({"image", "camera", "open_image"})),
                 tmp_path / "out3", spark)
    with pytest.raises(PermissionError, match="'camera'"):  # the annotation prior's axes are the camera's
        run_ours(CaseInput(toy_benchmark_case, frozenset({"image", "open_image", "gt"})), tmp_path / "out4",
                 spark.with_overrides(["optimize.enabled=false"]))


def test_open_state_of_another_size_than_the_camera_is_an_input_error(toy_benchmark_case, tmp_path):
    case = _copy(toy_benchmark_case, tmp_path / "case")
    Image.open(toy_benchmark_case.open_seg).resize((128, 128), Image.Resampling.NEAREST).save(case.open_seg)
    masks = SparkConfig().with_overrides(["optimize.method=native", "optimize.part_masks=true"])
    with pytest.raises(InputError, match="open-state mask is 128 x 128 px, camera.json says 256 x 256") as err:
        run_ours(ours_case(case.folder, masks), tmp_path / "out", masks)
    assert case.open_seg.name in str(err.value)
    # the whole silhouette's source
    Image.open(toy_benchmark_case.open_image).resize((128, 128)).save(case.open_image)
    with pytest.raises(InputError, match="open-state mask is 128 x 128 px, camera.json says 256 x 256") as err:
        run_ours(ours_case(case.folder, SparkConfig()), tmp_path / "out2", SparkConfig())
    assert case.open_image.name in str(err.value)
    shutil.copy(toy_benchmark_case.open_image, case.open_image)
    # SPARK's closed term reads it
    Image.open(toy_benchmark_case.input_image).resize((128, 128)).save(case.input_image)
    with pytest.raises(InputError, match="input image is 128 x 128 px, the camera says 256 x 256"):
        run_ours(ours_case(case.folder, SparkConfig()), tmp_path / "out3", SparkConfig())


def test_refine_settings_follow_the_optimize_section():
    from spark_bench.methods.ours.config import OptimizeConfig
    from spark_bench.methods.ours.refine import RefineSettings

    opt = OptimizeConfig(refine="vlm", top_k=5, final_sizes=[48], final_taus=[0.5], final_steps=[7], w_part=0.25,
                         screen_values_prismatic=[0.2], short_fine_steps=0)
    settings = RefineSettings.from_config(opt)
    assert not settings.refine_discrete and RefineSettings.from_config().refine_discrete
    assert settings.top_k == 5 and [(s.size, s.tau, s.steps) for s in settings.final] == [(48, 0.5, 7)]
    assert settings.weights.w_part == 0.25 and settings.screen_values["prismatic"] == (0.2,)
    assert [(s.size, s.steps) for s in settings.short_stages()] == [(opt.screen_size, opt.short_steps)]
