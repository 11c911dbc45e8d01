"""The CPU kernels NumPy, OpenBLAS and torch run are pinned before they load, and every row says which."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from spark_bench.kernels import PINS, cpu_field, cpu_flags, pinned_values

PROBE = """
import json, os, sys
{first}
import spark_bench
from spark_bench.versions import CPU_KERNELS, verdict_versions
import torch
print(json.dumps({{"env": {{k: os.environ.get(k) for k in {names!r}}},
                  "torch": torch.backends.cpu.get_cpu_capability(),
                  "recorded": verdict_versions()[CPU_KERNELS]}}))
"""


def _probe(first: str = "", **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in PINS}
    code = PROBE.format(first=first, names=list(PINS))
    out = subprocess.run([sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
                         timeout=300, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_flags_choose_the_avx2_kernels_or_the_baseline(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel name\t: Test CPU 9000\nflags\t\t: fpu sse2 avx avx2 fma avx512f\n"
                    "processor\t: 1\nflags\t: fpu\n")
    assert cpu_field("model name", str(info)) == "Test CPU 9000" and cpu_field("bogomips", str(info)) is None
    assert {"avx2", "fma", "avx512f"} <= cpu_flags(str(info)) and "fpu" in cpu_flags(str(info))
    assert cpu_flags(str(tmp_path / "missing")) == set()
    assert pinned_values({"avx2", "fma", "avx512f"}) == {
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR", "OPENBLAS_CORETYPE": "Haswell",
        "ATEN_CPU_CAPABILITY": "avx2", "MKL_CBWR": "COMPATIBLE", "ONEDNN_MAX_CPU_ISA": "AVX2"}
    assert pinned_values({"avx"})["ATEN_CPU_CAPABILITY"] == "default"
    assert pinned_values({"avx"})["OPENBLAS_CORETYPE"] == "Prescott"
    assert pinned_values({"avx"})["ONEDNN_MAX_CPU_ISA"] == "SSE41"
    # MKL picks its code by CPU maker too: the branch Intel documents as the same on Intel and AMD, on both
    assert pinned_values({"avx"})["MKL_CBWR"] == pinned_values({"avx2", "fma"})["MKL_CBWR"] == "COMPATIBLE"


@pytest.mark.skipif(not cpu_flags(), reason="no /proc/cpuinfo flags: nothing is pinned")
def test_importing_spark_bench_first_pins_torch_and_records_it():
    """Imported first, spark_bench sets the variables before torch loads: torch runs the AVX2 kernels even on
    an AVX-512 machine (the baseline ones without AVX2), and the row's record names them."""
    found = _probe()
    expected = pinned_values(cpu_flags())
    assert found["env"] == expected
    assert found["torch"] == expected["ATEN_CPU_CAPABILITY"].upper()
    assert found["recorded"] == ", ".join(f"{k}={v}" for k, v in expected.items())


@pytest.mark.skipif(not cpu_flags(), reason="no /proc/cpuinfo flags: nothing is pinned")
def test_a_user_setting_is_kept_and_numpy_loaded_first_is_said():
    kept = _probe(ATEN_CPU_CAPABILITY="default")
    assert kept["env"]["ATEN_CPU_CAPABILITY"] == "default" and kept["torch"] == "DEFAULT"
    assert "ATEN_CPU_CAPABILITY=default" in kept["recorded"]
    late = _probe(first="import numpy")
    assert late["recorded"] == "not pinned (numpy was imported before spark_bench)"
