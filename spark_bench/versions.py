"""The versions of the packages that can change a verdict (a sim check, an opening episode, a metric), recorded in
every results row so that numbers from two installs are never compared unawares.

MuJoCo simulates, CoACD decomposes, PyBullet loads, trimesh and NumPy and SciPy compute the geometry and
the metrics, torch runs the joint optimizer and the policies, gymnasium and stable-baselines3 the
environments and the policies; which CPU kernels NumPy, OpenBLAS and torch run is recorded too
(:mod:`spark_bench.kernels`). The leaderboard ranks only the rows made with the same versions of these
(:func:`spark_bench.evaluation.board.version_groups`).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import metadata

from spark_bench.kernels import cpu_kernels

#: The distributions whose release can change a verdict, by the name pip knows them by.
VERDICT_PACKAGES = ("mujoco", "coacd", "pybullet", "trimesh", "numpy", "scipy", "torch", "gymnasium",
                    "stable-baselines3")


#: The key of :func:`verdict_versions` for the CPU kernels asked for (:func:`spark_bench.kernels.cpu_kernels`).
CPU_KERNELS = "cpu kernels"


@lru_cache(maxsize=1)
def verdict_versions() -> dict[str, str]:
    """``{distribution: version}`` of :data:`VERDICT_PACKAGES` in this environment (``"absent"`` when one is
    not installed), and under :data:`CPU_KERNELS` the floating-point kernels NumPy, OpenBLAS and torch were
    asked for: a run on other kernels can give other verdicts, as one with another release can."""
    out = {CPU_KERNELS: cpu_kernels()}
    for name in VERDICT_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "absent"
    return out
