"""``ours`` with no ground truth: the ``retrieval`` prior and geometry backends.

Configuration (label, regime, declared inputs, refusals), the retrieved structure (axes back in the
benchmark frame after the search's turn, limits from the object), and one small case end to end: a
tiny gallery the test makes, the case's ground-truth object folder and label images deleted before the
run, every object the run loads checked to come from the gallery, and one retrieval for both stages.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from spark_bench.asset.ops import similarity_asset
from spark_bench.asset.urdf import write_object_folder
from spark_bench.data.case import BenchmarkCase, to_benchmark_frame
from spark_bench.data.prepare import PrepareOptions, prepare_case
from spark_bench.data.readers import load_object
from spark_bench.data.synth.generate import generate_object
from spark_bench.errors import InputError
from spark_bench.methods.base import CaseInput
from spark_bench.methods.ours.config import SparkConfig
from spark_bench.methods.ours.geometry import predicted_parts
from spark_bench.methods.ours.method import OursMethod
from spark_bench.methods.ours.prior import assemble_prior
from spark_bench.methods.ours.retrieved import retrieval_geometry, retrieval_prior
from spark_bench.methods.retrieval.search import Retrieval

RETRIEVAL = {"prior": {"backend": "retrieval"}, "geometry": {"backend": "retrieval"},
             "optimize": {"method": "native"}}


# ----- configuration --------------------------------------------------------------------------------------
def test_retrieval_backends_label_regime_and_inputs():
    config = SparkConfig.from_dict(RETRIEVAL)
    assert config.label() == "prior=retrieval,geometry=retrieval,open=dataset,opt=native"
    assert config.case_inputs() == ("image", "camera", "open_image")
    method = OursMethod(config)
    assert method.regime == "image + gt camera + gt open image"
    assert method.label() == "ours (prior=retrieval,geometry=retrieval,open=dataset,opt=native)"
    # without the optimization the open image is no input
    assert SparkConfig.from_dict({**RETRIEVAL, "optimize": {"enabled": False}}).case_inputs() == ("image", "camera")
    # mixed with a simulated stage, the regime names that one only
    mixed = OursMethod(SparkConfig.from_dict({"geometry": {"backend": "retrieval"}}))
    assert mixed.regime == "image + gt camera + gt open image + gt structure (simulated prior)"
    assert "gt geometry" not in mixed.regime and "gt" in mixed.inputs


def test_retrieval_gallery_setting_changes_the_label(tmp_path):
    default = SparkConfig.from_dict({**RETRIEVAL, "retrieval": {"gallery": "synth-gallery-v1"}})
    assert default.label() == SparkConfig.from_dict(RETRIEVAL).label()
    mine = SparkConfig.from_dict({**RETRIEVAL, "retrieval": {"gallery": str(tmp_path / "my-objects")}})
    other = SparkConfig.from_dict({**RETRIEVAL, "retrieval": {"gallery": str(tmp_path / "x" / "my-objects")}})
    assert mine.label().startswith("prior=retrieval,geometry=retrieval,open=dataset,opt=native,gallery=my-objects,"
                                   "settings=")
    assert mine.label() != other.label()  # two folders of one name never share a row
    # the gallery is no setting of a configuration that retrieves nothing
    plain = SparkConfig.from_dict({"retrieval": {"gallery": str(tmp_path / "my-objects")}})
    assert plain.label() == SparkConfig().label()
    assert SparkConfig().with_overrides(["prior.backend=retrieval", "geometry.backend=retrieval",
                                         "optimize.method=native"]).label() == SparkConfig.from_dict(RETRIEVAL).label()


def test_retrieval_config_errors_name_the_problem(tmp_path):
    with pytest.raises(InputError, match="geometry.backend 'retrieval'"):
        SparkConfig.from_dict({"prior": {"backend": "retrieval"}})  # ground-truth parts, gallery names
    with pytest.raises(InputError, match=r"unknown setting\(s\) \['retrieval.galery'\]"):
        SparkConfig.from_dict({**RETRIEVAL, "retrieval": {"galery": "x"}})
    path = tmp_path / "ours.toml"
    path.write_text('[prior]\nbackend = "retrieval"\n[geometry]\nbackend = "retrieval"\n'
                    '[retrieval]\ngallery = "/data/partnet"\n[optimize]\nmethod = "native"\n')
    config = SparkConfig.from_file(path)
    assert config.retrieval.gallery == "/data/partnet" and config.retrieval.gallery_name == "partnet"


# ----- the retrieved structure ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cabinet_objects(tmp_path_factory):
    root = tmp_path_factory.mktemp("objects")
    return {f"cab{seed}": generate_object("StorageFurniture", seed, root, f"cab{seed}") for seed in (12, 13, 14)}


def _yawed(asset, yaw_deg: float):
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    turn = np.eye(4)
    turn[:2, :2] = [[c, -s], [s, c]]
    return to_benchmark_frame(similarity_asset(to_benchmark_frame(asset)[0], turn))[0]


def test_retrieval_prior_keeps_the_retrieved_joints_after_the_turn(cabinet_objects):
    """The object as the search returns it (turned 33 degrees about the up axis): the prior's named axes,
    assembled back, must be its joints' axes exactly, its pivots on their lines, its limits theirs."""
    asset = _yawed(load_object(cabinet_objects["cab13"]), 33.0)
    found = Retrieval(asset, {"yaw_deg": 33.0, "gallery": "g", "object_id": "cab13"})
    prior, frame = retrieval_prior(found)
    geometry = retrieval_geometry(found)
    assert prior.source == "retrieval" and geometry.source == "retrieval:g/cab13"
    assembled = assemble_prior(prior, geometry, frame)
    assert assembled.meta["part_pairing"]["by"] == "names"
    truth, rebuilt = asset.joint_frames(), assembled.joint_frames()
    movable = asset.movable_joints()
    assert movable and len(prior.joints) == len(movable)
    for joint in movable:
        point, axis = truth[joint.name]
        new_point, new_axis = rebuilt[joint.name]
        assert abs(float(np.dot(axis, new_axis))) > np.cos(np.radians(0.5)), joint.name
        offset = new_point - point
        assert np.linalg.norm(offset - np.dot(offset, axis) * axis) < 1e-6, joint.name  # same axis line
        assert assembled.joints[joint.name].upper == pytest.approx(joint.upper - joint.lower)
    # the turn is needed: named in the unturned frame, the axes would be off by the yaw
    wrong = assemble_prior(prior, geometry, None).joint_frames()
    assert max(1.0 - abs(float(np.dot(truth[j.name][1], wrong[j.name][1]))) for j in movable) > 0.05
    # every part keeps its mesh
    assert set(geometry.meshes) <= {link.name for link in prior.links}


