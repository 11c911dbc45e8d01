"""The pinch grasp on a part's handle candidates (:mod:`spark_bench.manipulation.grasp` finds the part's
front and runs the rest): the best candidate the pads can hold, the pads placed beside it, slid to the
narrowest section of a hinged part's piece.
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.manipulation.features import Front
from spark_bench.manipulation.grasp_target import GraspTarget
from spark_bench.manipulation.gripper import GripperConfig
from spark_bench.manipulation.handle_search import carried_links, handle_searches, on_handle
from spark_bench.manipulation.handles import PINCH_MARGIN, candidates, pad_center, reach_depth, sides_hold
from spark_bench.manipulation.pads import pad_landing, plan_pads

#: A handle standing out of its base by this much (m) is held firmly; a lower one (a keyhole plate, an
#: escutcheon) is taken only when nothing stands out further.
FIRM_PROUD = 0.02


def pinch_grasp(asset: ArticulatedAsset, joint: str, front: Front, gripper: GripperConfig, seed: int,
           collision=None) -> tuple[GraspTarget | None, str | None, str | None]:
    """The pinch grasp on the best handle candidate, or ``(None, why none fits, the declined word)``.

    A candidate the pads cannot hold is passed over: one where the part's surface, from the fingertips up
    (below the handle search's proud cut too), has sides too shallow for the pads at every level (a low
    rounded rib), or, given ``collision`` (the part's simulated collision shapes, world frame at rest), one
    whose simulated shape's sides give the pads no hold
    (:func:`~spark_bench.manipulation.handles.sides_hold`)."""
    n, basis = front.outward, front.basis
    widest = None
    unheld: list[str] = []
    span = 2 * gripper.max_opening - 2 * PINCH_MARGIN

    def grasped(points: np.ndarray) -> np.ndarray:
        return on_handle(points, basis, front.origin if front.rotational else None, front.axis)

    for source, pts, groups in handle_searches(asset, joint, front, seed):
        fitting, wide = candidates(pts, groups, front, gripper, grasped)
        if wide is not None:
            widest = max(widest or 0.0, wide)
        if not fitting:
            continue
        # a feature standing well out first (a knob, not a keyhole plate), then the best placed; one where an
        # open pad would land on the object (a piece of a wide plate) only when no other is clear. A wide
        # feature's further pieces (a stretch of a wheel's spoke beyond its hub) come after every first piece
        # standing out as far
        ranked = sorted(fitting, key=lambda c: (c.base is not None and float(np.max(c.points @ n)) - c.base < FIRM_PROUD,
                                                c.alternate, front.lateral_score(c.points)))
        first = None
        for candidate in ranked:
            grasp = pinch_on(asset, joint, front, candidate, source, gripper)
            tips = float(grasp.point @ n) - gripper.tip_beyond_tcp
            if not sides_hold(front.part, grasp.point, n, grasp.closing, grasp.long_axis, tips, gripper):
                unheld.append("its sides slope too gently for the pads to hold (a low rounded rib)")
                continue
            if collision is not None and not sides_hold(collision, grasp.point, n, grasp.closing,
                                                                  grasp.long_axis, tips, gripper):
                unheld.append("its simulated collision shape's sides slope too gently for the pads to hold")
                continue
            first = first or grasp
            if not grasp.landing or len(ranked) == 1:
                return grasp, None, None
        if first is not None:
            return first, None, None
    if widest is not None:
        return None, (f"its handle is {1000 * widest:.0f} mm across, wider than the open gripper "
                      f"({1000 * span:.0f} mm)"), "too_wide"
    if unheld:
        return None, f"no handle the gripper can hold: {'; '.join(dict.fromkeys(unheld))}", "unholdable"
    return None, None, None


def pinch_on(asset: ArticulatedAsset, joint: str, front: Front, best, source: str, gripper: GripperConfig
              ) -> GraspTarget:
    """The pinch grasp on handle candidate ``best``, its pads placed; ``landing`` set when an open pad would
    come down on the object (:func:`~spark_bench.manipulation.pads.pad_landing`)."""
    n, basis = front.outward, front.basis
    depth = best.points @ n
    point = pad_center(best, front, gripper) @ basis + reach_depth(best.base, float(depth.max()),
                                                                  float(depth.min()), gripper) * n
    grasp = GraspTarget(point=point, outward=n, long_axis=best.long_axis(front), has_handle=True, source=source)
    holding = place_pads(asset, joint, grasp, best.points, front.face, gripper)
    opening = gripper.max_opening if grasp.opening is None else grasp.opening
    thickness = gripper.pad_thickness if grasp.pad_thickness is None else grasp.pad_thickness
    if holding:  # a hinged part's piece (a wheel's hub): its other pieces may lie in the pads' closing sweep
        grasp.point = grasp.point + clear_sweep(best, grasp, gripper) * grasp.long_axis
    grasp.landing = pad_landing(asset.mesh(), grasp.point, n, grasp.closing, grasp.long_axis, opening,
                                thickness, gripper) > 0.0
    return grasp


def place_pads(asset: ArticulatedAsset, joint: str, grasp: GraspTarget, held: np.ndarray, face: float,
                gripper: GripperConfig) -> list[str]:
    """Put ``grasp``'s pads in the gaps beside the feature it holds when something else of the object stands
    in the open fingers' sweep (:func:`~spark_bench.manipulation.pads.plan_pads`: ``opening``, ``pad_thickness``,
    ``clearance`` set and the point shifted; unchanged when nothing is in the way or no pads fit).

    :param held: surface points of the feature held (a handle candidate's, a tab's)
    :param face: the level (m, along ``grasp.outward``) of the front the feature stands out of
    :returns: the parts hinged to the part that the feature lies on
    """
    # the handle's side: the part, and a part hinged to it that the feature lies on (a safe's dial or lever,
    # held at rest: :func:`~spark_bench.manipulation.scene.hold_hinged_parts`); any other hinged part (a big dial
    # beside a bar) stands in the pads' way like another part's feature
    links = asset.part_of_joint(joint)
    holding = [name for name in carried_links(asset, joint, links) if _holds(asset, name, held)]
    own = [name for name in asset.links if name in links or name in holding]
    others = [name for name in asset.links if name not in own]
    pads = plan_pads(asset.mesh(links=own), asset.mesh(links=others) if others else None, grasp.point,
                     grasp.outward, grasp.closing, grasp.long_axis, face, gripper)
    if pads is not None:
        grasp.point = grasp.point + pads["shift"] * grasp.closing
        grasp.opening, grasp.pad_thickness = pads["opening"], pads["pad_thickness"]
        grasp.clearance = pads["clearance"]
    return holding


#: The pads slide along the handle in steps of this (m), up to half their height, to close on the narrowest
#: section of the piece planned (:func:`clear_sweep`) when that is narrower by more than
#: :data:`SWEEP_GAIN` (m) than where they were planned.
SWEEP_STEP = 0.002
SWEEP_GAIN = 2 * PINCH_MARGIN
#: Points of the piece count in its section when they stand this far (m) above the fingertips' level (as
#: :data:`~spark_bench.manipulation.pads.LANDING_MARGIN`).
SWEEP_PROUD = 0.004


def clear_sweep(best, grasp: GraspTarget, gripper: GripperConfig) -> float:
    """How far (m) along the grasp's long axis to slide the pads so that, closing, they meet the narrowest
    section of the piece ``best`` of a hinged part (a wheel's hub, not its spokes' roots beside the hub
    within the pads' height, whose sloping edges the pads would squeeze first): the piece's width across,
    over the pads' height, at each slide up to half a pad height with the pads still over the piece for half
    their height; the smallest slide to the narrowest, when that is narrower by :data:`SWEEP_GAIN`; else 0."""
    closing, along, n = grasp.closing, grasp.long_axis, grasp.outward
    tips = float(grasp.point @ n) - gripper.tip_beyond_tcp
    rel = best.points - grasp.point
    raised = best.points @ n - tips > SWEEP_PROUD
    x, a = rel[raised] @ closing, rel[raised] @ along
    if len(x) == 0:
        return 0.0
    half = 0.5 * gripper.pad_height

    def width(shift: float) -> float | None:
        band = np.abs(a - shift) <= half
        return float(np.ptp(x[band])) if band.any() else None

    here = width(0.0)
    shifts = [0.0] + [sign * k * SWEEP_STEP for k in range(1, int(half / SWEEP_STEP) + 1) for sign in (-1.0, 1.0)]
    found = []
    for shift in shifts:
        overlap = min(shift + half, float(a.max())) - max(shift - half, float(a.min()))
        w = width(shift)
        if overlap >= half and w is not None:
            found.append((w, shift))
    if here is None or not found:
        return 0.0
    narrowest = min(w for w, _ in found)
    if narrowest > here - SWEEP_GAIN:
        return 0.0
    return next(shift for w, shift in found if w <= narrowest + SWEEP_STEP)


#: A link holds a handle candidate when every candidate point lies within this distance (m) of its box.
HOLD_MARGIN = 0.001


def _holds(asset: ArticulatedAsset, link: str, points: np.ndarray) -> bool:
    """Whether ``points`` (a handle candidate's surface samples) lie on ``link`` (within its box)."""
    mesh = asset.mesh(links=[link])
    if len(mesh.vertices) == 0:
        return False
    low, high = np.asarray(mesh.vertices).min(0) - HOLD_MARGIN, np.asarray(mesh.vertices).max(0) + HOLD_MARGIN
    return bool(np.all((points >= low) & (points <= high)))
