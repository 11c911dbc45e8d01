"""The method registry: built-ins, methods registered at run time, entry points, and ``ours``' regime."""

from __future__ import annotations

import json
import sys
from importlib.metadata import EntryPoint

import pytest

from spark_bench.errors import SparkBenchError
from spark_bench.methods import registry
from spark_bench.methods.base import Method, MethodSpec
from spark_bench.methods.registry import available_methods, make_method, register_method, unregister_method


class Plugin:
    name, version, inputs, regime = "plugin", "2", ("image",), "image"

    def label(self):
        return "plugin"

    def config(self):
        return {}

    def generate(self, case, out_dir):
        return None


def test_builtin_methods_are_registered():
    names = available_methods()
    for name in ("oracle", "geometry", "predictions", "command", "ours"):
        assert name in names
    oracle = make_method("oracle")
    assert oracle.label() == "oracle" and oracle.inputs == ("gt",) and isinstance(oracle, Method)
    geometry = make_method("geometry")
    assert geometry.inputs == ("part_meshes",) and "contact_eps" in geometry.config()


def test_unknown_method_and_missing_options():
    with pytest.raises(SparkBenchError, match="unknown method 'nope'.*oracle"):
        make_method("nope")
    with pytest.raises(SparkBenchError, match="predictions=DIR"):
        make_method("predictions")
    with pytest.raises(SparkBenchError, match="methods_file=FILE"):
        make_method("command")


def test_method_spec_is_plain_hashable_data():
    a = MethodSpec.create("predictions", predictions="/x", label=None, regime="image")
    b = MethodSpec.create("predictions", regime="image", predictions="/x")
    assert a == b and hash(a) == hash(b) and a.option_dict == {"predictions": "/x", "regime": "image"}


def test_register_and_unregister_a_method():
    seen = []

    def factory(options):
        seen.append(options)
        return Plugin()

    register_method("plugin-test", factory)
    try:
        assert "plugin-test" in available_methods()
        with pytest.raises(ValueError, match="already registered"):
            register_method("plugin-test", factory)
        assert make_method(MethodSpec.create("plugin-test", label="x")).version == "2"
        assert seen == [{"label": "x"}]
    finally:
        unregister_method("plugin-test")
    assert "plugin-test" not in available_methods()
    with pytest.raises(ValueError, match="not registered"):
        unregister_method("plugin-test")
    # a built-in can be replaced for a while; unregistering brings the original back
    register_method("oracle", lambda options: Plugin(), overwrite=True)
    try:
        assert make_method("oracle").label() == "plugin"
    finally:
        unregister_method("oracle")
    assert make_method("oracle").label() == "oracle"


def test_a_methods_file_entry_is_a_method_unless_a_registered_name_takes_it(tmp_path):
    methods = tmp_path / "m.toml"
    methods.write_text('[methods.spark]\ncommand = ["prog", "{out}"]\n[methods.oracle]\ncommand = ["prog", "{out}"]\n')
    assert make_method("spark", methods_file=str(methods)).label() == "spark"
    assert registry.accepted_options("spark", {"methods_file": str(methods)}) == {"methods_file": registry.builtin_class(
        "command").entry_accepts["methods_file"]}
    # the built-in comes first, and takes no methods file: an error says so, rather than the file being ignored
    with pytest.raises(SparkBenchError, match="oracle takes no option methods_file"):
        make_method("oracle", methods_file=str(methods))


def test_entry_point_methods(monkeypatch):
    module = type(sys)("fake_plugin")
    module.factory = lambda options: Plugin()
    module.broken = lambda options: object()
    monkeypatch.setitem(sys.modules, "fake_plugin", module)
    eps = [EntryPoint("plugin", "fake_plugin:factory", registry.ENTRY_POINT_GROUP),
           EntryPoint("broken", "fake_plugin:broken", registry.ENTRY_POINT_GROUP)]
    monkeypatch.setattr(registry, "entry_points", lambda group: [e for e in eps if e.group == group])
    assert "plugin" in available_methods()
    assert make_method("plugin").version == "2"
    with pytest.raises(SparkBenchError, match="without"):
        make_method("broken")


