"""Where to grasp the moving part of a joint: its handle, from labels or from geometry.

The part's *front* is found first: its outward direction (the pull direction of a drawer, the swing
direction of a door's far edge, made exact by the normal of the faces facing it) and the front face's
level along it (:func:`~spark_bench.opening.planning.features.front_level`). Handles are then looked for, first
found first taken:

1. a link labelled ``handle`` among the part's links (``semantics.txt`` label, or GAPartNet's annotation
   ``category``);
2. a labelled handle of a part hinged to it (a safe's lever, its own joint) standing in front of the front;
3. geometry: the surface of the part and of the parts hinged to it (a dial, a knob) standing proud of the
   front face by more than :data:`~spark_bench.opening.planning.handle_search.HANDLE_MIN_PROUD`, in connected clusters.

Only clusters the open fingers can close around count (narrower than the open fingers by
:data:`PINCH_MARGIN` on each side, across the closing direction); the chosen one is the central one
(drawers) or the one farthest from the hinge (doors). A labelled handle whose bounding box's center is
not over the handle (a bucket's bail, an arc) is grasped at its far end (:func:`~spark_bench.opening.planning.handle_search.on_handle`). The fingers
reach down the handle as far as they can: the fingertips :data:`TIP_CLEARANCE` above the front face, or
the pads' whole length below the handle's top when it stands out further, so that a knob's head or a
bar is held from behind, not pinched at its rounded front.

A part with no handle but a finger-pull notch cut into an edge of its front
(:func:`~spark_bench.opening.planning.features.find_notch`) gets an *inside grip*: the closed fingers enter the
notch, the hand presses against the notch's inner wall and the fingers open against its sides
(``inside_grip=True``, ``press`` the direction of that wall). A revolute part with none of these but a tab
standing out past its free edge (a box lid's lifting tab, :func:`find_tab`) is pinched across the tab
from beyond that edge (``outward`` is then the edge's direction, not the swing's). Any other part gets
its front face's center (drawers) or a point of the front face near its free edge (doors), with
``has_handle=False`` and a one-line ``reason`` why a parallel gripper cannot pull it.

A pinch grasp is then checked against its neighbourhood (:func:`spark_bench.opening.planning.pads.plan_pads`), and
the hand's way in against the object (:func:`find_grasp`). A tab whose way in is blocked (a front-loading
washer's handle on its door's rim) gives way to the front's own grasps; a sliding plate (a sash) whose front
has nothing to pinch or no way in is looked at from its broad face
(:func:`~spark_bench.opening.planning.plate_front.plate_face`).

Where the handle candidates are looked for is :mod:`spark_bench.opening.planning.handle_search`; which of them a
parallel gripper can pinch, and where, :mod:`spark_bench.opening.planning.handles`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.transforms import unit
from spark_bench.opening.planning.features import (
    LEVEL_BIN,
    Front,
    clusters,
    face_normal,
    find_notch,
    front_level,
    long_axis,
    min_cluster,
    perpendicular_basis,
    rasterise_front,
)
from spark_bench.opening.planning.gripper import GripperConfig
from spark_bench.opening.planning.handle_search import (
    HANDLE_MIN_PROUD,
    N_HANDLE_SAMPLES,
    N_SAMPLES,
    carried_links,
    handle_searches,
    on_handle,
)
from spark_bench.opening.planning.handles import (
    PINCH_MARGIN,
    candidates,
    edge_pinch,
    pad_center,
    reach_depth,
    sides_hold,
)
from spark_bench.opening.planning.pads import approach_blocked, pad_landing, plan_pads
from spark_bench.opening.planning.plate_front import plate_face
from spark_bench.opening.planning.rest_meshes import RestMeshes

#: A revolute part's free edge must lie this far (m) from its hinge for a feature past it to be a lid's tab:
#: a shorter part is a lever (a toilet's flush lever, 8 cm), pressed on its face, not pinched at its end.
TAB_MIN_REACH = 0.15
#: The hand comes in along the outward direction: nothing of the object may stand in its way out to this
#: distance (m) in front of the grasp.
APPROACH_CLEAR = 0.5
#: A tab is at most this fraction of the part's length along its hinge long (longer: the free edge itself).
TAB_MAX_FRACTION = 0.5
#: How far (m) behind the front face the TCP goes in a notch: the fingertips reach 12 mm further.
NOTCH_DEPTH = 0.004
#: A handle standing out of its base by this much (m) is held firmly; a lower one (a keyhole plate, an
#: escutcheon) is taken only when nothing stands out further.
FIRM_PROUD = 0.02
#: A prismatic joint travelling at most this far (m) is a push button (a microwave's door release)...
BUTTON_TRAVEL = 0.01
#: ... when its part is at most this fraction of the object's size (bounding-box diagonals at rest): the 64
#: buttons of partnet_dev and real_objects are at most 0.11 of it; a coffee machine's drip-tray grate
#: (102145, lifted 10 mm) is 0.29.
BUTTON_SIZE = 0.2


@dataclass
class GraspTarget:
    """A grasp on the moving part of one joint, world frame at the rest configuration.

    :param point: the grasp point (where the TCP should go)
    :param outward: unit direction out of the part's front (the gripper approaches along ``-outward``)
    :param long_axis: the handle's long direction (perpendicular to ``outward``); fingers close across it
    :param has_handle: whether a handle was found (label or geometry)
    :param source: ``label``, ``geometry``, ``notch`` (a finger-pull notch), ``tab`` (a lid's tab past its
        free edge), ``edge`` (the whole front pinched by its edges) or ``face`` (no handle)
    :param grip: ``pinch`` (fingers close across the handle) or ``inside`` (a notch: the closed fingers
        enter it, the hand presses towards its inner wall, the fingers open against its sides)
    :param press: for an ``inside`` grip, the unit direction (in the front plane) from the notch's open
        edge to its inner wall, which the hand presses against while it opens the part
    :param notch_size: for a notch, its extent across the fingers' closing direction and along it, m
    :param opening: finger opening per side (m) to approach with, when a neighbouring feature is in the
        open fingers' sweep (None: approach fully open)
    :param pad_thickness: pad thickness (m) the pads must not exceed to fit beside the handle (None: any)
    :param clearance: room (m) left on each side of a pad placed in a gap beside the handle
    :param reason: why a parallel gripper cannot pull this part open (one line), or None when it can
    :param landing: an open pad comes down on the object (kept only when no other candidate is clear)
    :param declined: why the planner declined the part, as a word (None when it did not): ``no_handle``
        (nothing stands out of the front to pinch), ``too_wide`` (a handle wider than the open fingers),
        ``blocked`` (the object stands in the hand's way in), ``button`` (a push button), ``unholdable``
        (handle candidates, but none the pads can hold: their sides slope too gently, as a low rounded rib's,
        or the simulated collision shape has no side to hold); a part declined
        for ``no_handle``, ``too_wide`` or ``unholdable`` has nothing to pinch, and the environments'
        ``end_effector="auto"`` opens it with the suction cup
        (:func:`~spark_bench.opening.planning.suction.choose_end_effector`). The scene's drive check adds ``weak_pinch``
        (a pinch whose part starts to move along the fingers' closing, too heavy for one finger's servo:
        :func:`~spark_bench.opening.planning.drive_check.stuck_reason`), where ``auto`` takes the cup when the cup opens it
    :param cup_radius: for the suction cup, the radius (m) of the cup planned (one of
        :func:`~spark_bench.opening.planning.suction.cup_sizes`; None: the gripper)
    :param broad_face: the grasp is on a sliding plate's broad face, not on its front (``outward`` is that
        face's; :func:`~spark_bench.opening.planning.plate_front.plate_face`)
    """

    point: np.ndarray
    outward: np.ndarray
    long_axis: np.ndarray
    has_handle: bool
    source: str
    grip: str = "pinch"
    press: np.ndarray | None = None
    notch_size: tuple[float, float] | None = None
    opening: float | None = None
    pad_thickness: float | None = None
    clearance: float | None = None
    reason: str | None = None
    landing: bool = False
    declined: str | None = None
    cup_radius: float | None = None
    broad_face: bool = False

    @property
    def inside_grip(self) -> bool:
        """Whether the grasp is from inside a notch (the fingers grip by opening)."""
        return self.grip == "inside"

    @property
    def closing(self) -> np.ndarray:
        """The direction the fingers close along: across the handle, in the front plane."""
        c = np.cross(self.outward, self.long_axis)
        return c / np.linalg.norm(c)


def outward_direction(joint_type: str, origin: np.ndarray, axis: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The part's outward direction: the pull direction of a prismatic joint, or the direction in which
    the part's centroid starts to move when a revolute joint opens (``axis x r``).

    :param origin: a point on the joint axis (world)
    :param axis: unit joint axis (world), opening = increasing joint value
    :param points: the part's surface points at rest (world)
    """
    if joint_type == "prismatic":
        return unit(axis)
    r = points.mean(0) - origin
    r = r - np.dot(r, axis) * axis
    if np.linalg.norm(r) < 1e-9:
        raise ValueError("the part's centroid lies on its hinge axis: no outward direction")
    return unit(np.cross(axis, r))


class Tab(NamedTuple):
    """A lid's tab (:func:`find_tab`): the grasp across it, its surface points, and the free edge's level
    along ``grasp.outward`` (m)."""

    grasp: GraspTarget
    points: np.ndarray
    edge: float


def find_tab(part, points: np.ndarray, origin: np.ndarray, axis: np.ndarray,
             hinged: np.ndarray | None = None) -> Tab | None:
    """A tab standing out past the free edge of a revolute part (a box lid's lifting tab), or None.

    The free edge faces away from the hinge (``radial``, from the hinge to the part's centroid); a feature
    proud of that edge's face by more than :data:`HANDLE_MIN_PROUD` is pinched from beyond the edge,
    the fingers closing across its thickness. The edge's face is the densest level near the far end (a
    tab's own end face is a level too, but a smaller one).

    :param part: the part's mesh (world, at rest)
    :param points: the part's surface points at rest (world)
    :param origin: a point on the hinge axis
    :param axis: unit hinge axis
    :param hinged: surface points of parts hinged to it (a box lid's hasp): they may be the tab
    """
    r = points - origin
    r = r - np.outer(r @ axis, axis)
    radial = face_normal(part, unit(r.mean(0)))
    depth = points @ radial
    near = depth[depth > depth.max() - 0.12]
    counts, edges = np.histogram(near, bins=np.arange(near.min(), depth.max() + 2 * LEVEL_BIN, LEVEL_BIN))
    k = int(np.argmax(counts))
    edge = float(0.5 * (edges[k] + edges[k + 1]))
    if edge - float(origin @ radial) < TAB_MIN_REACH:
        return None
    tip = points[depth > edge + HANDLE_MIN_PROUD]
    if hinged is not None and len(hinged):
        tip = np.concatenate([tip, hinged[hinged @ radial > edge + HANDLE_MIN_PROUD]])
    basis = perpendicular_basis(radial)
    # a tab is a small feature of the free edge (which runs along the hinge), not the whole edge
    length = float(np.ptp(points @ axis))
    groups = [g for g in clusters(tip) if len(g) >= min_cluster(len(points))
              and float(np.ptp(tip[g] @ axis)) <= TAB_MAX_FRACTION * length]
    if not groups:
        return None
    best = tip[max(groups, key=len)]
    uv = best @ basis.T
    point = 0.5 * (uv.min(0) + uv.max(0)) @ basis + float(np.median(best @ radial)) * radial
    return Tab(GraspTarget(point=point, outward=radial, long_axis=long_axis(best, basis), has_handle=True,
                           source="tab"), best, edge)


def _front_of(asset: ArticulatedAsset, joint: str, seed: int, outward: np.ndarray | None = None) -> Front:
    """The part's front: along its outward direction (:func:`outward_direction`), or along ``outward`` when
    given (a sliding plate's broad face)."""
    spec = asset.joints[joint]
    part = asset.mesh(links=asset.part_of_joint(joint))
    if len(part.faces) == 0:
        raise ValueError(f"{asset.name}: the part moved by {joint} has no geometry")
    origin, axis = asset.joint_frames()[joint]
    points = sample_surface(part, N_SAMPLES, seed=seed)
    n = outward_direction(spec.type, origin, axis, points)
    rotational = spec.type != "prismatic"
    if outward is not None:  # a plate's broad face (plate_front.plate_face)
        n = unit(outward)
    elif rotational:
        n = face_normal(part, n)
    return Front(part=part, points=points, outward=n, basis=perpendicular_basis(n), face=front_level(points @ n),
                  origin=origin, axis=axis, rotational=rotational)


def _pinch(asset: ArticulatedAsset, joint: str, front: Front, gripper: GripperConfig, seed: int,
           collision=None) -> tuple[GraspTarget | None, str | None, str | None]:
    """The pinch grasp on the best handle candidate, or ``(None, why none fits, the declined word)``.

    A candidate the pads cannot hold is passed over: one where the part's surface, from the fingertips up
    (below the handle search's proud cut too), has sides too shallow for the pads at every level (a low
    rounded rib), or, given ``collision`` (the part's simulated collision shapes, world frame at rest), one
    whose simulated shape's sides give the pads no hold
    (:func:`~spark_bench.opening.planning.handles.sides_hold`)."""
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
            grasp = _pinch_on(asset, joint, front, candidate, source, gripper)
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


def _pinch_on(asset: ArticulatedAsset, joint: str, front: Front, best, source: str, gripper: GripperConfig
              ) -> GraspTarget:
    """The pinch grasp on handle candidate ``best``, its pads placed; ``landing`` set when an open pad would
    come down on the object (:func:`~spark_bench.opening.planning.pads.pad_landing`)."""
    n, basis = front.outward, front.basis
    depth = best.points @ n
    point = pad_center(best, front, gripper) @ basis + reach_depth(best.base, float(depth.max()),
                                                                  float(depth.min()), gripper) * n
    grasp = GraspTarget(point=point, outward=n, long_axis=best.long_axis(front), has_handle=True, source=source)
    holding = _place_pads(asset, joint, grasp, best.points, front.face, gripper)
    opening = gripper.max_opening if grasp.opening is None else grasp.opening
    thickness = gripper.pad_thickness if grasp.pad_thickness is None else grasp.pad_thickness
    if holding:  # a hinged part's piece (a wheel's hub): its other pieces may lie in the pads' closing sweep
        grasp.point = grasp.point + _clear_sweep(best, grasp, gripper) * grasp.long_axis
    grasp.landing = pad_landing(asset.mesh(), grasp.point, n, grasp.closing, grasp.long_axis, opening,
                                thickness, gripper) > 0.0
    return grasp


def _place_pads(asset: ArticulatedAsset, joint: str, grasp: GraspTarget, held: np.ndarray, face: float,
                gripper: GripperConfig) -> list[str]:
    """Put ``grasp``'s pads in the gaps beside the feature it holds when something else of the object stands
    in the open fingers' sweep (:func:`~spark_bench.opening.planning.pads.plan_pads`: ``opening``, ``pad_thickness``,
    ``clearance`` set and the point shifted; unchanged when nothing is in the way or no pads fit).

    :param held: surface points of the feature held (a handle candidate's, a tab's)
    :param face: the level (m, along ``grasp.outward``) of the front the feature stands out of
    :returns: the parts hinged to the part that the feature lies on
    """
    # the handle's side: the part, and a part hinged to it that the feature lies on (a safe's dial or lever,
    # held at rest: :func:`~spark_bench.opening.planning.scene.hold_hinged_parts`); any other hinged part (a big dial
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
#: section of the piece planned (:func:`_clear_sweep`) when that is narrower by more than
#: :data:`SWEEP_GAIN` (m) than where they were planned.
SWEEP_STEP = 0.002
SWEEP_GAIN = 2 * PINCH_MARGIN
#: Points of the piece count in its section when they stand this far (m) above the fingertips' level (as
#: :data:`~spark_bench.opening.planning.pads.LANDING_MARGIN`).
SWEEP_PROUD = 0.004


def _clear_sweep(best, grasp: GraspTarget, gripper: GripperConfig) -> float:
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


def find_grasp(asset: ArticulatedAsset, joint: str, seed: int = 0,
               gripper: GripperConfig | None = None, collision=None) -> GraspTarget:
    """The grasp on the part moved by ``joint``, at the asset's rest configuration.

    :param asset: the object (or a :class:`RestMeshes` of it, to share its meshes between joints)
    :param joint: a movable joint's name
    :param seed: seed of the surface sampling
    :param gripper: the gripper's dimensions, for fitting the pads beside the handle (default gripper)
    :param collision: the simulated collision shapes of the part and the parts hinged to it (one mesh, world
        frame at rest), to pass over handle candidates whose simulated shape the pads cannot hold; None: the
        visual surface only
    :raises ValueError: the part has no geometry, or its centroid lies on its hinge
    """
    gripper = gripper or GripperConfig()
    spec = asset.joints[joint]
    travel = spec.open_value - spec.rest_value
    if not isinstance(asset, RestMeshes):  # the button test and the planner share its merged meshes
        asset = RestMeshes(asset)
    if is_push_button(asset, joint):  # pressed, not pulled: nothing to plan
        part = asset.mesh(links=asset.part_of_joint(joint))
        if len(part.faces) == 0:
            raise ValueError(f"{asset.name}: the part moved by {joint} has no geometry")
        axis = unit(asset.joint_frames()[joint][1])
        return GraspTarget(point=np.asarray(part.vertices).mean(0), outward=-axis, long_axis=perpendicular_basis(axis)[0],
                           has_handle=False, source="face", declined="button",
                           reason=f"{joint}: a push button ({1000 * travel:.1f} mm of travel): pressed, not pulled open")
    grasp = _find(asset, joint, seed, gripper, collision)
    blocked = _way_in(asset, joint, grasp, gripper)
    if blocked is not None and grasp.source == "tab":
        # a tab pinched from beyond the free edge with the object in the pads' way there (a front-loading
        # washer's door handle on its rim, the body's front close behind it): the front's own grasps instead
        grasp = _find(asset, joint, seed, gripper, collision, tabs=False)
        blocked = _way_in(asset, joint, grasp, gripper)
    if blocked is not None or grasp.source == "face":
        # nothing to take at the front, or no way to it: a sliding plate (a sash) is taken by its broad face
        side = plate_face(asset, joint, APPROACH_CLEAR, seed)
        if side is not None:
            beside = _find(asset, joint, seed, gripper, collision, outward=side)
            # nothing to pinch there either: the cup's business, which checks its own way in to its own place
            if beside.source == "face" or _way_in(asset, joint, beside, gripper) is None:
                beside.broad_face = True
                grasp, blocked = beside, None
    if blocked is not None:
        link, distance, through = blocked
        what = (asset.links[link].label or link).replace("_", " ")
        part = part_name(asset, joint)
        in_front = _moving_part_of(asset, link, joint)
        grasp.declined = "blocked"
        if through and in_front is not None:  # a closed door before a tray: not the tray's own fault
            grasp.reason = (f"{joint}: the {part} lies behind the {what} ({in_front}), {1000 * distance:.0f} mm in "
                            "front of its grasp: that part must be opened first")
        elif through:  # the object lies across the whole way in, where the part should open to
            grasp.reason = (f"{joint}: the way the gripper comes in, in front of the {part}, runs into the "
                            f"{what} {1000 * distance:.0f} mm out (the joint opens into the object: is its axis "
                            "reversed?)")
        else:  # a neighbouring feature where the open fingers come down
            grasp.reason = (f"{joint}: the {what} stands in the open fingers' way to the {part}'s grasp, "
                            f"{1000 * distance:.0f} mm in front of it")
    return grasp


def _way_in(asset: ArticulatedAsset, joint: str, grasp: GraspTarget, gripper: GripperConfig):
    """What blocks ``grasp``'s way in (:func:`~spark_bench.opening.planning.pads.approach_blocked`), or None."""
    blocked = approach_blocked(asset, grasp, gripper, APPROACH_CLEAR)
    if blocked is not None and grasp.source == "face" and blocked[0] in asset.moving_links(joint):
        # nothing to pinch, and what stands before the face's centre is the part's own (the knob the pads
        # cannot hold): no other part in the way, the cup (``auto``) plans its own place and way in
        # (:func:`~spark_bench.opening.planning.suction.plan_suction`)
        return None
    return blocked


def _moving_part_of(asset: ArticulatedAsset, link: str, joint: str) -> str | None:
    """The movable joint (not ``joint``) whose part holds ``link``, or None (the body, a fixed part)."""
    return next((name for name, spec in asset.joints.items()
                 if name != joint and spec.is_movable and link in asset.part_of_joint(name)), None)


def is_push_button(asset: ArticulatedAsset, joint: str) -> bool:
    """Whether ``joint`` moves a push button: a prismatic joint of at most :data:`BUTTON_TRAVEL` of travel
    whose part is at most :data:`BUTTON_SIZE` of the object's size (a part without geometry counts by its
    travel alone)."""
    spec = asset.joints[joint]
    if spec.type != "prismatic" or not 0.0 < spec.open_value - spec.rest_value <= BUTTON_TRAVEL:
        return False
    part = asset.mesh(links=asset.part_of_joint(joint))
    whole = asset.mesh()
    if len(part.faces) == 0 or len(whole.faces) == 0:
        return True
    return _diagonal(part) <= BUTTON_SIZE * _diagonal(whole)


def _edge_sides_hold(front: Front, edge: tuple, gripper: GripperConfig, collision=None) -> bool:
    """Whether the pads hold an edge pinch's two edges (:func:`~spark_bench.opening.planning.handles.sides_hold`, on the
    part's surface and, given them, its collision shapes): the crown of a rounded lid is a strip narrower than
    the open fingers at its face level, but its sides slope away and the pads slide off them."""
    point, along, _ = edge
    closing = np.cross(along, front.outward)
    tips = float(point @ front.outward) - gripper.tip_beyond_tcp
    return all(sides_hold(mesh, point, front.outward, closing, along, tips, gripper)
               for mesh in (front.part, collision) if mesh is not None)


def _diagonal(mesh) -> float:
    return float(np.linalg.norm(np.ptp(np.asarray(mesh.vertices), axis=0)))


def _find(asset: ArticulatedAsset, joint: str, seed: int, gripper: GripperConfig, collision=None,
          tabs: bool = True, outward: np.ndarray | None = None) -> GraspTarget:
    """:func:`find_grasp` before the approach check (``tabs``: whether a lid's tab past its free edge is a
    grasp; ``outward``: the front's direction, default the part's own, :func:`_front_of`)."""
    front = _front_of(asset, joint, seed, outward)
    grasp, no_pinch, why = _pinch(asset, joint, front, gripper, seed, collision)
    if grasp is not None:
        return grasp
    n, basis, face = front.outward, front.basis, front.face

    image, lo = rasterise_front(front.part, n, basis, face)
    notches = find_notch(image, lo)
    if notches:
        notch = min(notches, key=lambda notch: front.lateral_score(np.atleast_2d(notch.center @ basis + face * n)))
        press = notch.press @ basis
        return GraspTarget(point=notch.center @ basis + (face - NOTCH_DEPTH) * n, outward=n, long_axis=press,
                           has_handle=True, source="notch", grip="inside", press=press,
                           notch_size=(notch.depth, notch.width))

    if front.rotational and tabs:  # a lid's tab standing out past its free edge, pinched from beyond that edge
        carried = [name for name in carried_links(asset, joint, asset.part_of_joint(joint))
                   if asset.links[name].has_geometry]
        hinged = sample_surface(asset.mesh(links=carried), N_HANDLE_SAMPLES, seed=seed) if carried else None
        tab = find_tab(front.part, front.points, front.origin, front.axis, hinged)
        if tab is not None:
            # the object under a tab (a top-loading washer's deck below its lid's lip) stands in the open
            # fingers' sweep as a neighbour's feature does: the pads come in pre-closed beside the tab
            _place_pads(asset, joint, tab.grasp, tab.points, tab.edge, gripper)
            return tab.grasp

    links = asset.part_of_joint(joint)
    others = [name for name in asset.links if name not in links]
    edge = edge_pinch(front, asset.mesh(links=others) if others else None, gripper)
    if edge is not None and _edge_sides_hold(front, edge, gripper, collision):
        # a front narrower than the open fingers, standing clear of its surround, with sides the pads hold
        return GraspTarget(point=edge[0], outward=n, long_axis=edge[1], has_handle=True, source="edge")

    # no handle: a point of the front face, central (drawer) or near the free edge (door)
    depth = front.points @ n
    face_points = front.points[np.abs(depth - face) < 2 * LEVEL_BIN]
    uv = face_points @ basis.T
    if front.rotational:
        r = face_points - front.origin
        radial = np.linalg.norm(r - np.outer(r @ front.axis, front.axis), axis=1)
        keep = radial > np.quantile(radial, 0.85)
        lateral = np.array([0.5 * (uv[:, 0].min() + uv[:, 0].max()), np.median(uv[keep, 1])])
    else:
        lateral = 0.5 * (uv.min(0) + uv.max(0))
    what = part_name(asset, joint)
    reason = no_pinch or (f"no handle, knob, notch or tab on the {what}: nothing stands out of its front for "
                          "a parallel gripper to pull")
    buttons = [j for j in asset.movable_joints() if j.name != joint and is_push_button(asset, j.name)]
    if buttons and not no_pinch:  # a microwave's door: a button releases it
        reason += f" (the object has {len(buttons)} push button{'s' * (len(buttons) > 1)}: a button may open it)"
    return GraspTarget(point=lateral @ basis + face * n, outward=n, long_axis=basis[0] if front.rotational else basis[1],
                       has_handle=False, source="face", reason=f"{joint}: {reason}",
                       declined=why or "no_handle")


def part_name(asset: ArticulatedAsset, joint: str) -> str:
    """What to call the part moved by ``joint`` in a message: its link's label, else ``part``."""
    label = asset.links[asset.joints[joint].child].label.replace("_", " ").strip()
    return label or "part"
