"""Where spark-bench keeps its caches (benchmarks, CoACD hulls, generated predictions)."""

from __future__ import annotations

import os
from pathlib import Path


def home() -> Path:
    """The cache root: ``$SPARK_BENCH_HOME`` or ``~/.cache/spark-bench``."""
    root = os.environ.get("SPARK_BENCH_HOME")
    path = Path(root).expanduser() if root else Path.home() / ".cache" / "spark-bench"
    path.mkdir(parents=True, exist_ok=True)
    return path


def cache_dir(name: str) -> Path:
    """A named sub-folder of :func:`home`, created on first use."""
    path = home() / name
    path.mkdir(parents=True, exist_ok=True)
    return path
