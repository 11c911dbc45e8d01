"""Fetched snapshots of other projects' repositories (the field's own assets, issue 43) and the clean skip where
they are absent. Nothing of them is kept in this repository: a test reads them where
``$SPARK_BENCH_FIELD_ASSETS`` points, a folder holding one snapshot (a work tree, or the part of one the test
needs) per repository, named as the repository: ``GenSim2``, ``Metaworld``, ``LIBERO``, ``IsaacGymEnvs``,
``newton`` (``benchmarks/measure_field_assets.py`` reads the same folders).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

#: The environment variable naming the folder of snapshots.
FIELD_ASSETS = "SPARK_BENCH_FIELD_ASSETS"


def field_snapshot(name: str, *parts: str) -> Path:
    """``$SPARK_BENCH_FIELD_ASSETS/<name>/<parts...>``, or skip the test with a clear reason when it is absent.

    :param name: the repository's name (``GenSim2``...)
    :param parts: a path inside the snapshot that must exist
    """
    root = os.environ.get(FIELD_ASSETS)
    if not root:
        pytest.skip(f"no snapshots of the field's assets (set ${FIELD_ASSETS} to a folder holding {name}/)")
    path = Path(root, name, *parts)
    if not path.exists():
        pytest.skip(f"snapshot {name} not available ({path} is absent)")
    return path
