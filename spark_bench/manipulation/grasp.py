"""Where to grasp the moving part of a joint: its handle, from labels or from geometry.

The part's *front* is found first: its outward direction (the pull direction of a drawer, the swing
direction of a door's far edge, made exact by the normal of the faces facing it) and the front face's
level along it (:func:`~spark_bench.manipulation.features.front_level`). Handles are then looked for, first
found first taken:

1. a link labelled ``handle`` among the part's links (``semantics.txt`` label, or GAPartNet's annotation
   ``category``);
2. a labelled handle of a part hinged to it (a safe's lever, its own joint) standing in front of the front;
3. geometry: the surface of the part and of the parts hinged to it (a dial, a knob) standing proud of the
   front face by more than :data:`~spark_bench.manipulation.handle_search.HANDLE_MIN_PROUD`, in connected clusters.

Only clusters the open fingers can close around count (narrower than the open fingers by
:data:`PINCH_MARGIN` on each side, across the closing direction); the chosen one is the central one
(drawers) or the one farthest from the hinge (doors). A labelled handle whose bounding box's center is
not over the handle (a bucket's bail, an arc) is grasped at its far end (:func:`~spark_bench.manipulation.handle_search.on_handle`). The fingers
reach down the handle as far as they can: the fingertips :data:`TIP_CLEARANCE` above the front face, or
the pads' whole length below the handle's top when it stands out further, so that a knob's head or a
bar is held from behind, not pinched at its rounded front.

A part with no handle but a finger-pull notch cut into an edge of its front
(:func:`~spark_bench.manipulation.features.find_notch`) gets an *inside grip*: the closed fingers enter the
notch, the hand presses against the notch's inner wall and the fingers open against its sides
(``inside_grip=True``, ``press`` the direction of that wall). A revolute part with none of these but a tab
standing out past its free edge (a box lid's lifting tab, :func:`find_tab`) is pinched across the tab
from beyond that edge (``outward`` is then the edge's direction, not the swing's). Any other part gets
its front face's center (drawers) or a point of the front face near its free edge (doors), with
``has_handle=False`` and a one-line ``reason`` why a parallel gripper cannot pull it.

A pinch grasp is then checked against its neighbourhood (:func:`spark_bench.manipulation.pads.plan_pads`), and
the hand's way in against the object (:func:`find_grasp`). A tab whose way in is blocked (a front-loading
washer's handle on its door's rim) gives way to the front's own grasps; a sliding plate (a sash) whose front
has nothing to pinch or no way in is looked at from its broad face
(:func:`~spark_bench.manipulation.plate_front.plate_face`).

Where the handle candidates are looked for is :mod:`spark_bench.manipulation.handle_search`; which of them a
parallel gripper can pinch, and where, :mod:`spark_bench.manipulation.handles`; the pinch on the best of them,
its pads placed, :mod:`spark_bench.manipulation.pinch`; what the planner answers,
:class:`~spark_bench.manipulation.grasp_target.GraspTarget`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.transforms import unit
from spark_bench.manipulation.features import (
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
from spark_bench.manipulation.grasp_target import GraspTarget
from spark_bench.manipulation.gripper import GripperConfig
from spark_bench.manipulation.handle_search import (
    HANDLE_MIN_PROUD,
    N_HANDLE_SAMPLES,
    N_SAMPLES,
    carried_links,
)
from spark_bench.manipulation.handles import edge_pinch, sides_hold
from spark_bench.manipulation.pads import approach_blocked
from spark_bench.manipulation.pinch import pinch_grasp, place_pads
from spark_bench.manipulation.plate_front import plate_face
from spark_bench.manipulation.rest_meshes import RestMeshes

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
#: A prismatic joint travelling at most this far (m) is a push button (a microwave's door release)...
BUTTON_TRAVEL = 0.01
#: ... when its part is at most this fraction of the object's size (bounding-box diagonals at rest): the 64
#: buttons of partnet_dev and real_objects are at most 0.11 of it; a coffee machine's drip-tray grate
#: (102145, lifted 10 mm) is 0.29.
BUTTON_SIZE = 0.2


def outward_direction(joint_type: str, origin: np.ndarray, axis: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The part's outward direction: the pull direction of a prismatic joint, or the direction in which
    the part's centroid starts to move when a revolute joint opens (``axis x r``).

    :param origin: a point on the joint axis (world)
    :param axis: unit joint axis (world), opening = increasing joint value
    :param points: the part's surface points at rest (world)
    """
    if joint_type == JointType.PRISMATIC:
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


