"""The method registry, what a method may see of a case, methods files and command templates."""

from __future__ import annotations

import json
import sys
from importlib.metadata import EntryPoint

import pytest
from helpers_bench import make_tiny_bench

from spark_bench import generators
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.external_methods import CommandMethod, find_object_folder, read_methods_file
from spark_bench.generators import (
    CaseInput,
    Generation,
    GenerationError,
    MethodSpec,
    available_methods,
    make_generator,
)


def test_builtin_methods_are_registered():
    names = available_methods()
    for name in ("oracle", "geometry", "predictions", "command", "ours"):
        assert name in names
    oracle = make_generator("oracle")
    assert oracle.label() == "oracle" and oracle.inputs == ("gt",) and isinstance(oracle, generators.Generator)
    geometry = make_generator("geometry")
    assert geometry.inputs == ("part_meshes",) and "contact_eps" in geometry.config()


def test_unknown_method_and_missing_options():
    with pytest.raises(SparkBenchError, match="unknown method 'nope'.*oracle"):
        make_generator("nope")
    with pytest.raises(SparkBenchError, match="--predictions DIR"):
        make_generator("predictions")
    with pytest.raises(SparkBenchError, match="--methods-file"):
        make_generator("command")


def test_method_spec_is_plain_hashable_data():
    a = MethodSpec.create("predictions", predictions="/x", label=None, regime="image")
    b = MethodSpec.create("predictions", regime="image", predictions="/x")
    assert a == b and hash(a) == hash(b) and a.option_dict == {"predictions": "/x", "regime": "image"}


