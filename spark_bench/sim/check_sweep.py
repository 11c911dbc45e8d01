"""The ``joint_sweep`` check of a run (the sweep itself: :mod:`spark_bench.sim.sweep`).

A blocked joint's reason says whether the surfaces of the two parts meet too (the object blocks it: its range or
geometry is wrong) or only their hulls do (:func:`spark_bench.sim.phantom.explain_blocking`).
"""

from __future__ import annotations

from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.results import CheckResult
from spark_bench.sim.sweep import check_joint_sweep, stopped_by_contact


def explain_sweep(sweep: CheckResult, prepared, model) -> None:
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


def joint_sweep(inputs: CheckInputs) -> CheckResult:
    """The ``joint_sweep`` check of a run. Converted here: swept on the MJCF rebuilt without its visual meshes
    (the sweep adds actuators and compiles again; visuals take no part), each blocked joint explained
    (:func:`explain_sweep`). A converted ``model.xml``: swept on its own spec, its movable joints counted."""
    if inputs.xml is not None:
        model = inputs.model
        sweep = check_joint_sweep(inputs.compiled.spec, inputs.joints, inputs.size)
        sweep.details["movable_joints"] = sum(1 for j in range(model.njnt) if model.jnt_type[j] in (2, 3))
        return sweep
    from spark_bench.sim.mjcf import build_spec

    bare = build_spec(inputs.asset, prepared=inputs.prepared, visuals=False)
    sweep = check_joint_sweep(bare, inputs.joints, inputs.size)
    if not sweep.passed:
        explain_sweep(sweep, inputs.prepared, bare.compile())
    return sweep
