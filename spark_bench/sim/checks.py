"""Sim-readiness checks: each a number and a pass/fail.

=====================  ========================================================  =====================
check                  value                                                     passes when
=====================  ========================================================  =====================
``mesh_files``         mesh files the URDF names that cannot be loaded            none (every file
                                                                                 exists, is a file and
                                                                                 has a surface)
``mjcf_compiles``      seconds to compile the MJCF                               MuJoCo compiles it
``pybullet_loads``     joints PyBullet built                                     same joints and hulls
``mass_inertia``       smallest mass of a moving body (kg)                       all > 0, inertia valid
``rest_stability``     largest joint drift after 2 s, fraction of its range      finite, no warning,
                                                                                 drift <= 2 % (or the
                                                                                 part moved < 0.1 % of
                                                                                 the object's size)
``rest_penetration``   deepest contact between two links at rest / object size   <= 0.5 %
``joint_sweep``        smallest fraction of a joint's range reached              >= 90 % out and back,
                                                                                 or short of it by at
                                                                                 most 0.1 % of the
                                                                                 object's size
=====================  ========================================================  =====================

Beside these, reported and never in the verdict: Infinigen-Sim's rest-force check
(:mod:`spark_bench.sim.rest_force`), the summed constraint force after one ``mj_forward`` at rest within
±1e-3, in the ``mjcf_compiles`` check's details as ``rest_force_infinigen`` (another paper's protocol:
an object spark-bench passes may fail it, and the other way round).

A blocked joint's reason says whether the surfaces of the two parts meet too (the object blocks it:
its range or geometry is wrong) or only their hulls do (:func:`spark_bench.sim.phantom.explain_blocking`).

The sweep is in :mod:`spark_bench.sim.sweep`; the result types in :mod:`spark_bench.sim.results`.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.converter import load_source, unloadable_mesh_files
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.relief import joint_bodies, summarize_relief
from spark_bench.sim.rest_force import REST_FORCE_CHECK, check_rest_force
from spark_bench.sim.rest_trim import summarize_trim
from spark_bench.sim.results import CheckReport, CheckResult
from spark_bench.sim.sweep import (
    SweptJoint,
    check_joint_sweep,
    part_radius,
    stopped_by_contact,
    swept_joints,
    swept_joints_of_model,
)

REST_SECONDS = 2.0
REST_DRIFT_TOLERANCE = 0.02
REST_DRIFT_FLOOR = 0.001
PENETRATION_TOLERANCE = 0.005


#: The checks that need the converted model, in report order (after ``mesh_files``).
MODEL_CHECKS = ("mjcf_compiles", "pybullet_loads", "mass_inertia", "rest_stability", "rest_penetration",
                "joint_sweep")


# ----- individual checks --------------------------------------------------------------------------
def check_mesh_files(asset: ArticulatedAsset) -> CheckResult:
    """Every mesh file the URDF names can be loaded as written (:func:`unloadable_mesh_files`)."""
    bad = unloadable_mesh_files(asset)
    details = {"unloadable": bad} if bad else {}
    if bad:
        details["reason"] = (f"{asset.source or asset.name}: {len(bad)} mesh file(s) the URDF names cannot be "
                             f"loaded as written (MuJoCo's URDF importer fails on them): " + "; ".join(bad[:3])
                             + ("; ..." if len(bad) > 3 else ""))
    return CheckResult(not bad, float(len(bad)), details)


def _carries_collision(model) -> np.ndarray:
    """Per body: whether it or a body below it has a geom that collides (by its contact bits or an explicit pair)."""
    carries = np.zeros(model.nbody, bool)
    colliding = {g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]}
    colliding |= {int(g) for g in model.pair_geom1} | {int(g) for g in model.pair_geom2}
    for g in colliding:
        carries[model.geom_bodyid[g]] = True
    for b in range(model.nbody - 1, 0, -1):
        carries[model.body_parentid[b]] |= carries[b]
    return carries


def check_mass_inertia(model) -> CheckResult:
    """Every body with a degree of freedom has positive mass and principal moments that satisfy the
    triangle inequality (MuJoCo's own test, with its tolerance), and carries collision geometry, itself or
    through the bodies below it (a door whose meshes were all left out has nothing to weigh or to touch; a
    ``*_helper`` link between two joints carries the part below it). The value is the smallest mass of a
    moving body, or of any body where nothing moves."""
    moving = [b for b in range(1, model.nbody) if model.body_dofnum[b] > 0 or model.body_weldid[b] != 0]
    bad = []
    for b in moving:
        a, bb, c = np.sort(model.body_inertia[b])
        if not (model.body_mass[b] > 0 and a > 0 and a + bb >= c * (1 - 1e-6)):
            bad.append(model.body(b).name)
    carries = _carries_collision(model)
    empty = [model.body(b).name for b in range(1, model.nbody) if model.body_dofnum[b] > 0 and not carries[b]]
    weighed = moving or list(range(1, model.nbody))
    smallest = float(min((model.body_mass[b] for b in weighed), default=float("nan")))
    details = {"moving_bodies": len(moving)}
    reasons = []
    if bad:
        reasons.append(f"invalid mass or inertia: {bad}")
    if empty:
        reasons.append(f"moving part(s) without collision geometry (their mass is a placeholder): {empty}")
    if not math.isfinite(smallest):
        reasons.append("the model has no body to weigh")
    if reasons:
        details["reason"] = "; ".join(reasons)
    return CheckResult(not reasons, smallest, details)


def _warnings(data) -> dict[str, int]:
    mujoco = mujoco_module()
    out = {}
    for member in ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_CONTACTFULL",
                   "mjWARN_CNSTRFULL", "mjWARN_INERTIA"):
        count = int(data.warning[int(getattr(mujoco.mjtWarning, member))].number)
        if count:
            out[member[len("mjWARN_"):].lower()] = count
    return out


@dataclass
class RestContact:
    """A contact a joint's part starts in, at rest: how deep, and how fast moving the joint opens it.

    :param depth: penetration at rest (m)
    :param rate: separation of the contact per unit of joint motion (m per rad or per m): positive
        when increasing the joint pulls the part out of its neighbour
    :param pair: the two geoms
    """

    depth: float
    rate: float
    pair: tuple[str, str]

    def explains(self, delta: float, margin: float) -> bool:
        """Whether a joint motion of ``delta`` is the part coming out of this overlap: in the direction that
        opens it, by at least half its depth (a contact the motion hardly opens, near the axis or across
        it, explains nothing) and no farther than its depth plus ``margin``.

        :param delta: the joint's motion from its rest value (rad or m)
        :param margin: how far beyond the overlap's depth the part may have moved (m)
        """
        opened = self.rate * delta
        return opened >= 0.5 * self.depth and opened <= self.depth + margin


def rest_contacts(model, data, joint_name: str) -> list[RestContact]:
    """The penetrating contacts, at ``data``'s current state, between the bodies that joint
    ``joint_name`` moves and every other body.

    :param model: the compiled ``MjModel``
    :param data: its ``MjData``, after ``mj_forward``
    :param joint_name: a hinge or slide of ``model``
    """
    jid = model.joint(joint_name).id
    moving = joint_bodies(model, jid)
    anchor, axis = data.xanchor[jid], data.xaxis[jid]
    hinge = int(model.jnt_type[jid]) == 3  # mjJNT_HINGE
    out = []
    for contact in data.contact[: data.ncon]:
        in1 = int(model.geom_bodyid[contact.geom1]) in moving
        in2 = int(model.geom_bodyid[contact.geom2]) in moving
        if in1 == in2 or contact.dist >= 0:
            continue
        # the frame's normal points from geom1 to geom2: the moving part leaves along it when it is geom2
        out_normal = -contact.frame[:3] if in1 else contact.frame[:3]
        velocity = np.cross(axis, contact.pos - anchor) if hinge else axis
        out.append(RestContact(-float(contact.dist), float(out_normal @ velocity),
                               (model.geom(contact.geom1).name, model.geom(contact.geom2).name)))
    return out


def check_rest_stability(model, joints: list[SweptJoint], size: float, seconds: float = REST_SECONDS) -> CheckResult:
    """Gravity on, every joint free with its damping, from rest: no NaN, no warning, small drift.

    Drift is the joint's displacement as a fraction of its range; a joint passes when that is at most
    :data:`REST_DRIFT_TOLERANCE`, or when its part moved less than :data:`REST_DRIFT_FLOOR` of the
    object's size (a camera button's 0.2 mm is 2 % of its 8 mm travel, but nothing moved).

    A part that starts inside a neighbour's hulls is pushed out of them in the first steps. That overlap
    is :func:`check_rest_penetration`'s to judge (up to :data:`PENETRATION_TOLERANCE` of the size), not
    a drift: a joint also passes when its motion only took its part out of a contact it started in
    (:meth:`RestContact.explains`, with the drift floor as margin), its part moved no farther than
    :data:`PENETRATION_TOLERANCE` of the object's size, it is still within its joint's range (with the
    floor as margin) and at rest at the end (slower than the drift floor per second). A hasp hanging
    against a box whose hull fills the staple's recess settles 8 mm out and stays there (``settled`` in
    the details); a part that moves farther than the overlap needs, opens it by less than half its depth
    (a sagging part with an overlap next to its axis), was never in one, or is pushed past
    its own stop (microwave 7263's buttons, 3.4 mm inside the panel's hulls at their outer stop and
    pushed 3.3 mm beyond it: the overlap fights the joint's limit) still drifts.
    """
    mujoco = mujoco_module()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    radius = {j.name: part_radius(model, data, model.joint(j.name).id) for j in joints}
    started_in = {j.name: rest_contacts(model, data, j.name) for j in joints}
    steps = int(round(seconds / model.opt.timestep))
    finite = True
    for _ in range(steps):
        mujoco.mj_step(model, data)
        if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
            finite = False
            break
    floor = REST_DRIFT_FLOOR * size
    drift, moved, settled, bad = {}, {}, {}, {}
    for joint in joints:
        jid = model.joint(joint.name).id
        span = (joint.upper - joint.lower) if joint.upper > joint.lower else 1.0
        value = float(data.qpos[model.jnt_qposadr[jid]])
        signed = value - joint.rest
        drift[joint.name] = abs(signed) / span
        moved[joint.name] = abs(signed) * radius[joint.name]
        if not (drift[joint.name] > REST_DRIFT_TOLERANCE and moved[joint.name] > floor):
            continue
        speed = abs(float(data.qvel[model.jnt_dofadr[jid]])) * radius[joint.name]
        out_of = [c for c in started_in[joint.name] if c.explains(signed, floor)]
        slack = floor / max(radius[joint.name], 1e-9)  # the floor in joint units
        in_range = joint.upper <= joint.lower or joint.lower - slack <= value <= joint.upper + slack
        if out_of and in_range and moved[joint.name] <= PENETRATION_TOLERANCE * size and speed <= floor:
            deepest = max(out_of, key=lambda c: c.depth)
            settled[joint.name] = {"depth": round(deepest.depth, 6), "pair": list(deepest.pair)}
        else:
            bad[joint.name] = drift[joint.name]
    worst = max(drift.values(), default=0.0) if finite else float("inf")
    warnings = _warnings(data)
    passed = finite and not warnings and not bad
    details = {"seconds": seconds, "drift": {k: round(v, 5) for k, v in drift.items()},
               "displacement": {k: round(v, 6) for k, v in moved.items()}, "warnings": warnings,
               "settled": settled}
    if not finite:
        details["reason"] = "NaN or infinite state"
    elif warnings:
        details["reason"] = f"MuJoCo warnings {warnings}"
    elif bad:
        name = max(bad, key=bad.get)
        details["reason"] = f"joint {name} drifted {drift[name]:.1%} of its range ({moved[name]:.4g} m) at rest"
    return CheckResult(passed, worst, details)


def check_rest_penetration(model, size: float, excluded: dict | None = None) -> CheckResult:
    """Deepest contact between collision geoms of different links at rest, as a fraction of ``size``."""
    mujoco = mujoco_module()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    deepest, pair = 0.0, None
    for contact in data.contact[: data.ncon]:
        if model.geom_bodyid[contact.geom1] == model.geom_bodyid[contact.geom2]:
            continue
        if -contact.dist > deepest:
            deepest = -float(contact.dist)
            pair = (model.geom(contact.geom1).name, model.geom(contact.geom2).name)
    value = deepest / size
    details = {"depth": deepest, "size": size, "deepest_pair": list(pair) if pair else None,
               "excluded_pairs": {f"{a}|{b}": round(d / size, 5) for (a, b), d in (excluded or {}).items()}}
    if value > PENETRATION_TOLERANCE:
        details["reason"] = f"{pair[0]} and {pair[1]} interpenetrate by {value:.2%} of the object's size at rest"
    return CheckResult(value <= PENETRATION_TOLERANCE, value, details)


def run_checks(src, options: ConvertOptions | None = None, render: Path | None = None,
               progress: bool = False) -> CheckReport:
    """Convert ``src`` (object folder, URDF or :class:`ArticulatedAsset`) and run every check; a
    ``model.xml`` written by :func:`spark_bench.sim.convert` is checked as it is.

    :param src: the object
    :param options: conversion options
    :param render: write the check strip (PNG) here
    :param progress: show conversion progress
    :raises InputError: when ``src`` cannot be read at all
    """
    from spark_bench.sim.mjcf import build_spec, prepare

    if not isinstance(src, ArticulatedAsset) and Path(src).suffix.lower() == ".xml":
        return run_model_checks(Path(src), render)
    clock = time.perf_counter()
    asset = load_source(src)
    report = CheckReport(asset.name, warnings=list(getattr(asset, "warnings", [])))
    seconds = report.seconds
    seconds["load"] = time.perf_counter() - clock
    report.checks["mesh_files"] = files = check_mesh_files(asset)
    if not files.passed:  # not converted: the asset as written cannot be simulated
        for name in MODEL_CHECKS:
            report.checks[name] = CheckResult(False, float("nan"), {
                "reason": "not converted: the URDF names mesh files that cannot be loaded (mesh_files)"})
        return report
    start = time.perf_counter()
    prepared = prepare(asset, options, progress=progress)
    prepared_at = time.perf_counter()
    convert_s = prepared_at - start
    seconds.update(prepared.report.seconds)
    seconds["coacd_cpu"] = prepared.report.coacd.coacd_cpu_s
    joints = swept_joints(asset)
    spec, model, report.checks["mjcf_compiles"] = _compile_check(asset, prepared, convert_s)
    seconds["compile"] = time.perf_counter() - prepared_at  # building the spec (visuals included) and compiling
    start = time.perf_counter()
    report.checks["pybullet_loads"] = _pybullet_check(asset, prepared)
    seconds["pybullet"] = time.perf_counter() - start
    if model is None:
        for name in ("mass_inertia", "rest_stability", "rest_penetration", "joint_sweep"):
            report.checks[name] = CheckResult(False, float("nan"), {"reason": "the MJCF does not compile"})
        return report
    start = time.perf_counter()
    _report_rest_force(report, model)
    report.checks["mass_inertia"] = check_mass_inertia(model)
    report.checks["rest_stability"] = check_rest_stability(model, joints, prepared.size)
    report.checks["rest_penetration"] = check_rest_penetration(model, prepared.size, prepared.excluded)
    seconds["rest"] = time.perf_counter() - start
    start = time.perf_counter()
    # the sweep adds actuators and compiles again: without the visual meshes, which do not take part
    bare = build_spec(asset, prepared=prepared, visuals=False)
    report.checks["joint_sweep"] = sweep = check_joint_sweep(bare, joints, prepared.size)
    if not sweep.passed:
        _explain_sweep(sweep, prepared, bare.compile())
    seconds["sweep"] = time.perf_counter() - start
    if render is not None:
        from spark_bench.sim.render import render_check_strip

        start = time.perf_counter()
        render_check_strip(spec, Path(render))
        seconds["render"] = time.perf_counter() - start
    seconds["total"] = time.perf_counter() - clock
    return report


def _compile_check(asset: ArticulatedAsset, prepared, convert_s: float) -> tuple[object, object, CheckResult]:
    """Build the object's MJCF spec and compile it: ``(spec, model, the mjcf_compiles check)``, spec and model
    None where it does not compile.

    :param asset: the object
    :param prepared: its prepared collision shapes (:func:`spark_bench.sim.mjcf.prepare`)
    :param convert_s: the seconds the preparation took (the check's details say them)
    """
    from spark_bench.sim.mjcf import build_spec

    try:
        spec = build_spec(asset, prepared=prepared)
        start = time.perf_counter()
        model = spec.compile()
        compile_s = time.perf_counter() - start
    except Exception as exc:  # MuJoCo reports compiler errors as ValueError; any failure is the verdict
        return None, None, CheckResult(False, float("nan"), {"reason": " ".join(str(exc).split())})
    return spec, model, CheckResult(True, compile_s, {
        "bodies": int(model.nbody - 1), "geoms": int(model.ngeom), "hulls": prepared.report.hulls,
        "hull_methods": prepared.report.methods, "coacd_calls": prepared.report.coacd.calls,
        "coacd_cache_hits": prepared.report.coacd.cache_hits, "coacd_turned": prepared.report.coacd.turned,
        "boxed": len(prepared.report.coacd.boxed), "convert_seconds": round(convert_s, 3),
        "relief": summarize_relief(prepared.relief), "excluded": sorted(f"{a}|{b}" for a, b in prepared.excluded),
        "rest_trim": summarize_trim(prepared.trim),
        "phantom_blocks": [b.to_dict() for b in prepared.phantom],
        "coacd_failures": prepared.report.coacd_failures})


def _report_rest_force(report: CheckReport, model) -> None:
    """Infinigen-Sim's rest-force check (:func:`~spark_bench.sim.rest_force.check_rest_force`) into the
    ``mjcf_compiles`` details as ``rest_force_infinigen``: reported, not a check of the verdict."""
    report.checks["mjcf_compiles"].details[REST_FORCE_CHECK] = check_rest_force(model).to_dict()


def _pybullet_check(asset: ArticulatedAsset, prepared) -> CheckResult:
    """The pybullet_loads check: PyBullet loads the object's collision URDF with the MJCF's joints and hulls.

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


def _explain_sweep(sweep: CheckResult, prepared, model) -> None:
    """Say, for every blocked joint, whether the object's surfaces or only its hulls block it
    (:func:`spark_bench.sim.phantom.explain_blocking`); the first one goes into the reason."""
    from spark_bench.sim.phantom import explain_blocking

    tolerance = 0.5 * prepared.options.clearance * prepared.size
    first = None
    for name, joint in sweep.details["joints"].items():
        if name not in sweep.details.get("failed", []) or not joint["blocked_by"] or not stopped_by_contact(joint):
            continue  # a part its contacts do not hold back: their surfaces are not the question
        block = joint["blocked_by"][0]
        if block.get("body") not in prepared.asset.links or block["blocked_by_body"] not in prepared.asset.links:
            continue
        joint["explanation"] = explain_blocking(prepared, model, name, block["body"], block["blocked_by_body"],
                                                tolerance)
        first = first or joint["explanation"]
    if first and "reason" in sweep.details:
        sweep.details["reason"] += f"; {first}"


def run_model_checks(xml: Path, render: Path | None = None) -> CheckReport:
    """The checks of an already converted ``model.xml`` (PyBullet: the ``model.urdf`` beside it).

    :raises InputError: when the file is missing or is not MJCF
    """
    from spark_bench.errors import InputError
    from spark_bench.sim.pybullet_io import load_in_pybullet
    from spark_bench.sim.render import model_bounds

    mujoco = mujoco_module()
    xml = Path(xml)
    if not xml.is_file():
        raise InputError(xml, "no such model file")
    try:
        spec = mujoco.MjSpec.from_file(str(xml))
    except ValueError as exc:
        raise InputError(xml, f"not a readable MJCF file: {exc}") from None
    report = CheckReport(spec.modelname or xml.parent.name)
    try:
        start = time.perf_counter()
        model = spec.compile()
    except ValueError as exc:
        report.checks["mjcf_compiles"] = CheckResult(False, float("nan"), {"reason": " ".join(str(exc).split())})
        return report
    report.checks["mjcf_compiles"] = CheckResult(True, time.perf_counter() - start,
                                                 {"bodies": int(model.nbody - 1), "geoms": int(model.ngeom)})
    _report_rest_force(report, model)
    joints = swept_joints_of_model(model)
    urdf = xml.with_suffix(".urdf")
    loaded = load_in_pybullet(urdf) if urdf.is_file() else None
    movable = sum(1 for j in range(model.njnt) if model.jnt_type[j] in (2, 3))
    if loaded is None or not loaded.loaded:
        reason = f"no {urdf.name} beside {xml.name}" if loaded is None else loaded.error
        report.checks["pybullet_loads"] = CheckResult(False, 0.0, {"reason": reason})
    else:
        hulls = {model.body(b).name: int(sum(1 for g in range(model.ngeom) if model.geom_bodyid[g] == b
                                             and model.geom_group[g] == 3)) for b in range(1, model.nbody)}
        same = all(loaded.collision_shapes.get(name, 0) == n for name, n in hulls.items() if n)
        details = {"collision_shapes": loaded.collision_shapes}
        if not same:
            details["reason"] = "PyBullet built other hulls than the MJCF"
        report.checks["pybullet_loads"] = CheckResult(same, float(loaded.n_joints), details)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = model_bounds(model, data)
    size = max(float(np.linalg.norm(hi - lo)), 1e-3)
    report.checks["mass_inertia"] = check_mass_inertia(model)
    report.checks["rest_stability"] = check_rest_stability(model, joints, size)
    report.checks["rest_penetration"] = check_rest_penetration(model, size)
    report.checks["joint_sweep"] = check_joint_sweep(spec, joints, size)
    report.checks["joint_sweep"].details["movable_joints"] = movable
    if render is not None:
        from spark_bench.sim.render import render_check_strip

        render_check_strip(spec, Path(render))
    return report
