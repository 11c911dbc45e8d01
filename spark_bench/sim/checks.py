"""Sim-readiness checks: each a number and a pass/fail.

=====================  ========================================================  =====================
check                  value                                                     passes when
=====================  ========================================================  =====================
``mjcf_compiles``      seconds to compile the MJCF                               MuJoCo compiles it
``pybullet_loads``     joints PyBullet built                                     same joints and hulls
``mass_inertia``       smallest mass of a moving body (kg)                       all > 0, inertia valid
``rest_stability``     largest joint drift after 2 s, fraction of its range      finite, no warning,
                                                                                 drift <= 2 % (or the
                                                                                 part moved < 0.1 % of
                                                                                 the object's size)
``rest_penetration``   deepest contact between two links at rest / object size   <= 0.5 %
``joint_sweep``        smallest fraction of a joint's range reached              >= 90 % out and back
=====================  ========================================================  =====================

The sweep drives one joint at a time with a position actuator (the others held at rest by theirs) from
its lower to its upper limit in 1.5 s, holds 0.5 s, returns in 1.5 s and holds 0.5 s. Gravity on the
swept part is fed forward (as a motor's gravity compensation would) and the servo's force is limited
to a few times what friction and damping need, so a part blocked by geometry stays blocked instead of
being pushed through the soft contacts; the contacts of a blocked part name the geoms that stopped it.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.options import ConvertOptions

REST_SECONDS = 2.0
REST_DRIFT_TOLERANCE = 0.02
REST_DRIFT_FLOOR = 0.001
PENETRATION_TOLERANCE = 0.005
SWEEP_REACH = 0.9
RAMP_SECONDS, HOLD_SECONDS = 1.5, 0.5
#: Servo force limit, as a multiple of the force friction and damping need at the sweep speed.
FORCE_MARGIN = 5.0


@dataclass
class CheckResult:
    """One check: whether it passed, its number, and details (JSON-able)."""

    passed: bool
    value: float
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        value = float(self.value) if math.isfinite(self.value) else None
        return {"passed": bool(self.passed), "value": value, **self.details}


@dataclass
class CheckReport:
    """All checks of one object. ``to_dict()`` is the ``spark-bench check --json`` output."""

    name: str
    checks: dict[str, CheckResult] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks.values())

    def to_dict(self) -> dict:
        return {"passed": self.passed, "checks": {k: v.to_dict() for k, v in self.checks.items()}}

    def failures(self) -> list[str]:
        """One line per failed check, with its reason where known."""
        return [f"{k}: {v.details.get('reason', 'failed')} (value {v.value:.4g})"
                for k, v in self.checks.items() if not v.passed]


@dataclass
class SweptJoint:
    """A movable joint as the checks see it."""

    name: str
    rotational: bool
    lower: float
    upper: float
    rest: float


def _mujoco():
    import os

    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    return mujoco


def swept_joints(asset: ArticulatedAsset) -> list[SweptJoint]:
    """The movable joints with the range each is swept over (a continuous joint: one full turn)."""
    return [SweptJoint(j.name, j.is_rotational, float(j.lower), float(j.upper), j.rest_value)
            for j in asset.movable_joints()]


# ----- individual checks --------------------------------------------------------------------------
def check_mass_inertia(model) -> CheckResult:
    """Every body with a degree of freedom has positive mass and principal moments that satisfy the
    triangle inequality (MuJoCo's own test, with its tolerance)."""
    moving = [b for b in range(1, model.nbody) if model.body_dofnum[b] > 0 or model.body_weldid[b] != 0]
    bad = []
    for b in moving:
        a, bb, c = np.sort(model.body_inertia[b])
        if not (model.body_mass[b] > 0 and a > 0 and a + bb >= c * (1 - 1e-6)):
            bad.append(model.body(b).name)
    smallest = float(min((model.body_mass[b] for b in moving), default=float("nan")))
    details = {"moving_bodies": len(moving)}
    if bad:
        details["reason"] = f"invalid mass or inertia: {bad}"
    return CheckResult(not bad, smallest, details)


def _warnings(data) -> dict[str, int]:
    mujoco = _mujoco()
    out = {}
    for member in ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_CONTACTFULL",
                   "mjWARN_CNSTRFULL", "mjWARN_INERTIA"):
        count = int(data.warning[int(getattr(mujoco.mjtWarning, member))].number)
        if count:
            out[member[len("mjWARN_"):].lower()] = count
    return out


