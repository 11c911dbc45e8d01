"""Methods files and ``command`` methods: templates, placeholders, failures, the object folder found."""

from __future__ import annotations

import json
import sys

import pytest
from helpers_bench import case_input, make_tiny_bench

from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError
from spark_bench.methods.base import GenerationError
from spark_bench.methods.command import CommandMethod, find_object_folder, read_methods_file
from spark_bench.methods.registry import make_method


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
        make_method("command", methods_file=str(toml), entry="nope")
    assert make_method("command", methods_file=str(toml), entry="other").label() == "other"


def test_command_arguments_fill_only_declared_inputs(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    case = Benchmark(bench).case("cab0")
    methods = tmp_path / "m.toml"
    methods.write_text('[methods.a]\ncommand = ["prog", "{image}", "{camera}", "{out}"]\n'
                       '[methods.b]\ncommand = ["prog", "{open_image}", "{out}"]\ninputs = ["image"]\n'
                       '[methods.c]\ncommand = ["prog", "{case_dir}", "{open_masks}"]\ninputs = ["gt", "open_masks"]\n'
                       '[methods.d]\ncommand = ["prog", "{case_dir}"]\ninputs = ["image"]\n')
    templates = read_methods_file(methods)
    method_a = CommandMethod(templates["a"])
    args = method_a.arguments(case_input(bench, method_a.inputs), tmp_path / "out")
    assert args == ["prog", str(case.input_image), str(case.camera_path), str(tmp_path / "out")]
    method_b = CommandMethod(templates["b"])
    with pytest.raises(GenerationError, match="open_image"):
        method_b.arguments(case_input(bench, method_b.inputs), tmp_path / "out")
    # the case folder holds the ground truth: only a method that declared gt gets it
    method_c = CommandMethod(templates["c"])
    assert method_c.arguments(case_input(bench, method_c.inputs), tmp_path / "out") == [
        "prog", str(case.folder), str(case.open_seg)]
    method_d = CommandMethod(templates["d"])
    with pytest.raises(GenerationError, match="case_dir"):
        method_d.arguments(case_input(bench, method_d.inputs), tmp_path / "out")


def test_command_failure_reports_last_stderr_line(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    methods = tmp_path / "m.toml"
    methods.write_text(f'[methods.a]\ncommand = [{json.dumps(sys.executable)}, "-c", '
                       f'"import sys; print(\'model not found\', file=sys.stderr); sys.exit(3)", "{{out}}"]\n')
    method = make_method("a", methods_file=str(methods))
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(GenerationError, match="exit status 3: model not found"):
        method.generate(case_input(bench, method.inputs), out)
    assert (out / "method_stderr.txt").read_text() == "model not found\n"
    # the shell never sees the template: a ';' stays one argument
    methods.write_text('[methods.a]\ncommand = ["echo", "{out}; rm -rf /"]\n')
    method = make_method("a", methods_file=str(methods))
    assert method.arguments(case_input(bench, method.inputs), out) == ["echo", f"{out}; rm -rf /"]


def test_command_that_cannot_start_or_times_out_fails_the_case(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    methods = tmp_path / "m.toml"
    methods.write_text('[methods.missing]\ncommand = ["/nonexistent/prog", "{out}"]\n'
                       f'[methods.slow]\ncommand = [{json.dumps(sys.executable)}, "-c", "import time; time.sleep(30)"]\n'
                       'timeout = 0.5\n')
    for name, words in (("missing", "missing: cannot start '/nonexistent/prog'"), ("slow", "slow: timed out after 0.5 s")):
        method = make_method(name, methods_file=str(methods))
        out = tmp_path / name
        out.mkdir()
        with pytest.raises(GenerationError, match=words):
            method.generate(case_input(bench, method.inputs), out)


def test_command_writes_an_object_folder(tmp_path):
    bench = make_tiny_bench(tmp_path, n=1)
    script = "import pathlib, sys; d = pathlib.Path(sys.argv[1]) / 'obj'; d.mkdir(); (d / 'mobility.urdf').write_text('<robot/>')"
    methods = tmp_path / "m.toml"
    methods.write_text(f'[methods.a]\ncommand = [{json.dumps(sys.executable)}, "-c", {json.dumps(script)}, "{{out}}"]\n')
    method = make_method("a", methods_file=str(methods))
    out = tmp_path / "out"
    out.mkdir()
    generation = method.generate(case_input(bench, method.inputs), out)
    assert generation.folder == out / "obj" and generation.info == {"returncode": 0}


def test_find_object_folder(tmp_path):
    (tmp_path / "a" / "obj").mkdir(parents=True)
    with pytest.raises(GenerationError, match="found 0"):
        find_object_folder(tmp_path / "a")
    (tmp_path / "a" / "obj" / "mobility.urdf").write_text("<robot/>")
    assert find_object_folder(tmp_path / "a") == tmp_path / "a" / "obj"
