"""Simulation: asset -> MJCF (``mujoco.MjSpec``) with convex collision hulls, PyBullet loading, and
the sim-readiness checks.

- :func:`build_spec` ``(asset, options=None) -> mujoco.MjSpec``: the object, ready to compile or extend
- :func:`convert` ``(src, out_dir, options=None) -> Path``: ``model.xml`` + ``model.urdf`` + meshes
- :func:`run_checks` ``(src, options=None) -> CheckReport``: every check, a number and a verdict each
- :data:`CHECKS`: the checks, declared once (:class:`CheckSpec`: name, needs, function, docs row), in report order
- :class:`ConvertOptions`, :class:`CoacdParams`: every knob, with measured defaults

Names are imported lazily (PEP 562), so that ``spark-bench --help`` and CoACD worker processes stay
light.
"""

from __future__ import annotations

from spark_bench.lazy import lazy_exports

_EXPORTS = {
    "build_spec": "spark_bench.sim.mjcf",
    "prepare": "spark_bench.sim.mjcf",
    "PreparedObject": "spark_bench.sim.prepared",
    "convert": "spark_bench.sim.converter",
    "run_checks": "spark_bench.sim.checks",
    "CHECKS": "spark_bench.sim.check_registry",
    "CheckSpec": "spark_bench.sim.check_registry",
    "CheckReport": "spark_bench.sim.results",
    "CheckResult": "spark_bench.sim.results",
    "ConvertOptions": "spark_bench.sim.options",
    "CoacdParams": "spark_bench.sim.options",
    "write_pybullet_urdf": "spark_bench.sim.pybullet_io",
    "load_in_pybullet": "spark_bench.sim.pybullet_io",
    "render_check_strip": "spark_bench.sim.render",
}

__all__, __getattr__ = lazy_exports(__name__, _EXPORTS)
