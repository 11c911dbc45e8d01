"""Shared test fixtures: the shared real PartNet-Mobility objects and an isolated cache folder."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
# tests never write into the user's cache: one throwaway home per test session unless one is given
os.environ.setdefault("SPARK_BENCH_HOME", tempfile.mkdtemp(prefix="spark-bench-tests-"))

REPO_ROOT = Path(__file__).resolve().parents[1]
REAL_OBJECTS = REPO_ROOT.parent / "shared" / "real_objects"
REAL_IDS = ("41083", "40147", "45780", "7179", "47645", "102442", "3763")


def real_object_path(object_id: str) -> Path:
    """The folder of a shared real object, or skip the test with a clear reason when it is absent."""
    path = REAL_OBJECTS / object_id
    if not path.is_dir():
        pytest.skip(f"shared real objects not available ({path} is absent)")
    return path


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
