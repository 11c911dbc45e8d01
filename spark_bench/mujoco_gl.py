"""The one way spark_bench imports MuJoCo: with ``MUJOCO_GL=egl`` unless the caller chose a
backend, set before the first ``import mujoco`` (MuJoCo picks its OpenGL backend at import; headless
machines have EGL, not a display). Imported inside functions so that ``spark-bench --help`` and the
CoACD workers do not load MuJoCo."""

from __future__ import annotations

import os


def mujoco_module():
    """The ``mujoco`` module, imported after ``os.environ.setdefault("MUJOCO_GL", "egl")``."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    return mujoco
