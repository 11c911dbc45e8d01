"""The stage backends of ``ours``: a new backend is one class, and the configuration, the method's inputs and
regime, and the pipeline all follow what it declares; the report's timings come from the one stage timer."""

from __future__ import annotations

import json

import pytest

from spark_bench.data.case import BenchmarkCase
from spark_bench.errors import InputError
from spark_bench.methods.base import CaseInput
from spark_bench.methods.ours import SparkConfig, run_ours
from spark_bench.methods.ours.method import OursMethod, ours_case
from spark_bench.methods.ours.prior import ground_truth_structure
from spark_bench.methods.ours.stages import (
    GEOMETRY_BACKENDS,
    OPEN_STATE_BACKENDS,
    OPTIMIZERS,
    PRIOR_BACKENDS,
    REFINEMENTS,
)
from spark_bench.methods.ours.stages.prior import PriorAnswer, PriorBackend


class ExactPrior(PriorBackend):
    """A throw-away prior: the ground truth's coarse URDF without noise, axes in the object frame (so,
    unlike ``annotation``, it reads no camera); it requires a file folder to be left empty."""

    name = "test-exact"
    reads = frozenset({"gt"})
    simulated_as = "gt structure (exact)"
    uses_gt_object = True

    def settings(self, config):
        return [("prior.noise", ())]

    def validate(self, config, source):
        if config.prior.file_dir:
            raise InputError(source, "prior.backend = 'test-exact' reads no file: leave prior.file_dir empty")

    def run(self, run, geometry):
        return PriorAnswer(ground_truth_structure(run.gt), None, None)


@pytest.fixture
def exact_prior():
    PRIOR_BACKENDS.register(ExactPrior)
    yield ExactPrior
    PRIOR_BACKENDS.unregister(ExactPrior.name)


def test_a_new_prior_backend_is_one_registered_class(exact_prior, toy_case, tmp_path):
    base = SparkConfig().with_overrides(["prior.backend=test-exact", "optimize.enabled=false"])
    # the label, the inputs and the regime are what the class declares: no camera without optimization
    assert base.label() == "prior=test-exact,geometry=annotation,open=dataset,opt=none"
    assert base.case_inputs() == ("image", "gt")
    assert OursMethod(base).regime == "image + gt structure (exact) + gt geometry"
    # its settings section changes the label; its requirement is checked
    noisy = base.with_overrides(["prior.noise.p_axis=0.5"])
    assert noisy.changed_settings() == {"prior.noise.p_axis": 0.5}
    assert noisy.label().startswith(base.label() + ",settings=")
    with pytest.raises(InputError, match="test-exact' reads no file"):
        base.with_overrides(["prior.file_dir=answers"])
    names = r"\['annotation', 'vlm', 'file', 'retrieval', 'test-exact'\]"
    with pytest.raises(InputError, match=f"is not one of {names}"):
        base.with_overrides(["prior.backend=exact"])

    # the pipeline runs it: without optimization on a case it may not see the camera of
    case = CaseInput(BenchmarkCase(toy_case), frozenset(base.case_inputs()))
    report = run_ours(case, tmp_path / "plain", base)
    assert report["backends"]["prior"] == "test-exact" and report["label"] == base.label()
    prior_errors = report["diagnostics"]["prior"]
    assert prior_errors["type_err"] == 0.0 and prior_errors["axis_err"] < 1e-6
    written = json.loads((tmp_path / "plain" / "prior.json").read_text())
    assert [j["type"] for j in written["joints"]] == ["revolute", "prismatic"] and "axis_frame" not in written
    with pytest.raises(PermissionError, match="'gt'"):
        run_ours(CaseInput(BenchmarkCase(toy_case), frozenset({"image"})), tmp_path / "denied", base)

    # and with SPARK's recipe after it (a few iterations)
    fitted = base.with_overrides(["optimize.enabled=true", "optimize.spark.iters=3",
                                  "optimize.spark.size=32"])
    assert fitted.case_inputs() == ("image", "camera", "open_image", "gt")
    report = run_ours(ours_case(toy_case, fitted), tmp_path / "fitted", fitted)
    assert report["backends"]["optimize"] == "spark" and len(report["loss_curve"]) == 3
    assert all((tmp_path / "fitted" / f).is_file() for f in ("mobility.urdf", "prior/mobility.urdf"))
    assert report["diagnostics"]["prior"] == prior_errors


def test_a_backend_name_is_registered_once(exact_prior):
    with pytest.raises(ValueError, match="registered already"):
        PRIOR_BACKENDS.register(ExactPrior)


