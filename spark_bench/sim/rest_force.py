"""Infinigen-Sim's rest-force check: at rest, an exported asset must not push against itself.

Reproduced from ``princeton-vl/infinigen``, ``tests/sim/test_sim_export.py``,
``TestSimExports.test_sim_export``, its "Step 3: Verify initial constraint forces are zero" (read at commit
198eada1, 2025-11-10; the step was deleted by commit 6f5d6802 the same day and is absent from the test,
now ``tests/infinigen/sim/test_sim_export.py``, at 25a7d284, 2026-07-08, which keeps only "compiles"):

- the exporter's MJCF is loaded (``MjModel.from_xml_path``) with a fresh ``MjData``: ``qpos = qpos0`` (the
  rest configuration), ``qvel = 0``, no control; gravity as the model says;
- one ``mj_forward``;
- passes when ``-1e-3 < sum(data.qfrc_constraint) < 1e-3``: Python's ``sum`` of the **signed** constraint
  forces of every degree of freedom (no absolute value, strict inequalities), in generalized-force units as
  they come, N on a slide dof and N·m on a hinge dof, added together;
- its ``skipped_tests.json`` (``{"lamp": ["init_force"]}``) is asked ``"init_force" not in skipped_tests``,
  the dict's keys (asset names), so it skipped nothing: no exception here either.

Applied here to spark-bench's compiled model of the object (:func:`spark_bench.sim.mjcf.build_spec`, whose
``qpos0`` is the rest configuration), as Infinigen's test applied it to its exporter's MJCF. Being a signed
sum, forces on two dofs can cancel (a pair of doors pressed shut in opposite senses passes); the details
give the absolute sum too. A force at rest comes from what the converter made of the object: a part whose
hulls overlap a neighbour's (a contact pushing it out), a joint at rest outside its limit, or a joint's
friction loss resisting gravity along the joint: holding a part that gravity pulls into its range (the
converter sizes that friction to hold it), or, at its maximum, a part that gravity pulls into its rest stop
(a lid lying shut: MuJoCo's limit acts only once the joint is past it, so at exactly the rest value the
friction loss alone resists; ``benchmarks/results/rest_force_partnet_dev.md``). Which of these carries the force is reported
(:func:`force_carriers`): ``qfrc_constraint = J^T f`` over the active constraint rows, each row's share
``J_i^T f_i`` attributed to its contact (the two bodies), joint limit, friction loss or equality.

The result is reported beside spark-bench's own checks, never in their verdict (it is another paper's
protocol): :func:`spark_bench.sim.checks.run_checks` puts it in the ``mjcf_compiles`` check's details as
``rest_force_infinigen``.
"""

from __future__ import annotations

import numpy as np

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.results import CheckResult

#: The name the check is reported under.
REST_FORCE_CHECK = "rest_force_infinigen"
#: Infinigen's bound on the summed constraint force at rest (passes when strictly inside ±this).
REST_FORCE_LIMIT = 1e-3
#: How many degrees of freedom and carriers the details list (largest first).
LISTED = 5
def constraint_jacobian(model, data) -> np.ndarray:
    """The active constraint rows' Jacobian, dense ``(nefc, nv)``, whether MuJoCo stored it dense or sparse.

    :param model: the ``MjModel``
    :param data: its ``MjData`` after ``mj_forward``
    """
    mujoco = mujoco_module()
    nefc, nv = int(data.nefc), int(model.nv)
    if not mujoco.mj_isSparse(model):
        return np.asarray(data.efc_J[: nefc * nv]).reshape(nefc, nv)
    dense = np.zeros((nefc, nv))
    for row in range(nefc):
        start, count = int(data.efc_J_rowadr[row]), int(data.efc_J_rownnz[row])
        columns = data.efc_J_colind[start: start + count]
        dense[row, columns] = data.efc_J[start: start + count]
    return dense


def _carrier_of(model, data, row: int) -> tuple[str, str]:
    """``(kind, what)`` of constraint row ``row``: a contact names its two bodies, a limit or a friction
    loss its joint (or tendon), an equality its index."""
    c = mujoco_module().mjtConstraint
    kind, ident = int(data.efc_type[row]), int(data.efc_id[row])
    if kind in (int(c.mjCNSTR_CONTACT_FRICTIONLESS), int(c.mjCNSTR_CONTACT_PYRAMIDAL),
                int(c.mjCNSTR_CONTACT_ELLIPTIC)):
        contact = data.contact[ident]
        return "contact", "|".join(sorted(model.body(int(model.geom_bodyid[g])).name
                                          for g in (contact.geom1, contact.geom2)))
    if kind == int(c.mjCNSTR_LIMIT_JOINT):
        return "limit", model.joint(ident).name
    if kind == int(c.mjCNSTR_FRICTION_DOF):  # the id is a dof: its joint
        return "friction_loss", model.joint(int(model.dof_jntid[ident])).name
    if kind in (int(c.mjCNSTR_LIMIT_TENDON), int(c.mjCNSTR_FRICTION_TENDON)):
        return ("limit" if kind == int(c.mjCNSTR_LIMIT_TENDON) else "friction_loss"), model.tendon(ident).name
    return "equality", str(ident)


