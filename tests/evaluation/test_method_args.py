"""``eval --method NAME --method-args key=value,...`` and a config file's ``[method]`` table: the method's options
as data, the deprecated flags that gave them before, and the run identity, which does not depend on how the
options were given."""

from __future__ import annotations

import json

import pytest

from spark_bench.cli import build_parser, main
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.commands import method_spec
from spark_bench.methods.options import Text, parse_method_args, resolve_options
from spark_bench.methods.registry import register_method, unregister_method


def spec_of(*argv):
    return method_spec(build_parser().parse_args(["eval", *argv]))


class Plugin:
    name, version, inputs, regime = "plugin", "1", ("image",), "image"

    def __init__(self, options=None):
        self.options = options

    def label(self):
        return "plugin"

    def config(self):
        return dict(self.options)

    def generate(self, case, out_dir):
        return None


# ----- the text of --method-args ---------------------------------------------------------------------------
def test_method_args_split_at_commas_outside_quotes_and_merge_over_repeats():
    given = parse_method_args(['predictions=/p,label="ours (a=1,b=2)"', "regime = image + gt camera ,"])
    assert given == {"predictions": "/p", "label": '"ours (a=1,b=2)"', "regime": "image + gt camera"}
    assert all(isinstance(v, Text) for v in given.values())
    with pytest.raises(SparkBenchError, match="'label' is given twice"):
        parse_method_args(["label=a", "label=b"])
    with pytest.raises(SparkBenchError, match="'oops' is not KEY=VALUE"):
        parse_method_args(["a=1,oops"])
    with pytest.raises(SparkBenchError, match="not closed"):
        parse_method_args(['label="a,b'])


def test_a_method_that_declares_no_options_gets_json_scalars_else_text():
    register_method("plugin-args", lambda options: Plugin(options))
    try:
        spec = spec_of("--method", "plugin-args", "--method-args",
                       'steps=3,scale=0.5,fast=true,name=abc,quoted="3",none=null,list=[1]')
        assert spec.option_dict == {"steps": 3, "scale": 0.5, "fast": True, "name": "abc", "quoted": "3",
                                    "list": "[1]"}
    finally:
        unregister_method("plugin-args")


def test_declared_text_options_keep_the_text_and_paths_become_absolute(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "preds").mkdir()
    spec = spec_of("--method", "predictions", "--method-args", 'predictions=preds,label=1e3,regime="image"')
    assert spec.option_dict == {"predictions": str(tmp_path / "preds"), "label": "1e3", "regime": "image"}
    # an empty path is no path: the default gallery
    assert spec_of("--method", "retrieval", "--method-args", "gallery=").option_dict == {}


