"""The versions of the packages that can change a verdict (a sim check, an opening episode, a metric), recorded in
every results row so that numbers from two installs are never compared unawares.

MuJoCo simulates, CoACD decomposes, PyBullet loads, trimesh and NumPy and SciPy compute the geometry and
the metrics, torch runs the joint optimizer and the policies, gymnasium and stable-baselines3 the
environments and the policies. The leaderboard ranks only the rows made with the same versions of these
(:func:`spark_bench.evaluation.board.version_groups`).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import metadata

#: The distributions whose release can change a verdict, by the name pip knows them by.
VERDICT_PACKAGES = ("mujoco", "coacd", "pybullet", "trimesh", "numpy", "scipy", "torch", "gymnasium",
                    "stable-baselines3")


@lru_cache(maxsize=1)
def verdict_versions() -> dict[str, str]:
    """``{distribution: version}`` of :data:`VERDICT_PACKAGES` in this environment (``"absent"`` when one is
    not installed)."""
    out = {}
    for name in VERDICT_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "absent"
    return out
