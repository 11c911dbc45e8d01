"""The sim-readiness checks, declared once: :data:`CHECKS`, one :class:`CheckSpec` per check, in report order.

:func:`spark_bench.sim.checks.run_checks` runs them in this order (a check whose need is not met fails with that
need's reason, or, for a converted ``model.xml``, is left out: :mod:`spark_bench.sim.check_inputs`), and the table of
checks in ``docs/conventions.md`` (*Sim-readiness*) is :func:`docs_table` (``tests/sim/test_check_registry.py`` holds
them equal). A new check is one module (its function: ``(CheckInputs) -> CheckResult``) and one line here.

PhysX's checks (:mod:`spark_bench.sim.physx`) are :data:`PHYSX_CHECKS`: the checks of :data:`CHECKS` they share,
under the same names and in the same order, and PhysX's own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from spark_bench.sim.check_files import mesh_files
from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.check_load import mjcf_compiles, pybullet_loads
from spark_bench.sim.check_mass import mass_inertia
from spark_bench.sim.check_rest import rest_penetration, rest_stability
from spark_bench.sim.check_sweep import joint_sweep
from spark_bench.sim.results import CheckResult

#: What a check can need, in the order a run makes them (:meth:`CheckInputs.unmet` says whether each is met).
NEEDS = {
    "source": "the object as written: its URDF (MJCF, USD) and the mesh files it names",
    "mjcf": "the object's MJCF: built from its conversion, or a converted model.xml as it is",
    "conversion": "the object converted: collision hulls, masses, joints and contact decisions (a converted "
                  "model.xml's: read from its compiled model)",
    "model": "the MJCF compiled by MuJoCo",
}


@dataclass(frozen=True)
class CheckSpec:
    """One sim-readiness check.

    :param name: its key in the report (``spark-bench check --json``'s ``checks``, the results store)
    :param needs: what it reads (keys of :data:`NEEDS`); where one is not met, the check is not run
    :param run: the check: ``(inputs) -> CheckResult``
    :param stage: the key of ``CheckReport.seconds`` its wall time is added to (None: not timed)
    :param value: the docs table's *value* column: what its number is
    :param passes: the docs table's *passes when* column
    """

    name: str
    needs: tuple[str, ...]
    run: Callable[[CheckInputs], CheckResult]
    stage: str | None
    value: str
    passes: str

    def __post_init__(self) -> None:
        unknown = [n for n in self.needs if n not in NEEDS]
        if unknown:
            raise ValueError(f"check {self.name}: unknown needs {unknown} (known: {list(NEEDS)})")

    def row(self) -> str:
        """Its row of the docs table."""
        return f"| `{self.name}` | {self.value} | {self.passes} |"


#: Every check, in report order.
CHECKS = (
    CheckSpec("mesh_files", ("source",), mesh_files, None,
              "mesh files the URDF names that cannot be loaded",
              "none: every mesh file the URDF names exists, is a file, and has a surface (MuJoCo's own URDF importer "
              "fails on any such file; the reason names each one; when it fails, the object is not converted and the "
              "six other checks fail with \"not converted\", as `convert` refuses it)"),
    CheckSpec("mjcf_compiles", ("mjcf",), mjcf_compiles, "compile",
              "seconds to compile", "MuJoCo compiles the model"),
    CheckSpec("pybullet_loads", ("conversion",), pybullet_loads, "pybullet",
              "joints PyBullet built",
              "PyBullet loads the URDF with the same number of joints, and the same number of collision shapes per "
              "link as the MJCF"),
    CheckSpec("mass_inertia", ("conversion", "model"), mass_inertia, "rest",
              "smallest mass of a moving body (kg)",
              "every moving body has mass > 0 and principal moments > 0 with `a + b ≥ c (1 − 1e-6)`"),
    CheckSpec("rest_stability", ("conversion", "model"), rest_stability, "rest",
              "largest joint drift after 2 s, as a fraction of the joint's range",
              "base welded, gravity on, joints free with their damping: the state stays finite, MuJoCo raises no "
              "warning, and every joint drifts ≤ 2 % of its range or its part moves < 0.1 % of the object size, or "
              "it only settled out of an overlap its part started in (in the direction that opens that contact, by "
              "at least half its depth and at most its depth plus that 0.1 %, its part moving ≤ 0.5 % of the size, "
              "within its range, at rest at the end: the overlap itself is `rest_penetration`'s to judge; the "
              "details list it under `settled`)"),
    CheckSpec("rest_penetration", ("conversion", "model"), rest_penetration, "rest",
              "deepest contact between two bodies at rest / object size",
              "≤ 0.5 % (pairs the converter excluded from collision are listed, not counted)"),
    CheckSpec("joint_sweep", ("conversion", "model"), joint_sweep, "sweep",
              "smallest fraction of a range reached or returned",
              "every joint reaches **≥ 90 %** of its range out **and** ≥ 90 % back, with a finite state"),
)
#: The checks' names, in report order.
CHECK_NAMES = tuple(c.name for c in CHECKS)

#: PhysX's own checks: ``physx_loads`` (PhysX builds the articulation, where MuJoCo compiles and PyBullet loads)
#: and ``joint_limits`` (PhysX reads back the limits it was given).
PHYSX_OWN = ("physx_loads", "joint_limits")
#: PhysX's checks after ``mesh_files``, in its report order (:func:`spark_bench.sim.physx.engines.physx_report`):
#: its own, and those of :data:`CHECKS` it shares, under their names and in their order (a test holds them so).
PHYSX_CHECKS = ("physx_loads", "mass_inertia", "joint_limits", "rest_stability", "rest_penetration", "joint_sweep")


def docs_table() -> str:
    """The table of checks in ``docs/conventions.md`` (*Sim-readiness*), Markdown, one row per check."""
    return "\n".join(["| check | value | passes when |", "|---|---|---|", *(c.row() for c in CHECKS)])


__all__ = ["CHECKS", "CHECK_NAMES", "NEEDS", "PHYSX_CHECKS", "PHYSX_OWN", "CheckSpec", "docs_table"]
