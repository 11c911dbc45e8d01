"""The joint-sweep check: every movable joint driven through its range, out and back.

The sweep drives one joint at a time with a position actuator (the others held at rest by theirs) from
its lower to its upper limit in 1.5 s, holds 0.5 s, returns in 1.5 s and holds 0.5 s. Gravity on the
swept part is fed forward (as a motor's gravity compensation would) and the servo's force is limited
to a few times what friction and damping need, so a part blocked by geometry stays blocked instead of
being pushed through the soft contacts; the contacts of a blocked part name the geoms that stopped it.
The limit is never below the part's own weight (at its far edge, on a hinge): a light part's friction and
damping ask for millinewtons, and a servo that weak is stopped by a grazing contact that could not hold the
part in the world (a hand, or a robot, pushes at least that hard). A joint passes when it reaches
``SWEEP_REACH`` of its range out and back; a part that stops short is explained by the forces on its joint
where it stopped (:func:`spark_bench.sim.explain.stop_cause`): a contact only when it opposes the drive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.explain import stop_cause
from spark_bench.sim.relief import joint_bodies
from spark_bench.sim.results import CheckResult

SWEEP_REACH = 0.9
#: A joint also passes when it stops short of its limits by at most this fraction of the object's size
#: (the clearance the conversion leaves between parts): a toaster's 1 mm button stopped 0.1 mm early
#: has reached 89 % of its range, but nothing is wrong with it.
SWEEP_FLOOR = 0.001
RAMP_SECONDS, HOLD_SECONDS = 1.5, 0.5
#: Servo force limit, as a multiple of the force friction and damping need at the sweep speed.
FORCE_MARGIN = 5.0
#: The least servo force limit, as a multiple of the swept part's weight (times its reach from the axis on a
#: hinge: the weight held at its far edge). Measured on partnet_dev (benchmarks/results/sim_real.md): below it,
#: sweeps of light parts stopped on contacts of 1-8 mN.
MIN_DRIVE_WEIGHTS = 1.0
#: A servo raised to the weight floor keeps its natural frequency below this many radians per time step
#: (explicit integration of its damping is stable below 1).
MAX_SERVO_OMEGA_DT = 0.5


@dataclass
class SweptJoint:
    """A movable joint as the checks see it."""

    name: str
    rotational: bool
    lower: float
    upper: float
    rest: float


def swept_joints(asset: ArticulatedAsset) -> list[SweptJoint]:
    """The movable joints with the range each is swept over (a continuous joint: one full turn)."""
    return [SweptJoint(j.name, j.is_rotational, float(j.lower), float(j.upper), j.rest_value)
            for j in asset.movable_joints()]


def swept_joints_of_model(model) -> list[SweptJoint]:
    """Hinges and slides of a compiled model (``model.xml`` input): range, rest = ``qpos0``."""
    mujoco = mujoco_module()
    out = []
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        rest = float(model.qpos0[model.jnt_qposadr[j]])
        lower, upper = (float(v) for v in model.jnt_range[j]) if model.jnt_limited[j] else (rest, rest + 2 * math.pi)
        out.append(SweptJoint(model.joint(j).name, kind == int(mujoco.mjtJoint.mjJNT_HINGE), lower, upper, rest))
    return out


def add_sweep_actuators(spec, joints: list[SweptJoint]) -> None:
    """A position actuator ``sweep_<joint>`` on every movable joint (gains set later from the model)."""
    mujoco = mujoco_module()
    for joint in joints:
        act = spec.add_actuator(name=f"sweep_{joint.name}", target=joint.name)
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_position(kp=1.0, kv=0.0)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-1.0, 1.0]


def weight_drive(model, jid: int, radius: float) -> float:
    """The weight of everything joint ``jid`` moves, as a generalized force on it: N on a slide, N m on a
    hinge (held at the part's far edge).

    :param model: the compiled model
    :param jid: the joint's id
    :param radius: :func:`part_radius` of the joint (1 for a slide)
    """
    mass = float(sum(model.body_mass[b] for b in joint_bodies(model, jid)))
    return mass * float(np.linalg.norm(model.opt.gravity)) * radius


def servo_limits(need: float, weight: float, inertia: float, span: float, dt: float) -> tuple[float, float]:
    """A sweep servo's force limit and stiffness: :data:`FORCE_MARGIN` times what friction, damping and
    inertia ``need``, at least :data:`MIN_DRIVE_WEIGHTS` times the part's ``weight``; the stiffness saturates the
    servo 5 % of the ``span`` from its target, and where the weight floor raised the limit, no stiffer than
    :data:`MAX_SERVO_OMEGA_DT` allows at time step ``dt`` (or than it was without the floor).

    :returns: ``(force, kp)``
    """
    base = FORCE_MARGIN * need
    force = max(base, MIN_DRIVE_WEIGHTS * weight)
    kp = force / (0.05 * span)
    if force > base:  # a light part: the floor must not make its servo too stiff to integrate
        kp = min(kp, max(base / (0.05 * span), inertia * (MAX_SERVO_OMEGA_DT / dt) ** 2))
    return force, kp


def _tune_actuators(model, data, joints: list[SweptJoint], radii: dict[str, float]) -> None:
    """Servo gains per joint from the joint-space inertia, friction and damping at rest, and the part's weight
    (``radii``: each joint's :func:`part_radius`, the data already at rest)."""
    mujoco = mujoco_module()
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    for joint in joints:
        jid = model.joint(joint.name).id
        dof = model.jnt_dofadr[jid]
        inertia = float(full[dof, dof])
        span = max(joint.upper - joint.lower, 1e-6)
        speed = span / RAMP_SECONDS
        need = model.dof_frictionloss[dof] + model.dof_damping[dof] * speed + inertia * speed / 0.25
        force, kp = servo_limits(need, weight_drive(model, jid, radii[joint.name]), inertia, span, model.opt.timestep)
        kv = 2.0 * math.sqrt(kp * inertia)
        act = model.actuator(f"sweep_{joint.name}").id
        model.actuator_gainprm[act, 0] = kp
        model.actuator_biasprm[act, :3] = [0.0, -kp, -kv]
        model.actuator_forcerange[act] = [-force, force]


def _geom_name(model, geom: int) -> str:
    return model.geom(geom).name or f"geom{geom}"


def _blocking_contacts(model, data, moving_bodies: set[int], top: int = 3) -> list[dict]:
    """The strongest contacts between the moving part and anything else: which geoms blocked it."""
    mujoco = mujoco_module()
    found: dict[tuple[int, int], float] = {}
    depth: dict[tuple[int, int], float] = {}
    force = np.zeros(6)
    for index, contact in enumerate(data.contact[: data.ncon]):
        b1, b2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
        if (b1 in moving_bodies) == (b2 in moving_bodies):
            continue
        mujoco.mj_contactForce(model, data, index, force)
        key = (contact.geom1, contact.geom2) if b1 in moving_bodies else (contact.geom2, contact.geom1)
        found[key] = max(found.get(key, 0.0), float(abs(force[0])))
        depth[key] = max(depth.get(key, 0.0), -float(contact.dist))
    ranked = sorted(found.items(), key=lambda kv: -kv[1])[:top]
    return [{"geom": _geom_name(model, a), "blocked_by": _geom_name(model, b), "force": round(f, 3),
             "depth": round(depth[(a, b)], 6), "body": model.body(model.geom_bodyid[a]).name,
             "blocked_by_body": model.body(model.geom_bodyid[b]).name} for (a, b), f in ranked]


def _run_schedule(model, data, acts: dict[str, int], targets: dict[str, list[float]], watch: int,
                  swept_dof: int) -> tuple[float, float]:
    """Step through per-actuator target lists (equal lengths); returns max and min of ``qpos[watch]``."""
    mujoco = mujoco_module()
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
    mujoco = mujoco_module()
    joint = joints[index]
    jid = model.joint(joint.name).id
    qadr, dof = model.jnt_qposadr[jid], model.jnt_dofadr[jid]
    moving = joint_bodies(model, jid)
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
    stopped_by = stop_cause(model, data, joint.name, f"sweep_{joint.name}") if reach < 0.98 else None
    back = dict(held)
    back[joint.name] = _ramp(joint.upper, joint.lower, ramp, hold)
    _, lowest = _run_schedule(model, data, acts, back, qadr, dof)
    returned = (reached - lowest) / (reached - joint.lower) if reached > joint.lower + 1e-12 else 1.0
    stopped_back_by = stop_cause(model, data, joint.name, f"sweep_{joint.name}") if returned < 0.98 else None
    result = {"reached": round(float(np.clip(reach, 0, 1)), 4), "returned": round(float(np.clip(returned, 0, 1)), 4),
              "finite": bool(np.all(np.isfinite(data.qpos))), "blocked_by": blocked, "opened_first": list(open_first)}
    if stopped_by is not None:
        result["stopped_by"] = stopped_by
    if stopped_back_by is not None:
        result["stopped_back_by"] = stopped_back_by
    return result


def _with_shortfall(result: dict, full: float) -> dict:
    """``result`` with ``shortfall``: how far (m, at the part's far edge) it stopped short, out or back."""
    result["shortfall"] = round((1.0 - min(result["reached"], result["returned"])) * full, 6)
    return result


def _owner_joint(model, body_name: str, names: set[str]) -> str | None:
    """The swept joint that moves body ``body_name`` (None for the fixed base)."""
    body = int(model.body(body_name).id)
    while body > 0:
        for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
            if model.joint(j).name in names:
                return model.joint(j).name
        body = int(model.body_parentid[body])
    return None


def part_radius(model, data, jid: int) -> float:
    """How far the part of a hinge reaches from its axis (1 for a slide: its motion is a distance).

    The farthest vertex of the part's meshes (visual and collision) from the axis line; a primitive
    geom counts with its bounding sphere. (A mesh's bounding sphere, centred on the geom's frame, can
    reach half as far again as the mesh: an 18 g hasp 0.116 m long measured 0.149 m.)
    """
    if model.jnt_type[jid] != 3:  # mjJNT_HINGE
        return 1.0
    moving = joint_bodies(model, jid)
    anchor, axis = data.xanchor[jid], data.xaxis[jid]
    best = 0.0
    for g in range(model.ngeom):
        if int(model.geom_bodyid[g]) not in moving:
            continue
        mesh = int(model.geom_dataid[g]) if model.geom_type[g] == 7 else -1  # mjGEOM_MESH
        if mesh >= 0:
            start = model.mesh_vertadr[mesh]
            local = model.mesh_vert[start:start + model.mesh_vertnum[mesh]]
            d = local @ data.geom_xmat[g].reshape(3, 3).T + (data.geom_xpos[g] - anchor)
            best = max(best, float(np.max(np.linalg.norm(d - np.outer(d @ axis, axis), axis=1), initial=0.0)))
        else:
            d = data.geom_xpos[g] - anchor
            best = max(best, float(np.linalg.norm(d - np.dot(d, axis) * axis)) + float(model.geom_rbound[g]))
    return best


def _sweep_passed(result: dict, floor: float = 0.0) -> bool:
    """Reached and returned :data:`SWEEP_REACH` of the range, or fell short by at most ``floor`` (m)."""
    reach = min(result["reached"], result["returned"])
    return result["finite"] and (reach >= SWEEP_REACH or result.get("shortfall", np.inf) <= floor)


def check_joint_sweep(spec, joints: list[SweptJoint], size: float = 0.0) -> CheckResult:
    """Sweep every movable joint, the others held at rest; a joint blocked by another movable part
    (a rack behind a closed oven door) is swept again with those parts opened first, as a person
    would. Value = smallest fraction of a range reached or returned (1.0 with no movable joint).

    :param spec: the object's spec (not modified)
    :param joints: the joints to sweep
    :param size: the object's size (m); a joint that stops short of its limits by at most
        :data:`SWEEP_FLOOR` of it passes (its ``shortfall``, in metres at the part's far edge)
    """
    mujoco = mujoco_module()
    check_spec = spec.copy()
    add_sweep_actuators(check_spec, joints)
    model = check_spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    radii = {j.name: part_radius(model, data, model.joint(j.name).id) for j in joints}
    _tune_actuators(model, data, joints, radii)
    reach_m = {j.name: (j.upper - j.lower) * radii[j.name] for j in joints}
    floor = SWEEP_FLOOR * size
    names = {j.name for j in joints}
    results = {}
    for index, joint in enumerate(joints):
        if joint.upper - joint.lower < 1e-9:  # nothing to sweep (a joint locked by its limits)
            results[joint.name] = {"reached": 1.0, "returned": 1.0, "finite": True, "blocked_by": [],
                                   "opened_first": [], "zero_range": True}
            continue
        result = _with_shortfall(sweep_joint(model, data, joints, index), reach_m[joint.name])
        blockers = tuple(sorted({o for b in result["blocked_by"]
                                 if (o := _owner_joint(model, b["blocked_by_body"], names)) not in (None, joint.name)}))
        if not _sweep_passed(result, floor) and blockers:
            retry = _with_shortfall(sweep_joint(model, data, joints, index, open_first=blockers), reach_m[joint.name])
            if _sweep_passed(retry, floor) or retry["reached"] > result["reached"]:
                retry["blocked_at_rest_by"] = result["blocked_by"]
                result = retry
        results[joint.name] = result
    worst = min((min(r["reached"], r["returned"]) for r in results.values()), default=1.0)
    failed = {k: r for k, r in results.items() if not _sweep_passed(r, floor)}
    details = {"joints": results, "failed": list(failed), "floor": round(floor, 6)}
    if failed:
        name, r = next(iter(failed.items()))
        details["reason"] = _failure_reason(name, r, joints)
    return CheckResult(not failed, worst, details)


def stopped_by_contact(result: dict) -> bool:
    """Whether a swept joint's stop (out, else back) is explained by contacts (or was not explained: an
    older result)."""
    cause = result.get("stopped_by") or result.get("stopped_back_by")
    return cause is None or cause["cause"] == "contact"


def _failure_reason(name: str, r: dict, joints: list[SweptJoint]) -> str:
    """One line for a joint that failed the sweep: how far it went, and what stopped it."""
    head = f"joint {name} reached {r['reached']:.0%} and returned {r['returned']:.0%} of its range"
    if not stopped_by_contact(r):
        cause = r.get("stopped_by") or r.get("stopped_back_by")
        return f"{head} (not blocked by a contact: {cause['text']})"
    what = ", ".join(f"{b['geom']} by {b['blocked_by']}" for b in r["blocked_by"]) or "no contact"
    if r["blocked_by"]:
        first = r["blocked_by"][0]
        joint = next(j for j in joints if j.name == name)
        at = joint.lower + r["reached"] * (joint.upper - joint.lower)
        where = f"{np.degrees(at):.0f} deg" if joint.rotational else f"{1000 * at:.0f} mm"
        deep = 1000 * first.get("depth", 0.0)
        what = (f"{first.get('body', '?')} runs into {first['blocked_by_body']} at {where}"
                + (f", {deep:.1f} mm deep" if deep >= 0.1 else "") + f": {what}")
    return f"{head} (blocked: {what})"