def _part_radius(model, data, jid: int) -> float:
    """How far the part of a hinge reaches from its axis (1 for a slide: its drift is a distance)."""
    if model.jnt_type[jid] != 3:  # mjJNT_HINGE
        return 1.0
    body = model.jnt_bodyid[jid]
    anchor, axis = data.xanchor[jid], data.xaxis[jid]
    best = 0.0
    for g in range(model.ngeom):
        b = model.geom_bodyid[g]
        while b > 0 and b != body:
            b = model.body_parentid[b]
        if b == body:
            d = data.geom_xpos[g] - anchor
            best = max(best, float(np.linalg.norm(d - np.dot(d, axis) * axis)) + float(model.geom_rbound[g]))
    return best


def check_rest_stability(model, joints: list[SweptJoint], size: float, seconds: float = REST_SECONDS) -> CheckResult:
    """Gravity on, every joint free with its damping, from rest: no NaN, no warning, small drift.

    Drift is the joint's displacement as a fraction of its range; a joint passes when that is at most
    :data:`REST_DRIFT_TOLERANCE`, or when its part moved less than :data:`REST_DRIFT_FLOOR` of the
    object's size (a camera button's 0.2 mm is 2 % of its 8 mm travel, but nothing moved).
    """
    mujoco = _mujoco()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    radius = {j.name: _part_radius(model, data, model.joint(j.name).id) for j in joints}
    steps = int(round(seconds / model.opt.timestep))
    finite = True
    for _ in range(steps):
        mujoco.mj_step(model, data)
        if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
            finite = False
            break
    drift, moved = {}, {}
    for joint in joints:
        jid = model.joint(joint.name).id
        span = (joint.upper - joint.lower) if joint.upper > joint.lower else 1.0
        delta = abs(float(data.qpos[model.jnt_qposadr[jid]]) - joint.rest)
        drift[joint.name] = delta / span
        moved[joint.name] = delta * radius[joint.name]
    bad = {k: v for k, v in drift.items() if v > REST_DRIFT_TOLERANCE and moved[k] > REST_DRIFT_FLOOR * size}
    worst = max(drift.values(), default=0.0) if finite else float("inf")
    warnings = _warnings(data)
    passed = finite and not warnings and not bad
    details = {"seconds": seconds, "drift": {k: round(v, 5) for k, v in drift.items()},
               "displacement": {k: round(v, 6) for k, v in moved.items()}, "warnings": warnings}
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
    mujoco = _mujoco()
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


def add_sweep_actuators(spec, joints: list[SweptJoint]) -> None:
    """A position actuator ``sweep_<joint>`` on every movable joint (gains set later from the model)."""
    mujoco = _mujoco()
    for joint in joints:
        act = spec.add_actuator(name=f"sweep_{joint.name}", target=joint.name)
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_position(kp=1.0, kv=0.0)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-1.0, 1.0]


def _tune_actuators(model, data, joints: list[SweptJoint]) -> None:
    """Servo gains per joint from the joint-space inertia, friction and damping at rest."""
    mujoco = _mujoco()
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    for joint in joints:
        jid = model.joint(joint.name).id
        dof = model.jnt_dofadr[jid]
        inertia = float(full[dof, dof])
        span = max(joint.upper - joint.lower, 1e-6)
        speed = span / RAMP_SECONDS
        need = model.dof_frictionloss[dof] + model.dof_damping[dof] * speed + inertia * speed / 0.25
        force = FORCE_MARGIN * need
        kp = force / (0.05 * span)
        kv = 2.0 * math.sqrt(kp * inertia)
        act = model.actuator(f"sweep_{joint.name}").id
        model.actuator_gainprm[act, 0] = kp
        model.actuator_biasprm[act, :3] = [0.0, -kp, -kv]
        model.actuator_forcerange[act] = [-force, force]


