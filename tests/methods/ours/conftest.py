"""Fixtures of the tests of ``ours``: the toy cabinet's benchmark case (:mod:`helpers_toy`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers_toy import write_toy_case

from spark_bench.data.case import BenchmarkCase


@pytest.fixture(scope="module")
def toy_case(tmp_path_factory) -> Path:
    """The folder of the toy cabinet's benchmark case (:func:`helpers_toy.write_toy_case`), written once per
    test module; tests that change it change a copy."""
    case = tmp_path_factory.mktemp("toy") / "case"
    write_toy_case(case)
    return case


@pytest.fixture(scope="module")
def toy_benchmark_case(toy_case: Path) -> BenchmarkCase:
    """:func:`toy_case` read as a :class:`~spark_bench.data.case.BenchmarkCase`."""
    return BenchmarkCase(toy_case)