def part_front(asset: ArticulatedAsset, joint: str, seed: int, outward: np.ndarray | None = None) -> Front:
    """The front of the part ``joint`` moves: along its outward direction (:func:`outward_direction`), or along
    ``outward`` when given (a sliding plate's broad face).

    :param asset: the object
    :param joint: a movable joint's name
    :param seed: seed of the surface sampling
    :param outward: the front's direction, or None for the part's own
    :raises ValueError: the part has no geometry
    """
    spec = asset.joints[joint]
    part = asset.mesh(links=asset.part_of_joint(joint))
    if len(part.faces) == 0:
        raise ValueError(f"{asset.name}: the part moved by {joint} has no geometry")
    origin, axis = asset.joint_frames()[joint]
    points = sample_surface(part, N_SAMPLES, seed=seed)
    n = outward_direction(spec.type, origin, axis, points)
    rotational = spec.type != JointType.PRISMATIC
    if outward is not None:  # a plate's broad face (plate_front.plate_face)
        n = unit(outward)
    elif rotational:
        n = face_normal(part, n)
    return Front(part=part, points=points, outward=n, basis=perpendicular_basis(n), face=front_level(points @ n),
                  origin=origin, axis=axis, rotational=rotational)


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
    grasp = find_grasp_unchecked(asset, joint, seed, gripper, collision)
    blocked = _way_in(asset, joint, grasp, gripper)
    if blocked is not None and grasp.source == "tab":
        # a tab pinched from beyond the free edge with the object in the pads' way there (a front-loading
        # washer's door handle on its rim, the body's front close behind it): the front's own grasps instead
        grasp = find_grasp_unchecked(asset, joint, seed, gripper, collision, tabs=False)
        blocked = _way_in(asset, joint, grasp, gripper)
    if blocked is not None or grasp.source == "face":
        # nothing to take at the front, or no way to it: a sliding plate (a sash) is taken by its broad face
        side = plate_face(asset, joint, APPROACH_CLEAR, seed)
        if side is not None:
            beside = find_grasp_unchecked(asset, joint, seed, gripper, collision, outward=side)
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
    """What blocks ``grasp``'s way in (:func:`~spark_bench.manipulation.pads.approach_blocked`), or None."""
    blocked = approach_blocked(asset, grasp, gripper, APPROACH_CLEAR)
    if blocked is not None and grasp.source == "face" and blocked[0] in asset.moving_links(joint):
        # nothing to pinch, and what stands before the face's centre is the part's own (the knob the pads
        # cannot hold): no other part in the way, the cup (``auto``) plans its own place and way in
        # (:func:`~spark_bench.manipulation.suction.plan_suction`)
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
    if spec.type != JointType.PRISMATIC or not 0.0 < spec.open_value - spec.rest_value <= BUTTON_TRAVEL:
        return False
    part = asset.mesh(links=asset.part_of_joint(joint))
    whole = asset.mesh()
    if len(part.faces) == 0 or len(whole.faces) == 0:
        return True
    return _diagonal(part) <= BUTTON_SIZE * _diagonal(whole)


def edge_sides_hold(front: Front, edge: tuple, gripper: GripperConfig, collision=None) -> bool:
    """Whether the pads hold an edge pinch's two edges (:func:`~spark_bench.manipulation.handles.sides_hold`, on the
    part's surface and, given them, its collision shapes): the crown of a rounded lid is a strip narrower than
    the open fingers at its face level, but its sides slope away and the pads slide off them."""
    point, along, _ = edge
    closing = np.cross(along, front.outward)
    tips = float(point @ front.outward) - gripper.tip_beyond_tcp
    return all(sides_hold(mesh, point, front.outward, closing, along, tips, gripper)
               for mesh in (front.part, collision) if mesh is not None)


def _diagonal(mesh) -> float:
    return float(np.linalg.norm(np.ptp(np.asarray(mesh.vertices), axis=0)))


def find_grasp_unchecked(asset: ArticulatedAsset, joint: str, seed: int, gripper: GripperConfig, collision=None,
                         tabs: bool = True, outward: np.ndarray | None = None) -> GraspTarget:
    """:func:`find_grasp` before the approach check: the pinch, notch, tab, edge or face grasp on the part's
    front, whether or not the hand can come in to it (a measurement of the fronts reads this).

    :param asset: the object (a :class:`RestMeshes` of it shares its meshes between calls)
    :param joint: a movable joint's name
    :param seed: seed of the surface sampling
    :param gripper: the gripper's dimensions
    :param collision: the part's simulated collision shapes (see :func:`find_grasp`), or None
    :param tabs: whether a lid's tab past its free edge is a grasp
    :param outward: the front's direction (default the part's own, :func:`part_front`)
    """
    front = part_front(asset, joint, seed, outward)
    grasp, no_pinch, why = pinch_grasp(asset, joint, front, gripper, seed, collision)
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
            place_pads(asset, joint, tab.grasp, tab.points, tab.edge, gripper)
            return tab.grasp

    links = asset.part_of_joint(joint)
    others = [name for name in asset.links if name not in links]
    edge = edge_pinch(front, asset.mesh(links=others) if others else None, gripper)
    if edge is not None and edge_sides_hold(front, edge, gripper, collision):
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
