"""The same CPU kernels on every x86 machine, so that a verdict does not depend on which one ran it.

NumPy, its OpenBLAS and torch each pick their floating-point kernels at run time from the CPU's
instruction sets: an AVX-512 machine runs other ``exp``/``sin``/reduction kernels (NumPy's ``X86_V4``
targets), other matrix-product kernels (OpenBLAS ``SkylakeX``) and other torch kernels (``AVX512``) than an
AVX2 machine, and their results differ in the last bits. Those bits reach the collision hulls, the joint
optimizer's pivots and the opening episodes, where a contact can decide a verdict. So spark-bench asks all
three, before any of them is imported, for the kernels every x86-64 machine of the last decade has (AVX2
and FMA: NumPy's ``X86_V3``, OpenBLAS ``Haswell``, torch ``AVX2``), and for the baseline ones on a CPU
without AVX2. A variable the user has set is left as it is.

torch's matrix products and its vector ``exp``/``log``/``sin``/``sqrt`` go through Intel's MKL, which picks
its code by CPU *vendor and model* as well: measured under emulated CPUs (``benchmarks/measure_kernels.py``),
an Intel Haswell and an AMD EPYC, both with AVX2, gave other bits for ``torch.mm``, an MLP, ``exp`` and
``sqrt``. MKL's conditional numerical reproducibility branch ``COMPATIBLE`` (``MKL_CBWR``) is the one Intel
documents as giving the same results on Intel and non-Intel CPUs (at a fixed thread count; spark-bench's
torch work runs on one thread); oneDNN (torch's convolutions) is capped at AVX2 too. Two of torch's vector
functions, ``sqrt`` and ``acos``, still differ between the emulated CPUs and this one with ``COMPATIBLE``
(they are not correctly rounded: their last bit follows an approximate instruction, which QEMU computes
exactly and CPU makers each their own way), so the code whose numbers reach a verdict does not call them
(:func:`spark_bench.methods.ours.exact.sqrt`, NumPy's correctly rounded ``sqrt``; the fused Adam step,
:func:`spark_bench.rl.policies.fused_adam`).

This works only when ``spark_bench`` is imported before NumPy and torch (the ``spark-bench`` command, the
evaluation's worker processes, ``import spark_bench`` first in a script): :func:`cpu_kernels` says what was
pinned, and whether NumPy was already loaded, and every results row records it beside the package versions
(:mod:`spark_bench.versions`). CoACD (OpenMP) gives the same hulls whatever its thread count; MuJoCo and
PyBullet have no run-time kernel choice.
"""

from __future__ import annotations

import os
import sys
from functools import lru_cache

#: NumPy's dispatch targets above AVX2 (``numpy.show_runtime()``: ``simd_extensions``), turned off.
NUMPY_ABOVE_AVX2 = "X86_V4 AVX512_ICL AVX512_SPR"
#: The environment variables read once by each library when it loads, and their values: on a CPU with AVX2
#: and FMA, and on one without.
PINS = {
    "NPY_DISABLE_CPU_FEATURES": (NUMPY_ABOVE_AVX2, NUMPY_ABOVE_AVX2),
    "OPENBLAS_CORETYPE": ("Haswell", "Prescott"),
    "ATEN_CPU_CAPABILITY": ("avx2", "default"),
    "MKL_CBWR": ("COMPATIBLE", "COMPATIBLE"),
    "ONEDNN_MAX_CPU_ISA": ("AVX2", "SSE41"),
}


def cpu_field(name: str, cpuinfo: str = "/proc/cpuinfo") -> str | None:
    """The value of field ``name`` (``flags``, ``model name``...) of the first CPU listed in ``cpuinfo``;
    None where there is no such file or field (not Linux, not x86).

    :param name: the field, as the file names it
    :param cpuinfo: the file to read
    """
    try:
        with open(cpuinfo, encoding="utf-8", errors="replace") as handle:
            for line in handle:
                key, _, value = line.partition(":")
                if key.strip() == name:
                    return value.strip()
    except OSError:
        pass
    return None


def cpu_flags(cpuinfo: str = "/proc/cpuinfo") -> set[str]:
    """The instruction-set flags of the first CPU listed in ``cpuinfo`` (empty where there is no such file:
    not Linux, not x86).

    :param cpuinfo: the file to read
    """
    return set((cpu_field("flags", cpuinfo) or "").split())


def pinned_values(flags: set[str]) -> dict[str, str]:
    """The value of each variable of :data:`PINS` for a CPU with ``flags``.

    :param flags: the CPU's instruction-set flags (:func:`cpu_flags`)
    """
    has_avx2 = {"avx2", "fma"} <= flags
    return {name: values[0] if has_avx2 else values[1] for name, values in PINS.items()}


def pin_cpu_kernels() -> None:
    """Set the variables of :data:`PINS` that are not set yet (x86 only), before NumPy or torch loads."""
    flags = cpu_flags()
    if not flags:
        return
    for name, value in pinned_values(flags).items():
        os.environ.setdefault(name, value)


@lru_cache(maxsize=1)
def cpu_kernels() -> str:
    """What this process's kernels were asked to be, in one comparable line: the pinned variables, or why
    they do not hold (NumPy was imported before ``spark_bench``; not an x86 machine with ``/proc/cpuinfo``)."""
    if not cpu_flags():
        return "not pinned (no /proc/cpuinfo flags)"
    if _NUMPY_BEFORE_US:
        return "not pinned (numpy was imported before spark_bench)"
    return ", ".join(f"{name}={os.environ.get(name, '')}" for name in PINS)


#: Whether NumPy was loaded before this module (then its kernels were chosen already).
_NUMPY_BEFORE_US = "numpy" in sys.modules
