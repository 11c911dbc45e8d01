"""Methods under test: what a method is and sees, the registry behind ``--method NAME``, and one module
per built-in method.

- :mod:`.base`: the input kinds, :class:`CaseInput` (a case that refuses undeclared inputs),
  :class:`Generation`, the :class:`Method` protocol, :class:`MethodSpec`;
- :mod:`.options`: a method's options as data (:class:`MethodOption`, ``--method-args key=value,...``, a
  config file's ``[method]`` table), checked and typed before the method's factory sees them;
- :mod:`.registry`: built-ins (by module name), entry points, :func:`register_method` (a decorator on a method
  class too) / :func:`unregister_method`, :func:`available_methods`, :func:`make_method`;
- :mod:`.oracle`, :mod:`.geometry`, :mod:`.predictions` (and the one reader of a predictions folder),
  :mod:`.command` (methods files, external programs per case), :mod:`.ours` (the SPARK pipeline of
  :mod:`spark_bench.methods.ours`);
- :mod:`.process`: the one runner of external programs (no shell, process group killed on timeout).

Imports run one way: ``options`` <- ``registry`` <- the method modules (each class registers itself with
``@register_method``), and ``base`` <- the method modules; the registry imports a built-in's module by its name
in :data:`~.registry.BUILTIN_MODULES` when the method is built, never at import (``spark-bench --help`` stays
fast). :mod:`spark_bench.methods.ours` uses ``base``, ``process`` and ``predictions`` and is used by ``ours``
only. The names below are loaded on first use.
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {
    "CaseInput": "spark_bench.methods.base",
    "Generation": "spark_bench.methods.base",
    "GenerationError": "spark_bench.methods.base",
    "Method": "spark_bench.methods.base",
    "MethodSpec": "spark_bench.methods.base",
    "MethodOption": "spark_bench.methods.options",
    "available_methods": "spark_bench.methods.registry",
    "make_method": "spark_bench.methods.registry",
    "register_method": "spark_bench.methods.registry",
    "unregister_method": "spark_bench.methods.registry",
})