def force_carriers(model, data) -> list[dict]:
    """What carries the constraint force at ``data``'s state: one entry per contact pair of bodies, joint
    limit, joint friction loss or equality with ``kind``, ``what``, ``sum`` (its share of the summed
    ``qfrc_constraint``) and ``largest`` (its largest share on one dof, by magnitude, signed), largest first.

    :param model: the ``MjModel``
    :param data: its ``MjData`` after ``mj_forward``
    """
    jacobian = constraint_jacobian(model, data)
    shares: dict[tuple[str, str], np.ndarray] = {}
    for row in range(int(data.nefc)):
        key = _carrier_of(model, data, row)
        share = jacobian[row] * float(data.efc_force[row])
        shares[key] = shares[key] + share if key in shares else share
    out = []
    for (kind, what), share in shares.items():
        if not np.any(share):  # an active row that carries nothing (a friction loss with nothing to hold)
            continue
        largest = float(share[int(np.argmax(np.abs(share)))]) if share.size else 0.0
        out.append({"kind": kind, "what": what, "sum": float(np.sum(share)), "largest": largest})
    return sorted(out, key=lambda c: -abs(c["largest"]))


def dof_forces(model, data) -> list[dict]:
    """The degrees of freedom carrying constraint force at ``data``'s state: ``joint``, ``type`` (``slide``
    in N, ``hinge`` in N·m...), ``force``, ``gravity`` (the generalized gravity force on the dof,
    ``-qfrc_bias`` at zero velocity: a friction loss holding a part still carries minus it) and
    ``friction_loss`` (the dof's, the most its friction can carry), largest magnitude first (zeros left out).
    """
    names = {1: "ball", 0: "free", 2: "slide", 3: "hinge"}
    out = []
    for dof in np.argsort(-np.abs(data.qfrc_constraint)):
        force = float(data.qfrc_constraint[dof])
        if force == 0.0:
            break
        joint = int(model.dof_jntid[dof])
        out.append({"joint": model.joint(joint).name, "type": names[int(model.jnt_type[joint])], "force": force,
                    "gravity": -float(data.qfrc_bias[dof]), "friction_loss": float(model.dof_frictionloss[dof])})
    return out


def check_rest_force(model, limit: float = REST_FORCE_LIMIT) -> CheckResult:
    """Infinigen-Sim's rest-force check of a compiled model (module docstring): one ``mj_forward`` from a fresh
    state; the value is ``sum(qfrc_constraint)``, passing when strictly inside ``±limit``.

    Details: ``threshold``, ``abs_sum`` (the sum of the magnitudes), ``contacts`` (active contacts at rest),
    ``dofs`` and ``carriers`` (the :data:`LISTED` largest: :func:`dof_forces`, :func:`force_carriers`), the
    ``source`` of the rule and, when it fails, a one-line ``reason``.

    :param model: the compiled ``MjModel``
    :param limit: the bound (Infinigen's 1e-3)
    """
    mujoco = mujoco_module()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    total = sum(data.qfrc_constraint.tolist())  # Python's sum, left to right, as Infinigen's test adds them
    passed = bool(-limit < total < limit)
    dofs, carriers = dof_forces(model, data), force_carriers(model, data)
    details = {"threshold": limit, "abs_sum": float(np.sum(np.abs(data.qfrc_constraint))),
               "contacts": int(data.ncon), "dofs": dofs[:LISTED], "carriers": carriers[:LISTED],
               "source": "Infinigen-Sim tests/sim/test_sim_export.py @ 198eada1 (signed sum of qfrc_constraint "
                         "after one mj_forward at rest, within ±1e-3); reported, not part of sim_pass"}
    if not passed:
        details["reason"] = _reason(total, limit, dofs, carriers)
    return CheckResult(passed, float(total), details)


def _reason(total: float, limit: float, dofs: list[dict], carriers: list[dict]) -> str:
    """One line: the sum, the dof that carries most, and what carries it."""
    if not np.isfinite(total):
        return "the constraint force at rest is not finite"
    line = f"summed constraint force at rest {total:.4g} (Infinigen passes inside ±{limit:g})"
    if dofs:
        unit = "N" if dofs[0]["type"] == "slide" else "N·m"
        line += f"; most on joint {dofs[0]['joint']} ({dofs[0]['force']:.4g} {unit})"
    if carriers:
        top = carriers[0]
        word = {"contact": "a contact between", "limit": "the limit of joint", "friction_loss": "the friction loss of "
                "joint", "equality": "equality"}.get(top["kind"], top["kind"])
        line += f", carried by {word} {top['what']}"
    return line