def test_an_unknown_key_is_an_error_naming_the_method_and_its_options(capsys):
    assert main(["eval", "--method", "retrieval", "--method-args", "galery=x", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--method retrieval takes no option galery (its options: gallery;" in err
    with pytest.raises(SparkBenchError, match="ours takes no option label"):
        spec_of("--method", "ours", "--method-args", "label=x")


# ----- the deprecated flags ---------------------------------------------------------------------------------
def test_the_old_flags_give_the_same_spec_with_one_deprecation_line_each(tmp_path, capsys):
    preds = tmp_path / "preds"
    preds.mkdir()
    old = spec_of("--method", "predictions", "--predictions", str(preds), "--label", "SINGAPO", "--regime", "image")
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"spark-bench: --{flag} is deprecated and goes in the next release: use --method-args {use}"
                     for flag, use in (("predictions", "predictions=DIR"), ("label", "label=TEXT"),
                                       ("regime", "regime=TEXT"))]
    new = spec_of("--method", "predictions", "--method-args", f"predictions={preds},label=SINGAPO,regime=image")
    assert old == new and capsys.readouterr().err == ""
    methods = tmp_path / "m.toml"
    methods.write_text('[methods.a]\ncommand = ["prog", "{out}"]\n[methods.b]\ncommand = ["prog", "{out}"]\n')
    assert (spec_of("--method", "command", "--methods-file", str(methods), "--entry", "b")
            == spec_of("--method", "command", "--method-args", f"methods_file={methods},entry=b"))
    assert "--methods-file is deprecated" in capsys.readouterr().err
    with pytest.raises(SparkBenchError, match="given by --label and by --method-args"):
        spec_of("--method", "predictions", "--label", "a", "--method-args", f"predictions={preds},label=b")


# ----- a config file's [method] table -----------------------------------------------------------------------
def test_a_config_files_method_table_gives_the_same_options(tmp_path):
    preds = tmp_path / "preds"
    preds.mkdir()
    config = tmp_path / "eval.toml"
    config.write_text(f'[method]\npredictions = "{preds}"\nlabel = "from file"\n')
    from_file = spec_of("--method", "predictions", "--config", str(config))
    assert from_file == spec_of("--method", "predictions", "--method-args", f"predictions={preds},label=from file")
    # the command line wins over the file
    assert spec_of("--method", "predictions", "--config", str(config),
                   "--method-args", "label=cli").option_dict["label"] == "cli"
    as_json = tmp_path / "eval.json"
    as_json.write_text(json.dumps({"method": {"predictions": str(preds), "label": "from file"}}))
    assert spec_of("--method", "predictions", "--config", str(as_json)) == from_file


def test_ours_reads_its_own_tables_of_the_config_file_beside_method(tmp_path):
    pytest.importorskip("spark_bench.methods.ours.config", reason="the SPARK pipeline is not installed")
    from spark_bench.methods.registry import make_method

    config = tmp_path / "ours.toml"
    config.write_text('[method]\n[optimize]\nmethod = "native"\npart_masks = true\n')
    spec = spec_of("--method", "ours", "--config", str(config))
    assert spec.option_dict == {"config": str(config)}
    assert spec == spec_of("--method", "ours", "--method-args", f"config={config}")
    assert "sup=part-masks" in make_method(spec).label()
    with pytest.raises(SparkBenchError, match="configure --method oracle, which takes no config file"):
        spec_of("--method", "oracle", "--config", str(config))
    other = tmp_path / "other.toml"
    other.write_text("")
    with pytest.raises(SparkBenchError, match="config file is given twice"):
        spec_of("--method", "ours", "--config", str(config), "--method-args", f"config={other}")


def test_the_run_identity_does_not_depend_on_how_the_options_are_given(tmp_path):
    from spark_bench.evaluation.runner import run_identity
    from spark_bench.evaluation.tasks import EvalOptions

    preds = tmp_path / "preds"
    preds.mkdir()
    config = tmp_path / "eval.toml"
    config.write_text(f'[method]\npredictions = "{preds}"\nlabel = "x"\n')
    specs = [spec_of("--method", "predictions", "--predictions", str(preds), "--label", "x"),
             spec_of("--method", "predictions", "--method-args", f"predictions={preds},label=x"),
             spec_of("--method", "predictions", "--config", str(config))]
    runs = {run_identity("synth-v1", spec, EvalOptions()) for spec in specs}
    assert len(runs) == 1 and runs.pop().label == "x"


# ----- the help ---------------------------------------------------------------------------------------------
def test_the_help_lists_the_registered_methods(capsys):
    register_method("plugin-help", lambda options: Plugin(options))
    try:
        with pytest.raises(SystemExit):
            main(["eval", "--help"])
    finally:
        unregister_method("plugin-help")
    out = " ".join(capsys.readouterr().out.split())
    assert "one of command, geometry, oracle, ours, plugin-help, predictions, retrieval," in out
    assert "--predictions DIR deprecated: --method-args predictions=DIR (--method predictions)" in out


def test_method_args_help_lists_the_methods_options(capsys):
    assert main(["eval", "--method", "predictions", "--method-args", "help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("--method predictions --method-args KEY=VALUE")
    assert "predictions  path" in out and "regime" in out
    assert main(["eval", "--method", "oracle", "--method-args", "help"]) == 0
    assert capsys.readouterr().out == "--method oracle takes no options\n"


def test_resolve_options_checks_kinds_of_file_values():
    from spark_bench.methods.options import MethodOption

    accepts = {"steps": MethodOption("n", "int"), "fast": MethodOption("f", "bool")}
    assert resolve_options("m", {"steps": 3.0, "fast": False}, accepts) == {"steps": 3, "fast": False}
    with pytest.raises(SparkBenchError, match="option fast must be true or false, got 'no'"):
        resolve_options("m", {"fast": "no"}, accepts)
