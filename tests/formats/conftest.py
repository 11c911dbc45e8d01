"""Fixtures of the foreign-format tests: a tiny benchmark, its first case and that case's ground truth."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers_bench import make_tiny_bench

from spark_bench import cli
from spark_bench.data.case import Benchmark


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> Path:
    """A benchmark of two procedural cabinets (``cab0``, ``cab1``: a drawer and a door each)."""
    return make_tiny_bench(tmp_path_factory.mktemp("bench"), n=2)


@pytest.fixture(scope="module")
def case0(bench):
    """The case ``cab0`` of ``bench``."""
    return Benchmark(bench).case("cab0")


@pytest.fixture(scope="module")
def gt(case0):
    """``cab0``'s ground truth (the object ``bench`` was written from)."""
    return case0.load_gt()


@pytest.fixture
def spark_cli():
    """``spark-bench``'s ``main`` (this package's commands are registered by ``cli.COMMAND_MODULES``)."""
    return cli.main
