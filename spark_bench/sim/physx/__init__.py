"""The sim-readiness checks in PhysX, through SAPIEN 3 on the CPU (``spark-bench check --engine physx``).

The object is the one MuJoCo checks: :func:`spark_bench.sim.mjcf.prepare`'s hulls, masses, joint dynamics and
excluded pairs, loaded into a physics-only SAPIEN scene (no rendering device, collision geometry only):

- :mod:`.hulls`: PhysX's cooking limits (255 vertices and 255 polygons a convex hull): a hull over them is split
  by planes into hulls within them, and every cooked hull is compared with the hull it was cooked from;
- :mod:`.build`: one articulation, links welded by fixed joints merged into one PhysX link, and a shapeless
  *carrier* link at every moving joint so that a part collides with its parent (PhysX never collides two links
  joined by an articulation joint);
- :mod:`.query`: PhysX's own contact generation on two free copies of a part and its parent, for pairs the
  articulation filters (built without carriers);
- :mod:`.checks` and :mod:`.sweep`: PhysX's limits, rest stability, rest penetration and the joint sweep with
  PhysX's own joint drives; :mod:`.engines` runs one engine or both.

``sapien`` is an optional dependency (``pip install -e ".[physx]"``); :func:`sapien_module` says so in one line.
"""

from __future__ import annotations

import importlib
import warnings

from spark_bench.errors import SparkBenchError

#: What to install for the PhysX checks.
INSTALL_HINT = 'the PhysX checks need SAPIEN 3: pip install -e ".[physx]" (or pip install "sapien>=3.0.3,<4")'


class SapienMissing(SparkBenchError):
    """SAPIEN is not installed (one line: what to install)."""


def sapien_module():
    """``import sapien`` (its warning that no Vulkan library is found is silenced: nothing is rendered).

    :raises SapienMissing: SAPIEN is not installed
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return importlib.import_module("sapien")
    except ImportError:
        raise SapienMissing(INSTALL_HINT) from None


def sapien_available() -> bool:
    """Whether SAPIEN can be imported."""
    try:
        sapien_module()
    except SapienMissing:
        return False
    return True
