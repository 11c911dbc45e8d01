"""``spark-bench check --engine mujoco|physx|all``: the checks of one engine or of both, and their report.

MuJoCo's checks are :func:`spark_bench.sim.checks.run_checks`. PhysX's (:func:`run_physx_checks`) read the same
prepared object (:func:`spark_bench.sim.mjcf.prepare`: its hulls, masses, joint dynamics and excluded pairs, from
the shape cache when MuJoCo's checks made them first) and run :mod:`spark_bench.sim.physx.checks` and
:mod:`spark_bench.sim.physx.sweep` on it. :class:`EngineReports` holds one
:class:`~spark_bench.sim.results.CheckReport` per engine; the object passes when it passes in every engine asked.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.sim.check_inputs import NOT_CONVERTED
from spark_bench.sim.check_registry import PHYSX_CHECKS
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.results import CheckReport, CheckResult

ENGINES = ("mujoco", "physx")


@dataclass
class EngineReports:
    """The checks of one object in each engine asked for.

    :param name: the object
    :param reports: one report per engine, in the order asked
    """

    name: str
    reports: dict[str, CheckReport] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return bool(self.reports) and all(r.passed for r in self.reports.values())

    def to_dict(self) -> dict:
        return {"passed": self.passed, "engines": {k: r.to_dict() for k, r in self.reports.items()}}

    def lines(self) -> list[str]:
        """The verdict table: one row per check, one column per engine (``-``: the engine has no such check),
        then the reason of each failure, naming its engine."""
        names = list(dict.fromkeys(n for r in self.reports.values() for n in r.checks))
        width = max(len(n) for n in names)
        out = [f"{'check':<{width}}  " + "  ".join(f"{e:<7}" for e in self.reports)]
        for name in names:
            cells = []
            for report in self.reports.values():
                result = report.checks.get(name)
                cells.append("-" if result is None else "pass" if result.passed else "FAIL")
            out.append(f"{name:<{width}}  " + "  ".join(f"{c:<7}" for c in cells))
        for engine, report in self.reports.items():
            out += [f"{engine}: {line}" for line in report.failures()]
        verdicts = ", ".join(f"{e} {'passed' if r.passed else 'failed'}" for e, r in self.reports.items())
        out.append(f"{self.name}: {'passed' if self.passed else 'failed'} ({verdicts})")
        return out


#: The PhysX checks whose verdict contacts decide: the only ones a second run with PCM off can change.
CONTACT_CHECKS = ("rest_stability", "rest_penetration", "joint_sweep")


def physx_report(prepared, carriers: bool = True, pcm: bool = True, diagnose: bool = True) -> CheckReport:
    """The PhysX checks of a prepared object (its ``mesh_files`` check aside).

    Where a check fails with PCM on and passes with it off, its reason says so (``without_pcm`` in its details):
    PhysX's persistent contact manifolds can report contacts millimetres deep between hulls that the same PhysX
    without them finds clear (partnet_dev 102381's link_2, 12.4 mm deep into link_0 at rest with PCM, passing
    without it: benchmarks/results/engine_agreement.md), and the verdict is what PhysX as SAPIEN, ManiSkill3 and
    Isaac configure it does, with its cause named. Only a failed check that contacts decide is checked again.

    :param prepared: :func:`spark_bench.sim.mjcf.prepare`'s object
    :param carriers: see :func:`spark_bench.sim.physx.build.build_object` (False: the part-parent pairs are
        queried, not collided)
    :param pcm: PhysX's persistent contact manifolds (the default, ManiSkill3's)
    :param diagnose: check a failure again with PCM off
    """
    from spark_bench.sim.physx import checks
    from spark_bench.sim.physx.build import build_object
    from spark_bench.sim.physx.sweep import check_joint_sweep
    from spark_bench.sim.sweep import swept_joints

    report = CheckReport(prepared.asset.name, warnings=list(prepared.asset.warnings))
    seconds = report.seconds
    start, cpu = time.perf_counter(), time.process_time()
    try:
        obj = build_object(prepared, carriers=carriers, pcm=pcm)
    except (RuntimeError, ValueError) as exc:  # PhysX refused a hull, a mass or a joint: that is the verdict
        report.checks["physx_loads"] = CheckResult(False, float("nan"), {"reason": " ".join(str(exc).split())})
        for name in PHYSX_CHECKS[1:]:
            report.checks[name] = CheckResult(False, float("nan"), {"reason": "PhysX did not load the object"})
        return report
    seconds["physx_build"] = time.perf_counter() - start
    joints = swept_joints(prepared.asset)
    report.checks["physx_loads"] = checks.check_physx_loads(obj)
    report.checks["mass_inertia"] = checks.check_mass_inertia(obj)
    report.checks["joint_limits"] = checks.check_joint_limits(obj)
    clock = time.perf_counter()
    report.checks["rest_stability"] = checks.check_rest_stability(obj, joints)
    report.checks["rest_penetration"] = checks.check_rest_penetration(obj)
    seconds["physx_rest"] = time.perf_counter() - clock
    clock = time.perf_counter()
    report.checks["joint_sweep"] = sweep = check_joint_sweep(obj, joints)
    if not sweep.passed:
        explain_sweep(sweep, prepared)
    seconds["physx_sweep"] = time.perf_counter() - clock
    if pcm and diagnose and any(not report.checks[name].passed for name in CONTACT_CHECKS):
        clock = time.perf_counter()
        _diagnose_pcm(report, physx_report(prepared, carriers, pcm=False, diagnose=False))
        seconds["physx_without_pcm"] = time.perf_counter() - clock
    seconds["physx_cpu"] = time.process_time() - cpu
    return report


def _diagnose_pcm(report: CheckReport, without: CheckReport) -> None:
    """Mark each failed check of ``report`` with its verdict in ``without`` (the same checks, PCM off)."""
    for name, check in report.checks.items():
        other = without.checks.get(name)
        if check.passed or other is None:
            continue
        check.details["without_pcm"] = {"passed": other.passed, "value": other.value}
        if other.passed and "reason" in check.details:
            check.details["reason"] += ("; it passes with PhysX's persistent contact manifolds (PCM) off: their "
                                        "contacts, not the object's hulls, fail it")


def explain_sweep(sweep: CheckResult, prepared) -> None:
    """Say, for every joint PhysX blocked, whether the object's surfaces or only its hulls meet on its path (the
    MuJoCo checks' :func:`spark_bench.sim.phantom.explain_blocking`, on the same hulls; engine-independent
    geometry); the first one goes into the reason."""
    from spark_bench.sim.mjcf import build_spec
    from spark_bench.sim.phantom import explain_blocking

    tolerance = 0.5 * prepared.options.clearance * prepared.size
    links = prepared.asset.links
    model, first = None, None
    for name in sweep.details["failed"]:
        joint = sweep.details["joints"][name]
        blocked = joint["blocked_by"] if joint["reached"] < 0.9 else joint.get("blocked_back_by", [])
        if not blocked or blocked[0]["body"] not in links or blocked[0]["blocked_by_body"] not in links:
            continue
        model = model if model is not None else build_spec(prepared.asset, prepared=prepared, visuals=False).compile()
        joint["explanation"] = explain_blocking(prepared, model, name, blocked[0]["body"],
                                                blocked[0]["blocked_by_body"], tolerance)
        first = first or joint["explanation"]
    if first and "reason" in sweep.details:
        sweep.details["reason"] += f"; {first}"


def run_physx_checks(src, options: ConvertOptions | None = None, progress: bool = False,
                     carriers: bool = True) -> CheckReport:
    """Convert ``src`` (object folder, URDF, MJCF or USD read as an asset, or an
    :class:`~spark_bench.asset.model.ArticulatedAsset`) as MuJoCo's checks do and run the PhysX checks.

    :raises SapienMissing: SAPIEN is not installed (before anything is converted)
    :raises InputError: ``src`` is a converted ``model.xml`` (its hulls are there, its asset is not)
    """
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.sim.check_files import check_mesh_files
    from spark_bench.sim.converter import load_source
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.physx import sapien_module

    sapien_module()
    if not isinstance(src, ArticulatedAsset) and Path(src).suffix.lower() == ".xml":
        raise InputError(src, "the PhysX checks need the object it was converted from (folder, URDF, MJCF or USD)")
    clock = time.perf_counter()
    asset = load_source(src)
    files = check_mesh_files(asset)
    if not files.passed:
        report = CheckReport(asset.name, {"mesh_files": files}, warnings=list(asset.warnings))
        for name in PHYSX_CHECKS:
            report.checks[name] = CheckResult(False, float("nan"), {"reason": NOT_CONVERTED})
        return report
    start = time.perf_counter()
    prepared = prepare(asset, options, progress=progress)
    report = physx_report(prepared, carriers)
    report.checks = {"mesh_files": files, **report.checks}
    report.seconds["prepare"] = time.perf_counter() - start
    report.seconds["total"] = time.perf_counter() - clock
    return report


def engine_names(choice: str) -> tuple[str, ...]:
    """The engines of ``--engine`` (``all``: every one)."""
    return ENGINES if choice == "all" else (choice,)


def check_engines(src, engines: tuple[str, ...], options: ConvertOptions | None = None, render: Path | None = None,
                  progress: bool = False) -> EngineReports:
    """The checks of ``src`` in each engine of ``engines`` (PhysX's needs SAPIEN: checked before MuJoCo runs).

    :param render: MuJoCo's check strip (PNG)
    """
    from spark_bench.asset.model import ArticulatedAsset
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.converter import load_source
    from spark_bench.sim.physx import sapien_module

    if "physx" in engines:
        sapien_module()
        if not isinstance(src, ArticulatedAsset) and Path(src).suffix.lower() != ".xml":
            src = load_source(src)  # read once for both engines
    out = EngineReports("")
    for engine in engines:
        if engine == "mujoco":
            out.reports[engine] = run_checks(src, options, render=render, progress=progress)
        else:
            out.reports[engine] = run_physx_checks(src, options, progress=progress)
        out.name = out.reports[engine].name
    return out
