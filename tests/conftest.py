"""Shared test fixtures: the shared real PartNet-Mobility objects and an isolated cache folder; and the pinned
CPU kernels for the whole session.

Test modules never import this file or each other; helpers shared by several test modules live in
``tests/helpers_*.py``.

pytest loads this file before any test module, so importing ``spark_bench`` first here pins the CPU kernels
(:mod:`spark_bench.kernels`) before a test module's ``import numpy``: the tests run the kernels the
``spark-bench`` command runs, on an AVX-512 machine too. Where something loaded NumPy or torch even earlier
(a pytest plugin), the session is started again with the pins in its environment (:func:`pytest_configure`).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import pytest  # none of these loads NumPy
from helpers_real import real_object_path

from spark_bench import kernels  # pins the CPU kernels before the test modules load NumPy

#: Set in a session started again for its kernels, so that it is started again at most once.
REEXEC_MARK = "SPARK_BENCH_TESTS_REPINNED"


def pytest_configure(config) -> None:
    """Start this pytest process again (same interpreter, same arguments) with the pins in its environment
    when the kernels it runs are not the pinned ones (something loaded NumPy or torch before this file); say
    so, once, where that does not help. Done here, not at import, so that pytest's capture of the output
    can be stopped first: the new process writes to the terminal, not to a capture file."""
    if kernels.kernels_hold():
        return
    if os.environ.get(REEXEC_MARK):
        sys.stderr.write(f"tests: CPU kernels {kernels.cpu_kernels()}; results may differ from a pinned run\n")
        return
    capture = config.pluginmanager.getplugin("capturemanager")
    if capture is not None:
        capture.stop_global_capturing()
    sys.stderr.write(f"tests: CPU kernels {kernels.cpu_kernels()}; starting pytest again with them pinned\n")
    sys.stdout.flush()
    sys.stderr.flush()
    os.environ.update({**kernels.pinned_env(), REEXEC_MARK: "1"})
    os.execv(sys.executable, sys.orig_argv)


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
