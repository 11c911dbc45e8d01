"""The ``mass_inertia`` check: every moving body has a valid mass and inertia, and something to collide."""

from __future__ import annotations

import math

import numpy as np

from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.results import CheckResult


def carries_collision(model) -> np.ndarray:
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
    carries = carries_collision(model)
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


def mass_inertia(inputs: CheckInputs) -> CheckResult:
    """The ``mass_inertia`` check of a run (:func:`check_mass_inertia` on its compiled model)."""
    return check_mass_inertia(inputs.model)