def test_case_input_refuses_undeclared_inputs(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case = CaseInput("cab0", bench / "cases" / "cab0", "StorageFurniture", frozenset({"image", "part_meshes"}))
    assert case.image.name == "input.png"
    for name in ("open_image", "gt_dir", "masks", "camera"):
        with pytest.raises(PermissionError, match="did not declare"):
            getattr(case, name)
    parts = case.part_meshes()
    assert set(parts.movable.values()) == {True} and parts.root == "base"
    assert set(parts.meshes) == {"base", "link_0", "link_1"}
    assert not hasattr(parts, "joints")  # no joint parameters reach the method


def test_case_camera_is_read_and_a_bad_one_names_its_file(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case_dir = bench / "cases" / "cab0"
    case = CaseInput("cab0", case_dir, "", frozenset({"camera"}))
    assert case.camera["width"] == 64 and len(case.camera["world_to_camera"]) == 4
    assert case.path("camera") == case_dir / "camera.json"
    for text, problem in (('{"width": 64,', "malformed JSON"), ("[1, 2]", "expected a JSON object"), (None, "not found")):
        if text is None:
            (case_dir / "camera.json").unlink()
        else:
            (case_dir / "camera.json").write_text(text)
        with pytest.raises(InputError, match=rf"camera\.json: .*{problem}"):
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


def test_methods_file_toml_and_json(tmp_path):
    toml = tmp_path / "m.toml"
    toml.write_text('[methods.spark]\ncommand = "python run.py --image {image} --out {out}"\ntimeout = 5\n'
                    'inputs = ["image"]\ncwd = "sub"\n[methods.other]\ncommand = ["prog", "{out}"]\n')
    methods = read_methods_file(toml)
    assert methods["spark"].argv == ["python", "run.py", "--image", "{image}", "--out", "{out}"]
    assert methods["spark"].cwd == str(tmp_path / "sub") and methods["spark"].timeout == 5
    as_json = tmp_path / "m.json"
    as_json.write_text(json.dumps({"methods": {"x": {"command": ["a", "{out}"], "inputs": ["image", "camera"]}}}))
    assert read_methods_file(as_json)["x"].inputs == ("image", "camera")
    bad = tmp_path / "bad.toml"
    bad.write_text('[methods.x]\ncommand = ["a"]\ninputs = ["telepathy"]\n')
    with pytest.raises(InputError, match="unknown inputs"):
        read_methods_file(bad)
    bad.write_text("methods = 3")
    with pytest.raises(InputError, match="'methods' table"):
        read_methods_file(bad)
    with pytest.raises(InputError, match="no method 'nope'"):
        make_generator("command", methods_file=str(toml), entry="nope")
    # a methods-file entry is also a method name of its own
    assert make_generator("spark", methods_file=str(toml)).label() == "spark"


def test_command_arguments_fill_only_declared_inputs(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case_dir = bench / "cases" / "cab0"
    methods = tmp_path / "m.toml"
    methods.write_text('[methods.a]\ncommand = ["prog", "{image}", "{camera}", "{out}"]\n'
                       '[methods.b]\ncommand = ["prog", "{open_image}", "{out}"]\ninputs = ["image"]\n')
    templates = read_methods_file(methods)
    method_a = CommandMethod(templates["a"])
    case = CaseInput("cab0", case_dir, "", frozenset(method_a.inputs))
    args = method_a.arguments(case, tmp_path / "out")
    assert args == ["prog", str(case_dir / "input.png"), str(case_dir / "camera.json"), str(tmp_path / "out")]
    method_b = CommandMethod(templates["b"])
    with pytest.raises(GenerationError, match="open_image"):
        method_b.arguments(CaseInput("cab0", case_dir, "", frozenset(method_b.inputs)), tmp_path / "out")


def test_command_failure_reports_last_stderr_line(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    methods = tmp_path / "m.toml"
    methods.write_text(f'[methods.a]\ncommand = [{json.dumps(sys.executable)}, "-c", '
                       f'"import sys; print(\'model not found\', file=sys.stderr); sys.exit(3)", "{{out}}"]\n')
    method = make_generator("a", methods_file=str(methods))
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(GenerationError, match="exit status 3: model not found"):
        method.generate(CaseInput("cab0", bench / "cases" / "cab0", "", frozenset(method.inputs)), out)
    # the shell never sees the template: a ';' stays one argument
    methods.write_text('[methods.a]\ncommand = ["echo", "{out}; rm -rf /"]\n')
    method = make_generator("a", methods_file=str(methods))
    args = method.arguments(CaseInput("cab0", bench / "cases" / "cab0", "", frozenset(method.inputs)), out)
    assert args == ["echo", f"{out}; rm -rf /"]


def test_find_object_folder(tmp_path):
    (tmp_path / "a" / "obj").mkdir(parents=True)
    with pytest.raises(GenerationError, match="found 0"):
        find_object_folder(tmp_path / "a")
    (tmp_path / "a" / "obj" / "mobility.urdf").write_text("<robot/>")
    assert find_object_folder(tmp_path / "a") == tmp_path / "a" / "obj"


def test_entry_point_methods(monkeypatch):
    class Plugin:
        name, version, inputs, regime = "plugin", "2", ("image",), "image"

        def label(self):
            return "plugin"

        def config(self):
            return {}

        def generate(self, case, out_dir):
            return None

    module = type(sys)("fake_plugin")
    module.factory = lambda options: Plugin()
    module.broken = lambda options: object()
    monkeypatch.setitem(sys.modules, "fake_plugin", module)
    eps = [EntryPoint("plugin", "fake_plugin:factory", generators.ENTRY_POINT_GROUP),
           EntryPoint("broken", "fake_plugin:broken", generators.ENTRY_POINT_GROUP)]
    monkeypatch.setattr(generators, "entry_points", lambda group: [e for e in eps if e.group == group])
    assert "plugin" in available_methods()
    assert make_generator("plugin").version == "2"
    with pytest.raises(SparkBenchError, match="without"):
        make_generator("broken")


def test_ours_label_and_regime_say_what_was_simulated(tmp_path):
    pytest.importorskip("spark_bench.spark.config", reason="the SPARK pipeline is not installed")
    ours = make_generator("ours")
    assert ours.label().startswith("ours (prior=annotation,")
    assert "gt prior" in ours.regime and "gt" in ours.inputs
    config = tmp_path / "spark.json"
    config.write_text(json.dumps({"optimize": {"enabled": False}}))
    plain = make_generator("ours", config=str(config))
    assert plain.label().endswith("opt=none)") and plain.config()["optimize"]["enabled"] is False