def test_every_backend_declares_inputs_of_the_known_kinds():
    from spark_bench.methods.base import INPUT_KINDS

    registries = (PRIOR_BACKENDS, GEOMETRY_BACKENDS, OPEN_STATE_BACKENDS, OPTIMIZERS, REFINEMENTS)
    assert [r.names() for r in registries] == [
        ["annotation", "vlm", "file", "retrieval"], ["annotation", "predictions", "spark", "retrieval"],
        ["dataset", "http"], ["spark", "native"], ["render", "vlm", "none"]]
    config = SparkConfig()
    for registry in registries:
        for name in registry.names():
            backend = registry[name]
            assert backend.case_inputs(config) <= set(INPUT_KINDS) - {"image"}, (registry.key, name)
            # a backend that reads the ground truth says how the regime names the stage it simulates
            assert ("gt" in backend.case_inputs(config)) == (backend.simulated_stage(config) is not None)
            assert not backend.uses_gt_object or "gt" in backend.reads


def test_the_report_timings_are_the_stage_timers(toy_case, tmp_path):
    config = SparkConfig().with_overrides(["optimize.spark.iters=2", "optimize.spark.size=32"])
    timings = run_ours(ours_case(toy_case, config), tmp_path / "out", config)["timings"]
    stages = ("load", "prior", "open_state", "spark_masks", "joint_optimization", "optimize", "export")
    assert set(stages) <= set(timings) and {f"{s}_cpu" for s in stages} <= set(timings)
    # SPARK's recipe's own phases, and no stage that did not run
    assert {"opt_closed_term", "opt_fit", "opt_fit_cpu"} <= set(timings)
    assert not {"retrieval", "geometry", "vlm_refine"} & set(timings)
    assert all(v >= 0 for v in timings.values())
    # the optimization's wall time holds its steps' (rounded to 4 places)
    steps = timings["open_state"] + timings["spark_masks"] + timings["joint_optimization"]
    assert timings["optimize"] >= steps - 3e-4


def test_the_vlm_refinement_starts_the_fit_from_the_vlms_second_answer(toy_case, tmp_path):
    """``optimize.refine = "vlm"``: the VLM, shown the prior, answers again; the fit starts from its answer."""
    from test_spark_vlm import GOOD, FakeVLM

    from spark_bench.data import load_object

    flipped = ["prior.noise.p_type=1.0", "prior.noise.p_axis=0", "prior.noise.p_sign=0", "prior.noise.p_range=0"]
    tiny = ["optimize.final_sizes=[32]", "optimize.final_taus=[0.7]", "optimize.final_steps=[3]",
            "optimize.screen_size=16", "optimize.short_steps=2", "optimize.max_faces=200"]
    with FakeVLM([(200, json.dumps(GOOD))]) as vlm:
        config = SparkConfig().with_overrides([*flipped, *tiny, "optimize.method=native", "optimize.refine=vlm",
                                               f"vlm.base_url={json.dumps(vlm.base_url)}", "vlm.backoff_s=0"])
        report = run_ours(ours_case(toy_case, config), tmp_path / "out", config)
    assert len(vlm.requests) == 1
    assert "first estimate" in vlm.requests[0]["body"]["messages"][1]["content"][0]["text"]
    assert report["backends"]["optimize"] == "native+vlm" and ",opt=native+vlm,settings=" in report["label"]
    # the prior says prismatic door, revolute drawer; the VLM's second answer, which the fit keeps, the truth
    prior = load_object(tmp_path / "out" / "prior")
    assert [prior.joints[n].type for n in ("joint_0", "joint_1")] == ["prismatic", "revolute"]
    assert [report["hypotheses"][n]["type"] for n in ("joint_0", "joint_1")] == ["revolute", "prismatic"]
    assert {"vlm_refine", "joint_optimization", "opt_final_fit"} <= set(report["timings"])


def test_the_spark_geometry_declares_the_camera_it_needs_without_optimization():
    """The ``spark`` geometry backend brings SPARK's view-turned parts into the prior's frame with the case
    camera, optimized or not: the camera is an input of such a configuration either way."""
    from spark_bench.methods.ours.config import SparkConfig

    for enabled in (True, False):
        config = SparkConfig.from_dict({"prior": {"backend": "vlm"}, "optimize": {"enabled": enabled},
                                        "geometry": {"backend": "spark", "spark_command": "run {image} {out}"}})
        assert "camera" in config.case_inputs() and "gt" not in config.case_inputs()
