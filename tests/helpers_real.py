"""The shared real PartNet-Mobility objects (``../shared/real_objects``) and the clean skip where they are absent."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
REAL_OBJECTS = REPO_ROOT.parent / "shared" / "real_objects"
#: The 75 real objects to develop and measure against (``../shared/partnet_dev``); tests skip where absent.
PARTNET_DEV = REPO_ROOT.parent / "shared" / "partnet_dev"
REAL_IDS = ("41083", "40147", "45780", "7179", "47645", "102442", "3763")


def real_object_path(object_id: str) -> Path:
    """The folder of a shared real object, or skip the test with a clear reason when it is absent."""
    path = REAL_OBJECTS / object_id
    if not path.is_dir():
        pytest.skip(f"shared real objects not available ({path} is absent)")
    return path
