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

The variables take effect only in a library that loads after they are set: the ``spark-bench`` command, the
evaluation's worker processes (started with them, :func:`pinned_env`) and a script that imports
``spark_bench`` first are pinned; a script or notebook that imports NumPy (or gymnasium, torch) first
runs the kernels its CPU offers. So what is recorded is not what was asked but what runs
(:func:`kernel_mismatches`: NumPy's dispatched targets, each loaded OpenBLAS's core type, torch's
capability), and :func:`cpu_kernels` says "not pinned" with the difference where they disagree; every
results row records it beside the package versions (:mod:`spark_bench.versions`), the evaluation runs the
cases of such a process in pinned worker processes, and the leaderboard names any row made unpinned.
On a CPU without AVX-512 NumPy loaded first dispatches as pinned, and is recorded as pinned. CoACD
(OpenMP) gives the same hulls whatever its thread count; MuJoCo and PyBullet have no run-time kernel choice.
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


def pinned_env() -> dict[str, str]:
    """The variables of :data:`PINS` a child process must start with to run the pinned kernels: the value
    set in this process where there is one (a user's own choice is kept), else the pinned one for this CPU;
    empty where nothing is pinned (no ``/proc/cpuinfo`` flags)."""
    flags = cpu_flags()
    if not flags:
        return {}
    return {name: os.environ.get(name) or value for name, value in pinned_values(flags).items()}


def _numpy_mismatch() -> str | None:
    """NumPy's dispatch targets that run although ``NPY_DISABLE_CPU_FEATURES`` turns them off (NumPy was
    loaded before the variable was set); None when NumPy is not loaded or runs what was asked."""
    if "numpy" not in sys.modules:
        return None
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # NumPy 1.x
        from numpy.core._multiarray_umath import __cpu_features__ as features
    running = [name for name in os.environ.get("NPY_DISABLE_CPU_FEATURES", "").split() if features.get(name)]
    return f"numpy runs {' '.join(running)}" if running else None


def _openblas_mismatch() -> str | None:
    """The loaded OpenBLAS libraries (NumPy's, SciPy's) whose core type is not ``OPENBLAS_CORETYPE``."""
    asked = os.environ.get("OPENBLAS_CORETYPE", "")
    if not asked or "numpy" not in sys.modules:
        return None
    from threadpoolctl import threadpool_info

    found = sorted({str(lib.get("architecture")) for lib in threadpool_info()
                    if lib.get("internal_api") == "openblas" and str(lib.get("architecture")).lower() != asked.lower()})
    return f"openblas runs {' '.join(found)}" if found else None


def _torch_mismatch() -> str | None:
    """torch's kernels where torch loaded before the variables were set: its capability when that is not
    ``ATEN_CPU_CAPABILITY``, and MKL's and oneDNN's choices (read once, at load, not observable)."""
    if "torch" not in sys.modules:
        return None
    asked = os.environ.get("ATEN_CPU_CAPABILITY", "")
    running = str(sys.modules["torch"].backends.cpu.get_cpu_capability())
    if asked and running.lower() != asked.lower():
        return f"torch runs {running}"
    if "torch" in _LOADED_BEFORE_US and any(_ENV_BEFORE_US[name] != os.environ.get(name)
                                            for name in ("MKL_CBWR", "ONEDNN_MAX_CPU_ISA")):
        return "torch loaded before the MKL and oneDNN pins"
    return None


def kernel_mismatches() -> list[str]:
    """How the kernels this process runs differ from those :data:`PINS`' variables ask for, one phrase per
    library (empty: they are the asked ones). Looked at in the libraries themselves, not inferred from the
    import order: NumPy loaded first on a CPU without AVX-512 dispatches exactly as pinned."""
    return [found for found in (_numpy_mismatch(), _openblas_mismatch(), _torch_mismatch()) if found]


#: How :func:`cpu_kernels` starts when this process runs other kernels than the pinned ones.
NOT_PINNED = "not pinned"


def kernels_hold() -> bool:
    """Whether this process runs the kernels that :data:`PINS`' variables ask for (no ``/proc/cpuinfo``
    flags: nothing to pin, so nothing to hold)."""
    return not cpu_kernels().startswith(NOT_PINNED) or not cpu_flags()


@lru_cache(maxsize=1)
def cpu_kernels() -> str:
    """What this process's kernels are, in one comparable line: the pinned variables, or ``not pinned``
    and how the running kernels differ from them (a library was loaded before ``spark_bench`` pinned it;
    not an x86 machine with ``/proc/cpuinfo``). Asked once, after the verdict work has loaded NumPy."""
    if not cpu_flags():
        return f"{NOT_PINNED} (no /proc/cpuinfo flags)"
    mismatches = kernel_mismatches()
    if mismatches:
        return f"{NOT_PINNED} ({'; '.join(mismatches)}: loaded before spark_bench set the pins)"
    return ", ".join(f"{name}={os.environ.get(name, '')}" for name in PINS)


#: The libraries that choose kernels and were loaded before this module (they read the variables already).
_LOADED_BEFORE_US = frozenset(name for name in ("numpy", "torch") if name in sys.modules)
#: The variables as they were when this module loaded, before :func:`pin_cpu_kernels` set any.
_ENV_BEFORE_US = {name: os.environ.get(name) for name in PINS}
