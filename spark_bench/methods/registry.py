"""The methods behind ``--method NAME``: built-ins, entry points, and methods registered at run time.

Built in (each in a module of its own, imported when used):

- ``oracle``: the ground truth itself (:mod:`spark_bench.methods.oracle`);
- ``geometry``: a geometry-only articulation estimator (:mod:`spark_bench.methods.geometry`);
- ``predictions``: one folder per case id under ``--predictions DIR`` (:mod:`spark_bench.methods.predictions`);
- ``command``: an external program per case, from a methods file (:mod:`spark_bench.methods.command`);
- ``ours``: the SPARK pipeline (:mod:`spark_bench.methods.ours`).

Third-party methods: the entry-point group :data:`~spark_bench.methods.base.ENTRY_POINT_GROUP`, each
entry a callable ``factory(options: dict) -> Method``; or :func:`register_method` at run time.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import entry_points

from spark_bench.errors import SparkBenchError
from spark_bench.methods.base import ENTRY_POINT_GROUP, METHOD_ATTRIBUTES, Method, MethodSpec

Factory = Callable[[dict], Method]


def _oracle(options: dict) -> Method:
    from spark_bench.methods.oracle import Oracle

    return Oracle()


def _geometry(options: dict) -> Method:
    from spark_bench.methods.geometry import GeometryBaseline

    return GeometryBaseline.from_options(options)


def _predictions(options: dict) -> Method:
    from spark_bench.methods.predictions import make_predictions

    return make_predictions(options)


def _command(options: dict) -> Method:
    from spark_bench.methods.command import make_command

    return make_command(options)


def _ours(options: dict) -> Method:
    from spark_bench.methods.ours.method import OursMethod

    return OursMethod.from_options(options)


#: The built-in methods (always registered under these names).
def _retrieval(options: dict) -> Method:
    from spark_bench.methods.retrieval.method import RetrievalMethod

    return RetrievalMethod.from_options(options)


BUILTINS: dict[str, Factory] = {"oracle": _oracle, "geometry": _geometry, "predictions": _predictions,
                                "command": _command, "ours": _ours, "retrieval": _retrieval}
_registry: dict[str, Factory] = dict(BUILTINS)


def register_method(name: str, factory: Factory, overwrite: bool = False) -> None:
    """Make ``factory(options) -> Method`` available as ``--method name``.

    :raises ValueError: when ``name`` is taken and ``overwrite`` is False
    """
    if name in _registry and not overwrite:
        raise ValueError(f"method {name!r} is already registered")
    _registry[name] = factory


def unregister_method(name: str) -> None:
    """Remove a method registered with :func:`register_method` (a built-in comes back as it was).

    :raises ValueError: when ``name`` is not registered
    """
    if name not in _registry:
        raise ValueError(f"method {name!r} is not registered")
    if name in BUILTINS:
        _registry[name] = BUILTINS[name]
    else:
        del _registry[name]


def _entry_points() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_methods() -> list[str]:
    """Names usable with ``--method``: built-ins, registered methods and installed entry points."""
    return sorted(set(_registry) | set(_entry_points()))


def make_method(spec_or_name: MethodSpec | str, **options) -> Method:
    """Build the method for ``spec_or_name``.

    Look-up order: an entry of the methods file (``methods_file`` option) named like the method (when
    no registered method has that name), the registered methods (built-ins first among them), then the
    entry points, whose objects must have every attribute of :data:`METHOD_ATTRIBUTES`.

    :param spec_or_name: a :class:`MethodSpec` or a method name
    :param options: further options when ``spec_or_name`` is a name
    :raises SparkBenchError: for an unknown method, or an entry point that gives no method
    """
    spec = MethodSpec.create(spec_or_name, **options) if isinstance(spec_or_name, str) else spec_or_name
    opts = spec.option_dict
    if opts.get("methods_file") and spec.name not in _registry:
        from spark_bench.methods.command import CommandMethod, read_methods_file

        templates = read_methods_file(opts["methods_file"])
        if spec.name in templates:
            return CommandMethod(templates[spec.name])
    if spec.name in _registry:
        return _registry[spec.name](opts)
    eps = _entry_points()
    if spec.name in eps:
        method = eps[spec.name].load()(opts)
        missing = [a for a in METHOD_ATTRIBUTES if not hasattr(method, a)]
        if missing:
            raise SparkBenchError(f"entry point {spec.name!r} gave an object without {missing}")
        return method
    raise SparkBenchError(f"unknown method {spec.name!r}; available: {', '.join(available_methods())}")
