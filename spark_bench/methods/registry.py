"""The methods behind ``--method NAME``: built-ins, entry points, and methods registered at run time.

A method class registers itself with the decorator ``@register_method("name")``; its classmethod
``from_options(options: dict)`` is its factory, and its mapping ``accepts`` (key ->
:class:`~spark_bench.methods.options.MethodOption`) says which options it takes, so that an unknown key is an
error naming the method and its keys. The options come from ``eval --method-args key=value,...`` or a config
file's ``[method]`` table (:mod:`spark_bench.methods.options`).

Built in (each in a module of its own, imported when the method is first built, never for ``--help``:
:data:`BUILTIN_MODULES`): ``oracle``, ``geometry``, ``predictions``, ``command``, ``ours``, ``retrieval``.

Third-party methods: the entry-point group :data:`ENTRY_POINT_GROUP`, each entry a callable
``factory(options: dict) -> Method`` or a class with ``from_options`` (and optionally ``accepts``); or
:func:`register_method` at run time (as a decorator too).

This module imports no method: each built-in module imports it (for the decorator), and it imports that module
by its name in :data:`BUILTIN_MODULES` when the method is asked for.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from importlib.metadata import entry_points
from typing import TYPE_CHECKING

from spark_bench.errors import SparkBenchError
from spark_bench.methods.options import MethodOption, resolve_options

if TYPE_CHECKING:
    from spark_bench.methods.base import Method, MethodSpec

Factory = Callable[[dict], "Method"]
#: The entry-point group of third-party methods (a plug-in's pyproject: ``[project.entry-points."spark_bench.methods"]``).
ENTRY_POINT_GROUP = "spark_bench.methods"
#: The built-in methods and the module whose class registers each (imported on first use).
BUILTIN_MODULES = {
    "oracle": "spark_bench.methods.oracle",
    "geometry": "spark_bench.methods.geometry",
    "predictions": "spark_bench.methods.predictions",
    "command": "spark_bench.methods.command",
    "ours": "spark_bench.methods.ours.method",
    "retrieval": "spark_bench.methods.retrieval.method",
}
_builtins: dict[str, type] = {}  # filled by the built-in modules' decorators
_registry: dict[str, Factory] = {}  # registered at run time (a built-in name: overridden)


def register_method(name: str, factory: Factory | type | None = None, overwrite: bool = False):
    """Make a method available as ``--method name``.

    As a decorator, ``@register_method("name")`` registers a class by its ``from_options`` classmethod (its
    ``accepts`` mapping, when it has one, lists its options); called with ``factory``, it registers
    ``factory(options) -> Method`` (or a class with ``from_options``).

    :raises ValueError: when ``name`` is taken and ``overwrite`` is False
    :raises TypeError: when a decorated class has no ``from_options``
    """
    if factory is None:
        def decorate(cls: type) -> type:
            if not callable(getattr(cls, "from_options", None)):
                raise TypeError(f"@register_method({name!r}): {cls.__name__} has no classmethod from_options")
            if BUILTIN_MODULES.get(name) == cls.__module__:
                _builtins[name] = cls
            else:
                register_method(name, cls, overwrite)
            return cls
        return decorate
    if (name in _registry or name in BUILTIN_MODULES) and not overwrite:
        raise ValueError(f"method {name!r} is already registered")
    _registry[name] = factory
    return factory


def unregister_method(name: str) -> None:
    """Remove a method registered with :func:`register_method` (a built-in comes back as it was).

    :raises ValueError: when ``name`` is not registered
    """
    if name in _registry:
        del _registry[name]
    elif name not in BUILTIN_MODULES:
        raise ValueError(f"method {name!r} is not registered")


def _entry_points() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_methods() -> list[str]:
    """Names usable with ``--method``: built-ins, registered methods and installed entry points (nothing is
    imported)."""
    return sorted(set(BUILTIN_MODULES) | set(_registry) | set(_entry_points()))


def builtin_class(name: str) -> type:
    """The class of built-in method ``name`` (its module imported on first use)."""
    if name not in _builtins:
        importlib.import_module(BUILTIN_MODULES[name])
    if name not in _builtins:
        raise SparkBenchError(f"{BUILTIN_MODULES[name]} registers no method {name!r}")
    return _builtins[name]


def _as_factory(target) -> Factory:
    """A factory: a class's ``from_options``, or the callable itself."""
    if isinstance(target, type) and callable(getattr(target, "from_options", None)):
        return target.from_options
    return target


def _accepts(target) -> Mapping[str, MethodOption] | None:
    """What ``target`` (a class, a factory, a bound ``from_options``) says it accepts, or None."""
    for holder in (target, getattr(target, "__self__", None)):
        accepts = getattr(holder, "accepts", None)
        if isinstance(accepts, Mapping):
            return accepts
    return None


def _lookup(name: str, options: Mapping) -> tuple[object, bool]:
    """``(target, from_entry_point)`` of ``name``: a methods-file entry (``methods_file`` option, when no
    registered method has that name), a registered method, a built-in, then an entry point.

    :raises SparkBenchError: for an unknown method
    """
    if options.get("methods_file") and name not in _registry and name not in BUILTIN_MODULES:
        entry = builtin_class("command").entry_method(name, str(options["methods_file"]))
        if entry is not None:
            return entry, False
    if name in _registry:
        return _registry[name], False
    if name in BUILTIN_MODULES:
        return builtin_class(name), False
    eps = _entry_points()
    if name in eps:
        return eps[name].load(), True
    raise SparkBenchError(f"unknown method {name!r}; available: {', '.join(available_methods())}")


def accepted_options(name: str, options: Mapping | None = None) -> Mapping[str, MethodOption] | None:
    """The options method ``name`` declares (key -> :class:`MethodOption`), or None when it does not say.

    :param options: the options given (their ``methods_file`` may make ``name`` an entry of that file)
    :raises SparkBenchError: for an unknown method
    """
    return _accepts(_lookup(name, options or {})[0])


def method_spec(name: str, options: Mapping) -> MethodSpec:
    """The :class:`MethodSpec` of ``name`` with ``options`` checked and typed
    (:func:`~spark_bench.methods.options.resolve_options`: path options made absolute here).

    :raises SparkBenchError: for an unknown method, an option it does not take or a value of the wrong kind
    """
    from spark_bench.methods.base import MethodSpec

    return MethodSpec.create(name, **resolve_options(name, options, accepted_options(name, options)))


def make_method(spec_or_name: MethodSpec | str, /, **options) -> Method:
    """Build the method for ``spec_or_name``: its factory gets the options checked and typed.

    Look-up order: an entry of the methods file (``methods_file`` option) named like the method (when
    no registered method has that name), the registered methods (built-ins first among them), then the
    entry points, whose objects must have every attribute of :data:`~spark_bench.methods.base.METHOD_ATTRIBUTES`.

    :param spec_or_name: a :class:`MethodSpec` or a method name
    :param options: further options when ``spec_or_name`` is a name
    :raises SparkBenchError: for an unknown method, an option it does not take, or an entry point that gives
        no method
    """
    from spark_bench.methods.base import METHOD_ATTRIBUTES, MethodSpec

    spec = MethodSpec.create(spec_or_name, **options) if isinstance(spec_or_name, str) else spec_or_name
    opts = spec.option_dict
    target, plugin = _lookup(spec.name, opts)
    method = _as_factory(target)(resolve_options(spec.name, opts, _accepts(target)))
    if plugin:
        missing = [a for a in METHOD_ATTRIBUTES if not hasattr(method, a)]
        if missing:
            raise SparkBenchError(f"entry point {spec.name!r} gave an object without {missing}")
    return method
