"""Shared test fixtures: the shared real PartNet-Mobility objects and an isolated cache folder.

Test modules never import this file or each other; helpers shared by several test modules live in
``tests/helpers_*.py``."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
from helpers_real import real_object_path

os.environ.setdefault("MUJOCO_GL", "egl")
# tests never write into the user's cache: one throwaway home per test session unless one is given
os.environ.setdefault("SPARK_BENCH_HOME", tempfile.mkdtemp(prefix="spark-bench-tests-"))

@pytest.fixture
def real_object():
    """``real_object("41083") -> Path`` (skips cleanly where ../shared/real_objects is absent)."""
    return real_object_path


@pytest.fixture
def isolated_home(tmp_path, monkeypatch) -> Path:
    """A fresh SPARK_BENCH_HOME for tests that write caches."""
    home = tmp_path / "spark-home"
    monkeypatch.setenv("SPARK_BENCH_HOME", str(home))
    return home


@pytest.fixture
def object_loads(monkeypatch) -> list[str]:
    """The folders ``load_object`` reads from here on, in order (both names the loader goes by are watched)."""
    import spark_bench.data as data
    import spark_bench.data.readers as readers

    loaded: list[str] = []
    real_load = readers.load_object

    def counting_load(folder, *args, **kwargs):
        loaded.append(str(folder))
        return real_load(folder, *args, **kwargs)

    monkeypatch.setattr(data, "load_object", counting_load)
    monkeypatch.setattr(readers, "load_object", counting_load)
    return loaded
