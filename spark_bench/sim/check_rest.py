"""The rest checks: ``rest_stability`` (gravity on, joints free: nothing drifts) and ``rest_penetration`` (no two
bodies deep inside each other at rest), with the tolerances the PhysX checks share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.relief import joint_bodies
from spark_bench.sim.results import CheckResult
from spark_bench.sim.sweep import SweptJoint, part_radius

REST_SECONDS = 2.0
REST_DRIFT_TOLERANCE = 0.02
REST_DRIFT_FLOOR = 0.001
PENETRATION_TOLERANCE = 0.005


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


def rest_stability(inputs: CheckInputs) -> CheckResult:
    """The ``rest_stability`` check of a run (:func:`check_rest_stability` on its compiled model)."""
    return check_rest_stability(inputs.model, inputs.joints, inputs.size)


def rest_penetration(inputs: CheckInputs) -> CheckResult:
    """The ``rest_penetration`` check of a run (:func:`check_rest_penetration` on its compiled model; the pairs the
    converter excluded listed, where it was converted here)."""
    return check_rest_penetration(inputs.model, inputs.size, inputs.excluded)
