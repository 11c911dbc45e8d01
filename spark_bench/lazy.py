"""Lazy package exports (PEP 562): a package's public names are imported on first use, so that
``spark-bench --help`` and worker processes do not pay for SciPy, MuJoCo or torch up front."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping


def lazy_exports(package: str, exports: Mapping[str, str]) -> tuple[list[str], Callable[[str], object]]:
    """``(__all__, __getattr__)`` for ``package``, whose ``exports`` maps each name to its module.

    Usage in a package ``__init__``: ``__all__, __getattr__ = lazy_exports(__name__, {...})``.
    """

    def __getattr__(name: str):
        if name in exports:
            return getattr(importlib.import_module(exports[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return sorted(exports), __getattr__
