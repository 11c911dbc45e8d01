"""The loading checks: ``mjcf_compiles`` (MuJoCo compiles the MJCF) and ``pybullet_loads`` (PyBullet loads the
collision URDF with the MJCF's joints and hulls).

Beside ``mjcf_compiles``'s verdict, and never in it: Infinigen-Sim's rest-force check
(:mod:`spark_bench.sim.rest_force`), the summed constraint force after one ``mj_forward`` at rest within ±1e-3, in
its details as ``rest_force_infinigen`` (another paper's protocol: an object spark-bench passes may fail it, and
the other way round).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.relief import summarize_relief
from spark_bench.sim.rest_force import REST_FORCE_CHECK, check_rest_force
from spark_bench.sim.rest_trim import summarize_trim
from spark_bench.sim.results import CheckResult


def conversion_details(prepared, convert_s: float) -> dict:
    """What the conversion made, for the ``mjcf_compiles`` check's details: hulls and how, CoACD's calls, the
    contact decisions.

    :param prepared: the prepared object (:func:`spark_bench.sim.mjcf.prepare`)
    :param convert_s: the seconds the preparation took
    """
    report = prepared.report
    return {
        "hulls": report.hulls, "hull_methods": report.methods, "coacd_calls": report.coacd.calls,
        "coacd_cache_hits": report.coacd.cache_hits, "coacd_turned": report.coacd.turned,
        "boxed": len(report.coacd.boxed), "convert_seconds": round(convert_s, 3),
        "relief": summarize_relief(prepared.relief), "excluded": sorted(f"{a}|{b}" for a, b in prepared.excluded),
        "rest_trim": summarize_trim(prepared.trim),
        "phantom_blocks": [b.to_dict() for b in prepared.phantom],
        "coacd_failures": report.coacd_failures}


def mjcf_compiles(inputs: CheckInputs) -> CheckResult:
    """The ``mjcf_compiles`` check of a run: the MJCF compiles (the value: seconds to compile); its details count
    the bodies and geoms, what the conversion made (where it was converted here) and Infinigen-Sim's rest force."""
    compiled = inputs.compiled
    if compiled.model is None:
        return CheckResult(False, float("nan"), {"reason": compiled.error})
    model = compiled.model
    details = {"bodies": int(model.nbody - 1), "geoms": int(model.ngeom)}
    if inputs.prepared is not None:
        details.update(conversion_details(inputs.prepared, inputs.convert_seconds))
    details[REST_FORCE_CHECK] = check_rest_force(model).to_dict()  # reported, not a check of the verdict
    return CheckResult(True, compiled.seconds, details)


def check_pybullet_conversion(asset: ArticulatedAsset, prepared) -> CheckResult:
    """PyBullet loads the object's collision URDF, written from its conversion, with the MJCF's joints and hulls.

    :param asset: the object
    :param prepared: its prepared collision shapes
    """
    from spark_bench.sim.pybullet_io import load_in_pybullet, write_pybullet_urdf

    with tempfile.TemporaryDirectory(prefix="spark_pybullet_") as tmp:
        loaded = load_in_pybullet(write_pybullet_urdf(prepared, Path(tmp), visuals=False))
    expected = {name: len(s) for name, s in prepared.shapes.items()}
    same = loaded.loaded and loaded.n_joints == len(asset.joints) and all(
        loaded.collision_shapes.get(name, 0) == n for name, n in expected.items() if n)
    details = {"collision_shapes": loaded.collision_shapes}
    if not same:
        details["reason"] = loaded.error or "PyBullet built other joints or hulls than the MJCF"
    return CheckResult(same, float(loaded.n_joints), details)


def check_pybullet_model_file(xml: Path, model) -> CheckResult:
    """PyBullet loads the ``model.urdf`` beside a converted ``model.xml`` with the hulls of its compiled model.

    :param xml: the ``model.xml``
    :param model: its compiled ``MjModel``
    """
    from spark_bench.sim.pybullet_io import load_in_pybullet

    urdf = xml.with_suffix(".urdf")
    loaded = load_in_pybullet(urdf) if urdf.is_file() else None
    if loaded is None or not loaded.loaded:
        reason = f"no {urdf.name} beside {xml.name}" if loaded is None else loaded.error
        return CheckResult(False, 0.0, {"reason": reason})
    hulls = {model.body(b).name: int(sum(1 for g in range(model.ngeom) if model.geom_bodyid[g] == b
                                         and model.geom_group[g] == 3)) for b in range(1, model.nbody)}
    same = all(loaded.collision_shapes.get(name, 0) == n for name, n in hulls.items() if n)
    details = {"collision_shapes": loaded.collision_shapes}
    if not same:
        details["reason"] = "PyBullet built other hulls than the MJCF"
    return CheckResult(same, float(loaded.n_joints), details)


def pybullet_loads(inputs: CheckInputs) -> CheckResult:
    """The ``pybullet_loads`` check of a run: of the conversion made here, or of a converted ``model.xml``."""
    if inputs.xml is not None:
        return check_pybullet_model_file(inputs.xml, inputs.model)
    return check_pybullet_conversion(inputs.asset, inputs.prepared)
