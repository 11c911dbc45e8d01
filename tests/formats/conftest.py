"""Fixtures of the SPARK-output tests: a tiny benchmark and its ground truth."""

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
    return Benchmark(bench).case("cab0")


@pytest.fixture(scope="module")
def gt0(case0):
    return case0.load_gt()


@pytest.fixture
def spark_cli():
    """``spark-bench``'s ``main`` (this package's commands are registered by ``cli.COMMAND_MODULES``)."""
    return cli.main