def test_ours_label_and_regime_say_what_was_simulated(tmp_path):
    pytest.importorskip("spark_bench.methods.ours.config", reason="the SPARK pipeline is not installed")
    ours = make_method("ours")
    assert ours.label().startswith("ours (prior=annotation,")
    # the default (SPARK's recipe) fits the whole open-state silhouette: no part masks, every gt stage named
    assert ours.label().endswith("opt=spark)")
    assert ours.regime == "image + gt camera + gt open image + gt structure (simulated prior) + gt geometry"
    assert ours.inputs == ("image", "camera", "open_image", "gt")
    config = tmp_path / "spark.json"
    config.write_text(json.dumps({"optimize": {"method": "native", "part_masks": True}}))
    with_parts = make_method("ours", config=str(config))
    assert "gt open part masks" in with_parts.regime and "open_masks" in with_parts.inputs
    assert "sup=part-masks" in with_parts.label()
    config.write_text(json.dumps({"optimize": {"enabled": False}}))
    plain = make_method("ours", config=str(config))
    assert plain.label().endswith("opt=none)") and plain.config()["optimize"]["enabled"] is False
    # the simulated prior names axes in the case camera's frame (as a VLM reading the image would): it uses the camera
    assert plain.regime == "image + gt camera + gt structure (simulated prior) + gt geometry"
    assert plain.inputs == ("image", "camera", "gt")
    # nothing simulated: no ground truth among the inputs
    config.write_text(json.dumps({"prior": {"backend": "file", "file_dir": str(tmp_path)},
                                  "geometry": {"backend": "predictions", "predictions_dir": str(tmp_path)}}))
    honest = make_method("ours", config=str(config))
    assert honest.regime == "image + gt camera + gt open image" and "gt" not in honest.inputs


# ----- methods registered on their class, their options as data --------------------------------------------
def test_each_builtin_class_registers_itself_and_declares_its_options():
    from spark_bench.methods.options import MethodOption

    for name, module in registry.BUILTIN_MODULES.items():
        cls = registry.builtin_class(name)
        assert cls.__module__ == module and cls.name == name and callable(cls.from_options)
        assert all(isinstance(option, MethodOption) for option in cls.accepts.values()), name
    assert set(registry.accepted_options("predictions")) == {"predictions", "label", "regime"}
    assert set(registry.accepted_options("command")) == {"methods_file", "entry"}
    assert registry.accepted_options("oracle") == {} and registry.accepted_options("geometry") == {}


def test_listing_the_methods_imports_none_of_them():
    """``eval --help`` lists the names without importing a method module (the registry table is by name)."""
    code = ("import sys; from spark_bench.methods.registry import available_methods; names = available_methods(); "
            "loaded = [m for m in sys.modules if m.startswith('spark_bench.methods.') and m not in "
            "('spark_bench.methods.registry', 'spark_bench.methods.options')]; print(names, loaded); "
            "assert not loaded and 'ours' in names")
    import subprocess

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_an_unknown_option_names_the_method_and_its_options(tmp_path):
    with pytest.raises(SparkBenchError, match=r"retrieval takes no option galery \(its options: gallery;"):
        make_method("retrieval", galery=str(tmp_path))
    with pytest.raises(SparkBenchError, match=r"oracle takes no option label \(its options: none"):
        make_method("oracle", label="x")
    with pytest.raises(SparkBenchError, match="predictions takes no option entry, gallery"):
        registry.method_spec("predictions", {"predictions": str(tmp_path), "gallery": "g", "entry": "e"})


def test_the_decorator_registers_a_class_with_typed_options():
    from spark_bench.methods.options import MethodOption, Text

    @register_method("typed-test")
    class Typed(Plugin):
        accepts = {"steps": MethodOption("steps", "int"), "scale": MethodOption("scale", "float"),
                   "fast": MethodOption("fast", "bool"), "note": MethodOption("note"), "free": MethodOption("x", "any")}

        def __init__(self, options):
            self.options = options

        @classmethod
        def from_options(cls, options):
            return cls(options)

    try:
        assert "typed-test" in available_methods()
        given = {"steps": Text("12"), "scale": Text("0.5"), "fast": Text("true"), "note": Text("1e3"),
                 "free": Text("3")}
        method = make_method("typed-test", **given)
        assert method.options == {"steps": 12, "scale": 0.5, "fast": True, "note": "1e3", "free": 3}
        assert registry.method_spec("typed-test", given).option_dict == method.options
        with pytest.raises(SparkBenchError, match="option steps must be a whole number"):
            make_method("typed-test", steps=Text("1.5"))
        with pytest.raises(SparkBenchError, match="option fast must be true or false"):
            make_method("typed-test", fast=Text("yes"))
        with pytest.raises(ValueError, match="already registered"):
            register_method("typed-test")(Typed)
    finally:
        unregister_method("typed-test")
    with pytest.raises(TypeError, match="from_options"):
        register_method("no-factory")(Plugin)


def test_an_entry_point_may_name_a_class_with_from_options(monkeypatch):
    from spark_bench.methods.options import MethodOption

    class Declared(Plugin):
        accepts = {"weights": MethodOption("a checkpoint", "path")}

        @classmethod
        def from_options(cls, options):
            method = cls()
            method.seen = options
            return method

    module = type(sys)("fake_declared")
    module.Declared = Declared
    monkeypatch.setitem(sys.modules, "fake_declared", module)
    eps = [EntryPoint("declared", "fake_declared:Declared", registry.ENTRY_POINT_GROUP)]
    monkeypatch.setattr(registry, "entry_points", lambda group: [e for e in eps if e.group == group])
    assert make_method("declared", weights="/w.pt").seen == {"weights": "/w.pt"}
    with pytest.raises(SparkBenchError, match="declared takes no option label"):
        make_method("declared", label="x")