def _geom_name(model, geom: int) -> str:
    return model.geom(geom).name or f"geom{geom}"


def _blocking_contacts(model, data, moving_bodies: set[int], top: int = 3) -> list[dict]:
    """The strongest contacts between the moving part and anything else: which geoms blocked it."""
    mujoco = _mujoco()
    found: dict[tuple[int, int], float] = {}
    force = np.zeros(6)
    for index, contact in enumerate(data.contact[: data.ncon]):
        b1, b2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
        if (b1 in moving_bodies) == (b2 in moving_bodies):
            continue
        mujoco.mj_contactForce(model, data, index, force)
        key = (contact.geom1, contact.geom2) if b1 in moving_bodies else (contact.geom2, contact.geom1)
        found[key] = max(found.get(key, 0.0), float(abs(force[0])))
    ranked = sorted(found.items(), key=lambda kv: -kv[1])[:top]
    return [{"geom": _geom_name(model, a), "blocked_by": _geom_name(model, b), "force": round(f, 3),
             "blocked_by_body": model.body(model.geom_bodyid[b]).name} for (a, b), f in ranked]


def _run_schedule(model, data, acts: dict[str, int], targets: dict[str, list[float]], watch: int,
                  swept_dof: int) -> tuple[float, float]:
    """Step through per-actuator target lists (equal lengths); returns max and min of ``qpos[watch]``."""
    mujoco = _mujoco()
    steps = len(next(iter(targets.values())))
    high, low = -np.inf, np.inf
    for k in range(steps):
        for name, values in targets.items():
            data.ctrl[acts[name]] = values[k]
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[swept_dof] = data.qfrc_bias[swept_dof]  # gravity (and Coriolis) feed-forward
        mujoco.mj_step(model, data)
        high, low = max(high, float(data.qpos[watch])), min(low, float(data.qpos[watch]))
    return high, low


def _ramp(start: float, end: float, steps: int, hold: int) -> list[float]:
    return [start + (end - start) * min(1.0, (k + 1) / steps) for k in range(steps)] + [end] * hold


def sweep_joint(model, data, joints: list[SweptJoint], index: int, open_first: tuple[str, ...] = ()) -> dict:
    """Drive ``joints[index]`` out and back (after opening the joints named in ``open_first``);
    returns the fraction of the range reached and returned, and the contacts of a blocked part."""
    mujoco = _mujoco()
    joint = joints[index]
    jid = model.joint(joint.name).id
    qadr, dof = model.jnt_qposadr[jid], model.jnt_dofadr[jid]
    moving = {b for b in range(model.nbody) if _is_descendant(model, b, model.jnt_bodyid[jid])}
    acts = {j.name: model.actuator(f"sweep_{j.name}").id for j in joints}
    by_name = {j.name: j for j in joints}
    dt = model.opt.timestep
    ramp, hold = int(RAMP_SECONDS / dt), int(HOLD_SECONDS / dt)
    mujoco.mj_resetData(model, data)
    held = {j.name: [j.rest] * (ramp + hold) for j in joints}
    if open_first:
        targets = dict(held)
        targets.update({n: _ramp(by_name[n].rest, by_name[n].upper, ramp, hold) for n in open_first})
        _run_schedule(model, data, acts, targets, qadr, dof)
        held.update({n: [by_name[n].upper] * (ramp + hold) for n in open_first})
    span = joint.upper - joint.lower
    out = dict(held)
    out[joint.name] = _ramp(joint.lower, joint.upper, ramp, hold)
    reached, _ = _run_schedule(model, data, acts, out, qadr, dof)
    reach = (reached - joint.lower) / span if span > 0 else 1.0
    blocked = _blocking_contacts(model, data, moving) if reach < 0.98 else []
    back = dict(held)
    back[joint.name] = _ramp(joint.upper, joint.lower, ramp, hold)
    _, lowest = _run_schedule(model, data, acts, back, qadr, dof)
    returned = (reached - lowest) / (reached - joint.lower) if reached > joint.lower + 1e-12 else 1.0
    return {"reached": round(float(np.clip(reach, 0, 1)), 4), "returned": round(float(np.clip(returned, 0, 1)), 4),
            "finite": bool(np.all(np.isfinite(data.qpos))), "blocked_by": blocked, "opened_first": list(open_first)}