def test_retrieved_prior_pairs_other_geometry_by_structure(cabinet_objects):
    """A retrieved prior with parts that are not the same retrieval's: paired by structure, not names."""
    asset = _yawed(load_object(cabinet_objects["cab13"]), 0.0)
    prior, frame = retrieval_prior(Retrieval(asset, {"yaw_deg": 0.0}))
    other = predicted_parts(asset, "predictions")
    assembled = assemble_prior(prior, other, frame)
    assert assembled.meta["part_pairing"]["by"] == "structure"


# ----- one case end to end ---------------------------------------------------------------------------------
@pytest.mark.slow
def test_ours_with_retrieval_reads_no_ground_truth(cabinet_objects, tmp_path, isolated_home, monkeypatch):
    """A case of cab12 with its ground-truth folder and label images deleted; the gallery holds a
    re-written copy of cab12 (other bytes: the leak check lets it through) and two other cabinets. The run
    must retrieve the copy once, assemble it, refine it against the open image and write the object,
    every object it loads coming from the gallery."""
    import spark_bench.data.readers as readers
    import spark_bench.methods.ours.pipeline as pipeline
    import spark_bench.methods.retrieval.search as search

    case_dir = tmp_path / "bench" / "cases" / "case-r"
    prepare_case(cabinet_objects["cab12"], case_dir, PrepareOptions(image_size=128, resolution=40))
    case = BenchmarkCase(case_dir)
    for path in (case.input_seg, case.open_seg):
        path.unlink()
    shutil.rmtree(case.gt_dir)
    gallery = tmp_path / "gallery"
    gallery.mkdir()
    for name, folder in cabinet_objects.items():
        if name == "cab12":
            write_object_folder(load_object(folder), gallery / "copy-cab12")
        else:
            shutil.copytree(folder, gallery / name)

    loaded, calls = [], []
    real_load, real_retrieve = readers.load_object, pipeline.retrieve_case
    monkeypatch.setattr(readers, "load_object", lambda folder, *a, **k: loaded.append(folder) or real_load(folder, *a, **k))
    # an empty in-process cache of gallery objects: earlier tests may have read these same cabinets
    monkeypatch.setattr(search, "_OBJECTS", search.ObjectCache())
    monkeypatch.setattr(pipeline, "retrieve_case", lambda *a, **k: calls.append(a) or real_retrieve(*a, **k))

    config = SparkConfig.from_dict({**RETRIEVAL, "retrieval": {"gallery": str(gallery)}}).with_overrides(
        ["optimize.final_steps=[6, 4]", "optimize.sweeps=1", "optimize.short_steps=4", "optimize.short_fine_steps=0",
         "optimize.top_k=1", "optimize.screen_values_revolute=[0.6, 1.2]", "optimize.screen_values_prismatic=[0.3]",
         "optimize.screen_local=[0.05]"])
    method = OursMethod(config)
    method.prepare()
    assert method.config()["retrieval_gallery"]["name"] == "gallery"
    out = tmp_path / "out"
    generation = method.generate(CaseInput(case, frozenset(method.inputs)), out)

    assert len(calls) == 1  # one retrieval for both stages
    assert loaded and all(str(gallery) in str(folder) for folder in loaded), loaded
    info = generation.info
    assert info["label"].startswith("prior=retrieval,geometry=retrieval,open=dataset,opt=native,gallery=gallery")
    assert info["retrieval"]["object_id"] == "copy-cab12"
    assert info["retrieval"]["gallery_check"]["status"] == "passed"
    assert generation.shape_metrics_valid and "w/o joint opt." in generation.variants
    report = json.loads((out / "spark_report.json").read_text())
    assert "diagnostics" not in report  # no ground truth at hand to compare with
    assert report["backends"]["prior"] == "retrieval" and report["prior_joints"]
    assert json.loads((out / "prior.json").read_text())["source"] == "retrieval"
    assert json.loads((out / "retrieval.json").read_text())["object_id"] == "copy-cab12"
    refined, before = real_load(out), real_load(out / "prior")
    assert sorted(j.name for j in refined.movable_joints()) == sorted(report["movable_joints"])
    assert len(before.movable_joints()) == len(real_load(cabinet_objects["cab12"]).movable_joints())
