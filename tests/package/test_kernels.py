"""The CPU kernels NumPy, OpenBLAS and torch run are pinned before they load, and every row says which."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from spark_bench.kernels import (
    NOT_PINNED,
    NUMPY_ABOVE_AVX2,
    PINS,
    cpu_field,
    cpu_flags,
    cpu_kernels,
    kernel_mismatches,
    kernels_hold,
    pinned_env,
    pinned_values,
)

#: NumPy at its baseline (AVX2 turned off as well): kernels other than those a CPU with AVX2 picks.
NUMPY_BASELINE_ONLY = "X86_V3 " + NUMPY_ABOVE_AVX2

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
def test_a_user_setting_is_kept():
    kept = _probe(ATEN_CPU_CAPABILITY="default")
    assert kept["env"]["ATEN_CPU_CAPABILITY"] == "default" and kept["torch"] == "DEFAULT"
    assert "ATEN_CPU_CAPABILITY=default" in kept["recorded"]


def _numpy_targets_above_avx2() -> list[str]:
    """NumPy's dispatch targets above AVX2 that this CPU offers (those the pin turns off), in a process
    without the pins."""
    code = ("from numpy._core._multiarray_umath import __cpu_features__ as f; "
            f"print(' '.join(n for n in {NUMPY_ABOVE_AVX2.split()!r} if f.get(n)))")
    clean = {k: v for k, v in os.environ.items() if k not in PINS}
    out = subprocess.run([sys.executable, "-c", code], env=clean, capture_output=True, text=True, check=True)
    return out.stdout.split()


@pytest.mark.skipif(not cpu_flags(), reason="no /proc/cpuinfo flags: nothing is pinned")
def test_numpy_loaded_first_is_recorded_by_what_it_runs():
    """NumPy imported before spark_bench: on an AVX-512 CPU it runs its AVX-512 targets and the record says
    "not pinned" and which; on another CPU it dispatches exactly as pinned, and is recorded as pinned."""
    late = _probe(first="import numpy")
    above = _numpy_targets_above_avx2()
    if above:
        assert late["recorded"].startswith(f"{NOT_PINNED} (numpy runs {' '.join(above)}")
    else:
        assert late["recorded"] == ", ".join(f"{k}={v}" for k, v in pinned_values(cpu_flags()).items())


@pytest.mark.skipif(not {"avx2", "fma"} <= cpu_flags(), reason="needs a CPU with AVX2 to run kernels not asked for")
def test_kernels_that_differ_from_the_variables_are_said_whatever_the_cpu():
    """The record looks at what NumPy dispatches, not at the import order: a variable set after NumPy
    loaded (here: AVX2 turned off too late) leaves NumPy on its AVX2 kernels, and the record names them."""
    first = f"import numpy; os.environ['NPY_DISABLE_CPU_FEATURES'] = {NUMPY_BASELINE_ONLY!r}"
    late = _probe(first=first)
    assert late["recorded"].startswith(f"{NOT_PINNED} (numpy runs X86_V3")
    in_time = _probe(NPY_DISABLE_CPU_FEATURES=NUMPY_BASELINE_ONLY)
    assert in_time["recorded"].startswith(f"NPY_DISABLE_CPU_FEATURES={NUMPY_BASELINE_ONLY},")


def test_children_start_with_the_pins_and_a_user_choice_is_kept(monkeypatch):
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Prescott")
    env = pinned_env()
    if not cpu_flags():
        assert env == {}
        return
    assert set(env) == set(PINS) and env["OPENBLAS_CORETYPE"] == "Prescott"
    assert env["NPY_DISABLE_CPU_FEATURES"] == os.environ["NPY_DISABLE_CPU_FEATURES"]


@pytest.mark.skipif(not cpu_flags(), reason="no /proc/cpuinfo flags: nothing is pinned")
def test_this_test_session_runs_the_pinned_kernels():
    """tests/conftest.py imports spark_bench before any test module imports NumPy (or starts pytest again):
    NumPy, its OpenBLAS and torch run here what the pins ask for."""
    import numpy  # noqa: F401
    import torch  # noqa: F401

    assert kernel_mismatches() == []
    assert kernels_hold() and not cpu_kernels().startswith(NOT_PINNED)


#: A pytest plugin that loads NumPy before tests/conftest.py can pin it, and turns AVX2 off too late.
EARLY_PLUGIN = f"""
import os
import numpy
os.environ["NPY_DISABLE_CPU_FEATURES"] = {NUMPY_BASELINE_ONLY!r}
"""


@pytest.mark.slow
@pytest.mark.skipif(not {"avx2", "fma"} <= cpu_flags(), reason="needs a CPU with AVX2 to run kernels not asked for")
def test_a_session_whose_numpy_loaded_before_the_pins_is_started_again_pinned(tmp_path):
    (tmp_path / "early_numpy_plugin.py").write_text(EARLY_PLUGIN)
    env = {k: v for k, v in os.environ.items() if k not in PINS and k != "SPARK_BENCH_TESTS_REPINNED"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(tmp_path), env.get("PYTHONPATH")]))
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "early_numpy_plugin",
                           f"{__file__}::test_this_test_session_runs_the_pinned_kernels"],
                          env=env, capture_output=True, text=True, timeout=300, cwd=Path(__file__).parents[2])
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "starting pytest again with them pinned" in done.stderr
    assert "1 passed" in done.stdout
