"""``run_ours`` end to end on a toy case: prior and refined objects, report, and the ablation's gain."""

import json

import pytest

from spark_bench.spark import SparkConfig, run_ours
from spark_bench.spark.toy import write_toy_case


@pytest.mark.slow
def test_run_ours_offline_end_to_end(tmp_path):
    from spark_bench.data import load_object

    case = tmp_path / "case"
    write_toy_case(case)
    # a prior with a wrong door axis and both types flipped (p = 1), pivots 0.1 off
    config = SparkConfig().with_overrides(["prior.noise.p_axis=1.0", "prior.noise.p_type=1.0",
                                           "prior.noise.p_sign=0.0", "prior.noise.sigma_origin=0.1"])
    report = run_ours(case, tmp_path / "out", config)
    # a non-default noise model: the label says the settings changed
    assert report["label"] == config.label()
    assert report["label"].startswith("prior=annotation,geometry=annotation,open=dataset,opt=native,settings=")
    saved = json.loads((tmp_path / "out" / "spark_report.json").read_text())
    assert saved["loss_curve"] == report["loss_curve"] and len(saved["loss_curve"]) > 20
    assert saved["geometry_is_ground_truth"] is True
    before, after = report["diagnostics"]["prior"], report["diagnostics"]["refined"]
    assert before["type_err"] == 1.0 and before["axis_err"] > 0.7
    assert after["type_err"] == 0.0 and after["axis_err"] < 0.035 and after["pivot_err"] < 0.02
    refined = load_object(tmp_path / "out")
    prior = load_object(tmp_path / "out" / "prior")
    assert refined.joints["joint_0"].type == "revolute" and prior.joints["joint_0"].type == "prismatic"
    assert refined.joints["joint_1"].type == "prismatic"
    # the rest geometry is untouched by the refinement
    assert abs(refined.bounds() - prior.bounds()).max() < 1e-6


@pytest.fixture(scope="module")
def toy_case(tmp_path_factory):
    case = tmp_path_factory.mktemp("toy") / "case"
    write_toy_case(case)
    return case


@pytest.mark.parametrize(("camera_text", "words"), [
    ("[1, 2]", "expected a JSON object"),
    ('{"width": 256}', "malformed camera"),
    ("{", "malformed JSON"),
])
def test_bad_camera_files_name_the_file(tmp_path, camera_text, words):
    from spark_bench.errors import InputError
    from spark_bench.spark.camera import load_camera

    path = tmp_path / "camera.json"
    path.write_text(camera_text)
    with pytest.raises(InputError, match=words) as err:
        load_camera(path)
    assert str(path) in str(err.value)
    with pytest.raises(InputError, match="camera file not found"):
        load_camera(tmp_path / "missing.json")


def test_camera_of_zero_size_is_rejected(toy_case, tmp_path):
    from spark_bench.errors import InputError
    from spark_bench.spark.camera import load_camera

    data = json.loads((toy_case / "camera.json").read_text())
    assert load_camera(toy_case / "camera.json").width == data["width"] == 256
    data["width"] = 0
    (tmp_path / "camera.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="image size must be positive, got 0 x 256"):
        load_camera(tmp_path / "camera.json")


def test_dataset_open_state_reads_the_case_links(toy_case, tmp_path):
    import shutil

    from spark_bench.errors import InputError
    from spark_bench.spark.open_state import dataset_open_state

    state = dataset_open_state(toy_case)
    assert sorted(state.part_masks) == ["body", "door", "drawer"]
    assert state.mask.sum() == sum(m.sum() for m in state.part_masks.values())
    case = tmp_path / "case"
    shutil.copytree(toy_case, case)
    data = json.loads((case / "case.json").read_text())
    (case / "case.json").write_text(json.dumps({**data, "links": "body"}))
    with pytest.raises(InputError, match='"links" must be the list'):
        dataset_open_state(case)
    (case / "case.json").write_text("{")
    with pytest.raises(InputError, match="case.json: malformed JSON"):
        dataset_open_state(case)


def test_open_state_of_another_size_than_the_camera_is_an_input_error(toy_case, tmp_path):
    import shutil

    from PIL import Image

    from spark_bench.errors import InputError

    case = tmp_path / "case"
    shutil.copytree(toy_case, case)
    Image.open(toy_case / "open_seg.png").resize((128, 128), Image.Resampling.NEAREST).save(case / "open_seg.png")
    with pytest.raises(InputError, match="open-state mask is 128 x 128 px, camera.json says 256 x 256") as err:
        run_ours(case, tmp_path / "out", SparkConfig())
    assert "open_seg.png" in str(err.value)


def test_refine_settings_follow_the_optimize_section():
    from spark_bench.spark.config import OptimizeConfig
    from spark_bench.spark.refine import RefineSettings

    opt = OptimizeConfig(refine="vlm", top_k=5, final_sizes=[48], final_taus=[0.5], final_steps=[7], w_part=0.25,
                         screen_values_prismatic=[0.2], short_fine_steps=0)
    settings = RefineSettings.from_config(opt)
    assert not settings.refine_discrete and RefineSettings.from_config().refine_discrete
    assert settings.top_k == 5 and [(s.size, s.tau, s.steps) for s in settings.final] == [(48, 0.5, 7)]
    assert settings.weights.w_part == 0.25 and settings.screen_values["prismatic"] == (0.2,)
    assert [(s.size, s.steps) for s in settings.short_stages()] == [(opt.screen_size, opt.short_steps)]
