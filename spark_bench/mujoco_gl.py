"""The one way spark_bench imports MuJoCo: with ``MUJOCO_GL=egl`` unless the caller chose a
backend, set before the first ``import mujoco`` (MuJoCo picks its OpenGL backend at import; headless
machines have EGL, not a display). Imported inside functions so that ``spark-bench --help`` and the
CoACD workers do not load MuJoCo."""

from __future__ import annotations

import os
import sys


def mujoco_module():
    """The ``mujoco`` module, imported after ``os.environ.setdefault("MUJOCO_GL", "egl")``."""
    loaded = sys.modules.get("mujoco")
    if loaded is not None:  # hot loops (ray casts) call this: the backend was chosen at the first import
        return loaded
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    return mujoco
