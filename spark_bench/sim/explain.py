"""Why a swept part stopped short: the forces on its joint where it stopped, by where they come from.

The joint sweep (:mod:`spark_bench.sim.sweep`) drives a part with a force-limited servo; a part that stops
short of its range is held there by something. The contacts at the stop are not always it: a contact of a
few millinewtons cannot hold a part its servo pushes with a newton. So the explanation is read off the
generalized forces on the joint at the stop (MuJoCo's own decomposition: the actuator's force, the passive
springs and damping, and the constraint forces by constraint type, mapped to the joint through their
Jacobians): the drive, and each force that opposes it. The largest opposing one is the cause:

- ``contact``: the part runs into another (the contacts' share, with the geoms that carry it);
- ``joint friction``: the joint's own friction (URDF ``<dynamics friction>``) holds what the drive can give;
- ``joint limit``: a limit of the joint, or of another joint the part hangs on;
- ``spring``: a joint spring (stiffness) pulls it back;
- ``coupling``: an equality constraint (a mimic joint) holds it;
- ``drive too weak``: nothing above opposes it as much as the drive's own limit: the servo is at its force
  limit and the part's weight or inertia (what the gravity feed-forward leaves) takes it.

A contact explains the stop only when its share is at least :data:`CONTACT_SHARE` of the drive's force.
"""

from __future__ import annotations

import numpy as np

from spark_bench.mujoco_gl import mujoco_module

#: The least share of the drive's force the contacts must oppose to be the cause of a stop.
CONTACT_SHARE = 0.5
#: A servo at this fraction of its force limit is saturated.
SATURATED = 0.98


def _constraint_groups() -> dict[str, tuple[int, ...]]:
    """MuJoCo's constraint types (``mjtConstraint``) by the cause they stand for."""
    kinds = mujoco_module().mjtConstraint
    return {
        "coupling": (int(kinds.mjCNSTR_EQUALITY),),
        "joint friction": (int(kinds.mjCNSTR_FRICTION_DOF), int(kinds.mjCNSTR_FRICTION_TENDON)),
        "joint limit": (int(kinds.mjCNSTR_LIMIT_JOINT), int(kinds.mjCNSTR_LIMIT_TENDON)),
        "contact": (int(kinds.mjCNSTR_CONTACT_FRICTIONLESS), int(kinds.mjCNSTR_CONTACT_PYRAMIDAL),
                    int(kinds.mjCNSTR_CONTACT_ELLIPTIC)),
    }


def joint_forces(model, data, dof: int) -> dict[str, float]:
    """The generalized forces on ``dof`` at ``data``'s state (after a step), by source: ``drive`` (the
    actuators), ``spring`` and ``damping`` (passive), ``gravity and inertia`` (what the applied feed-forward
    leaves of the bias force), and each constraint group of :func:`_constraint_groups`.

    :param model: the compiled model
    :param data: its data, after ``mj_step`` (the constraint forces of that step)
    :param dof: the joint's degree of freedom
    """
    mujoco = mujoco_module()
    out = {"drive": float(data.qfrc_actuator[dof])}
    damping = -float(model.dof_damping[dof]) * float(data.qvel[dof])
    out["damping"] = damping
    out["spring"] = float(data.qfrc_passive[dof]) - damping
    out["gravity and inertia"] = float(data.qfrc_applied[dof]) - float(data.qfrc_bias[dof])
    types = np.asarray(data.efc_type[: data.nefc])
    forces = np.asarray(data.efc_force[: data.nefc])
    mapped = np.zeros(model.nv)
    for cause, members in _constraint_groups().items():
        mask = np.isin(types, members)
        if not mask.any():
            out[cause] = 0.0
            continue
        mujoco.mj_mulJacTVec(model, data, mapped, np.where(mask, forces, 0.0))
        out[cause] = float(mapped[dof])
    return out


def stop_cause(model, data, joint: str, actuator: str) -> dict:
    """What holds joint ``joint`` where it stopped: the cause (see the module), the drive's force, whether
    its servo is saturated, each opposing force (generalized: N for a slide, N m for a hinge) and one
    sentence for the check's reason.

    :param model: the compiled model
    :param data: its data at the stop, after a step
    :param joint: the swept joint's name
    :param actuator: the name of the servo that drives it
    """
    dof = int(model.jnt_dofadr[model.joint(joint).id])
    act = model.actuator(actuator).id
    forces = joint_forces(model, data, dof)
    drive = forces.pop("drive")
    direction = np.sign(drive) or 1.0
    opposing = {k: round(float(-direction * v), 6) for k, v in forces.items() if -direction * v > 1e-9}
    limit = float(np.max(np.abs(model.actuator_forcerange[act]))) if model.actuator_forcelimited[act] else np.inf
    saturated = bool(abs(float(data.actuator_force[act])) >= SATURATED * limit)
    unit = "N" if int(model.jnt_type[model.joint(joint).id]) == int(mujoco_module().mjtJoint.mjJNT_SLIDE) else "N m"
    others = {k: v for k, v in opposing.items() if k != "contact"}
    strongest = max(others, key=others.get, default=None)
    if abs(drive) > 0 and opposing.get("contact", 0.0) >= CONTACT_SHARE * abs(drive):
        cause = "contact"
    elif strongest in ("joint friction", "joint limit", "spring", "coupling"):
        cause = strongest
    else:  # only the part's weight, inertia or damping against a drive that gives no more
        cause = "drive too weak"
    held = opposing.get(cause, opposing.get("gravity and inertia", 0.0))
    text = (f"held by {cause} ({held:.3g} {unit} against a drive of {abs(drive):.3g} {unit}"
            + (", the servo at its force limit" if saturated else "") + ")")
    if cause == "drive too weak":
        text = (f"the drive is too weak for the part: its servo gives {abs(drive):.3g} {unit}"
                + (" (its force limit)" if saturated else "") + f", contacts oppose {opposing.get('contact', 0.0):.3g}")
    return {"cause": cause, "drive": round(abs(drive), 6), "saturated": saturated, "opposing": opposing,
            "text": text}