def _is_descendant(model, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = model.body_parentid[body]
    return ancestor == 0


def _owner_joint(model, body_name: str, names: set[str]) -> str | None:
    """The swept joint that moves body ``body_name`` (None for the fixed base)."""
    body = int(model.body(body_name).id)
    while body > 0:
        for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
            if model.joint(j).name in names:
                return model.joint(j).name
        body = int(model.body_parentid[body])
    return None


def _sweep_passed(result: dict) -> bool:
    return result["reached"] >= SWEEP_REACH and result["returned"] >= SWEEP_REACH and result["finite"]


def check_joint_sweep(spec, joints: list[SweptJoint]) -> CheckResult:
    """Sweep every movable joint, the others held at rest; a joint blocked by another movable part
    (a rack behind a closed oven door) is swept again with those parts opened first, as a person
    would. Value = smallest fraction of a range reached or returned (1.0 with no movable joint)."""
    mujoco = _mujoco()
    check_spec = spec.copy()
    add_sweep_actuators(check_spec, joints)
    model = check_spec.compile()
    data = mujoco.MjData(model)
    _tune_actuators(model, data, joints)
    names = {j.name for j in joints}
    results = {}
    for index, joint in enumerate(joints):
        if joint.upper - joint.lower < 1e-9:  # nothing to sweep (a joint locked by its limits)
            results[joint.name] = {"reached": 1.0, "returned": 1.0, "finite": True, "blocked_by": [],
                                   "opened_first": [], "zero_range": True}
            continue
        result = sweep_joint(model, data, joints, index)
        blockers = tuple(sorted({o for b in result["blocked_by"]
                                 if (o := _owner_joint(model, b["blocked_by_body"], names)) not in (None, joint.name)}))
        if not _sweep_passed(result) and blockers:
            retry = sweep_joint(model, data, joints, index, open_first=blockers)
            if _sweep_passed(retry) or retry["reached"] > result["reached"]:
                retry["blocked_at_rest_by"] = result["blocked_by"]
                result = retry
        results[joint.name] = result
    worst = min((min(r["reached"], r["returned"]) for r in results.values()), default=1.0)
    failed = {k: r for k, r in results.items() if not _sweep_passed(r)}
    details = {"joints": results}
    if failed:
        name, r = next(iter(failed.items()))
        what = ", ".join(f"{b['geom']} by {b['blocked_by']}" for b in r["blocked_by"]) or "no contact"
        details["reason"] = (f"joint {name} reached {r['reached']:.0%} and returned {r['returned']:.0%} "
                             f"of its range (blocked: {what})")
    return CheckResult(not failed, worst, details)


# ----- the whole report ---------------------------------------------------------------------------
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
    from spark_bench.sim.pybullet_io import load_in_pybullet, write_pybullet_urdf

    if not isinstance(src, ArticulatedAsset) and Path(src).suffix.lower() == ".xml":
        return run_model_checks(Path(src), render)
    asset = src if isinstance(src, ArticulatedAsset) else _load(src)
    report = CheckReport(asset.name)
    start = time.perf_counter()
    prepared = prepare(asset, options, progress=progress)
    convert_s = time.perf_counter() - start
    joints = swept_joints(asset)
    try:
        spec = build_spec(asset, prepared=prepared)
        start = time.perf_counter()
        model = spec.compile()
        compile_s = time.perf_counter() - start
    except Exception as exc:  # MuJoCo reports compiler errors as ValueError; any failure is the verdict
        report.checks["mjcf_compiles"] = CheckResult(False, float("nan"), {"reason": " ".join(str(exc).split())})
        spec = model = None
    else:
        report.checks["mjcf_compiles"] = CheckResult(True, compile_s, {
            "bodies": int(model.nbody - 1), "geoms": int(model.ngeom), "hulls": prepared.report.hulls,
            "hull_methods": prepared.report.methods, "coacd_calls": prepared.report.coacd.calls,
            "coacd_cache_hits": prepared.report.coacd.cache_hits, "convert_seconds": round(convert_s, 3),
            "relief": summarize_relief(prepared.relief), "excluded": sorted(f"{a}|{b}" for a, b in prepared.excluded)})
    with tempfile.TemporaryDirectory(prefix="spark_pybullet_") as tmp:
        loaded = load_in_pybullet(write_pybullet_urdf(prepared, Path(tmp)))
    expected = {name: len(s) for name, s in prepared.shapes.items()}
    same = loaded.loaded and loaded.n_joints == len(asset.joints) and all(
        loaded.collision_shapes.get(name, 0) == n for name, n in expected.items() if n)
    details = {"collision_shapes": loaded.collision_shapes}
    if not same:
        details["reason"] = loaded.error or "PyBullet built other joints or hulls than the MJCF"
    report.checks["pybullet_loads"] = CheckResult(same, float(loaded.n_joints), details)
    if model is None:
        for name in ("mass_inertia", "rest_stability", "rest_penetration", "joint_sweep"):
            report.checks[name] = CheckResult(False, float("nan"), {"reason": "the MJCF does not compile"})
        return report
    report.checks["mass_inertia"] = check_mass_inertia(model)
    report.checks["rest_stability"] = check_rest_stability(model, joints, prepared.size)
    report.checks["rest_penetration"] = check_rest_penetration(model, prepared.size, prepared.excluded)
    report.checks["joint_sweep"] = check_joint_sweep(spec, joints)
    if render is not None:
        from spark_bench.sim.render import render_check_strip

        render_check_strip(spec, Path(render))
    return report


def swept_joints_of_model(model) -> list[SweptJoint]:
    """Hinges and slides of a compiled model (``model.xml`` input): range, rest = ``qpos0``."""
    mujoco = _mujoco()
    out = []
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        rest = float(model.qpos0[model.jnt_qposadr[j]])
        lower, upper = (float(v) for v in model.jnt_range[j]) if model.jnt_limited[j] else (rest, rest + 2 * math.pi)
        out.append(SweptJoint(model.joint(j).name, kind == int(mujoco.mjtJoint.mjJNT_HINGE), lower, upper, rest))
    return out


def run_model_checks(xml: Path, render: Path | None = None) -> CheckReport:
    """The checks of an already converted ``model.xml`` (PyBullet: the ``model.urdf`` beside it).

    :raises InputError: when the file is missing or is not MJCF
    """
    from spark_bench.errors import InputError
    from spark_bench.sim.pybullet_io import load_in_pybullet
    from spark_bench.sim.render import model_bounds

    mujoco = _mujoco()
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
    report.checks["joint_sweep"] = check_joint_sweep(spec, joints)
    report.checks["joint_sweep"].details["movable_joints"] = movable
    if render is not None:
        from spark_bench.sim.render import render_check_strip

        render_check_strip(spec, Path(render))
    return report


def summarize_relief(cuts) -> dict:
    """Hinge-relief cuts per joint: the hulls bevelled, the deepest penetration removed (m)."""
    out: dict[str, dict] = {}
    for cut in cuts:
        entry = out.setdefault(cut.joint, {"geoms": [], "cuts": 0, "max_depth": 0.0})
        if cut.geom not in entry["geoms"]:
            entry["geoms"].append(cut.geom)
        entry["cuts"] += 1
        entry["max_depth"] = round(max(entry["max_depth"], cut.depth), 5)
    return out


def _load(src) -> ArticulatedAsset:
    from spark_bench.data import load_object

    return load_object(Path(src))
