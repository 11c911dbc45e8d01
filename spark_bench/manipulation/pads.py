"""Finger pads planned around a handle: when another part's feature stands in the open fingers' sweep.

A feature of *another* part standing proud of the front inside the open fingers' sweep (the edge lip of
the other leaf of a double door, a few mm beside this door's lip) would end up between the pads and be
held too. The pads are then placed in the gaps beside the handle instead: the fingers approach
pre-closed to ``opening``, thin enough (``pad_thickness``) to leave ``clearance`` on each side, with the
TCP shifted so that each pad sits in the middle of its gap. Everything is worked out from geometry.
"""

from __future__ import annotations

import numpy as np

from spark_bench.manipulation.features import first_hit
from spark_bench.manipulation.gripper import GripperConfig

#: Another part's surface stands in the fingers' way when it is this far (m) proud of the grasped front
#: (a neighbour's front face level with this one is not in the way: the fingertips stop short of it).
OBSTACLE_MIN_PROUD = 0.004  # half of grasp.HANDLE_MIN_PROUD: less than a handle, more than noise
#: Room (m) kept between an open pad's outer face and a neighbouring feature, and beside the pads' height.
SWEEP_MARGIN = 0.002
#: Thinnest pad (m) the planner asks for, and the least room (m) it leaves on each side of a pad in a gap.
PAD_MIN_THICKNESS = 0.0025
PAD_MIN_CLEARANCE = 0.001


def near_box(mesh, origin: np.ndarray, frame: np.ndarray, lo, hi):
    """The triangles of ``mesh`` that may meet a box (those whose three corners all lie beyond one of the
    box's faces do not), as a smaller mesh in the world frame; None when none may. Tested on the corners'
    flags, not their coordinates: a real object's 10^6 triangles, several boxes per grasp.

    :param mesh: a triangle mesh (world frame), or None
    :param origin: the box frame's origin (world)
    :param frame: 3x3, its rows the box frame's unit axes (world)
    :param lo: lower corner in box coordinates (``-inf`` entries: unbounded)
    :param hi: upper corner in box coordinates (``inf`` entries: unbounded)
    """
    from trimesh import Trimesh

    if mesh is None or len(mesh.faces) == 0:
        return None
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    local = (vertices - origin) @ np.asarray(frame).T
    keep = np.ones(len(faces), bool)
    for k in range(3):
        for beyond in ((local[:, k] < lo[k]) if np.isfinite(lo[k]) else None,
                       (local[:, k] > hi[k]) if np.isfinite(hi[k]) else None):
            if beyond is not None:
                keep &= ~(beyond[faces[:, 0]] & beyond[faces[:, 1]] & beyond[faces[:, 2]])
    if not keep.any():
        return None
    used, inverse = np.unique(faces[keep], return_inverse=True)  # only the kept triangles' corners
    return Trimesh(vertices[used], inverse.reshape(-1, 3), process=False)


def clipped_vertices(mesh, origin: np.ndarray, frame: np.ndarray, lo, hi) -> np.ndarray:
    """The vertices of ``mesh`` clipped to a box, in the box's coordinates.

    :param mesh: a triangle mesh (world frame), or None
    :param origin: the box frame's origin (world)
    :param frame: 3x3, its rows the box frame's unit axes (world)
    :param lo: lower corner in box coordinates (``-inf`` entries: unbounded)
    :param hi: upper corner in box coordinates (``inf`` entries: unbounded)
    :returns: (k, 3) box coordinates of the clipped triangles' corners (k = 0: nothing in the box); the
        extremes of any linear function over the mesh inside the box are attained among them
    """
    from trimesh import Trimesh
    from trimesh.intersections import slice_mesh_plane

    empty = np.zeros((0, 3))
    near = near_box(mesh, origin, frame, lo, hi)
    if near is None:
        return empty
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    piece = Trimesh((np.asarray(near.vertices) - origin) @ np.asarray(frame).T, near.faces, process=False)
    for k in range(3):
        for sign, bound in ((1.0, lo[k]), (-1.0, hi[k])):
            if not np.isfinite(bound):
                continue
            normal, at = np.zeros(3), np.zeros(3)
            normal[k], at[k] = sign, bound
            piece = slice_mesh_plane(piece, normal, at)
            if piece is None or len(piece.faces) == 0:
                return empty
    return piece.vertices[piece.faces].reshape(-1, 3)


def plan_pads(part, others, point: np.ndarray, outward: np.ndarray, closing: np.ndarray, long_axis: np.ndarray,
              face: float, gripper: GripperConfig) -> dict | None:
    """Where the pads go when another part's feature stands inside the open fingers' sweep.

    The sweep is the box the open pads and the room between them occupy at the grasp: across the
    closing direction out to the open pads' outer faces, along the handle the pads' height, and along the
    outward direction everything in front of the fingertips that stands :data:`OBSTACLE_MIN_PROUD` proud
    of the front. The part's own geometry in it is the handle; any other part's geometry in it would be
    pinched with the handle. Each pad then goes into the middle of the gap between the handle and the
    nearest obstacle on its side, the pads thin enough (half the narrower gap, at most the gripper's own)
    to leave room on both sides of them.

    :param part: the grasped part's mesh (world, at rest)
    :param others: the rest of the object's mesh (world, at rest), or None
    :param point: the grasp point (TCP), centred on the handle
    :param outward: unit direction out of the front
    :param closing: unit direction the fingers close along
    :param long_axis: unit direction along the handle
    :param face: the front face's level along ``outward``
    :param gripper: the gripper's dimensions (finger reach, travel, pad height and thickness)
    :returns: None when nothing is in the way, or when no pads fit (the grasp then stays as it was);
        else ``shift`` (TCP offset along ``closing``), ``opening`` (per finger), ``pad_thickness`` and
        ``clearance`` (m)
    """
    frame = np.stack([closing, long_axis, outward])
    reach = gripper.max_opening + gripper.pad_thickness + SWEEP_MARGIN
    half_height = gripper.pad_height / 2 + SWEEP_MARGIN
    front = max(-gripper.tip_beyond_tcp, face + OBSTACLE_MIN_PROUD - float(point @ outward))
    lo, hi = np.array([-reach, -half_height, front]), np.array([reach, half_height, np.inf])
    own = clipped_vertices(part, point, frame, lo, hi)
    if len(own) == 0:
        return None
    h_lo, h_hi = float(own[:, 0].min()), float(own[:, 0].max())
    middle = 0.5 * (h_lo + h_hi)
    plus = clipped_vertices(others, point, frame, [middle, lo[1], lo[2]], hi)
    minus = clipped_vertices(others, point, frame, lo, [middle, hi[1], hi[2]])
    gaps = {}
    if len(plus):
        gaps[1.0] = float(plus[:, 0].min()) - h_hi
    if len(minus):
        gaps[-1.0] = h_lo - float(minus[:, 0].max())
    if not gaps:
        return None
    thickness = float(np.clip(min(gaps.values()) / 2, PAD_MIN_THICKNESS, gripper.pad_thickness))
    room = {side: (gap - thickness) / 2 for side, gap in gaps.items()}
    clearance = min(room.values())
    if clearance < PAD_MIN_CLEARANCE:
        return None
    room_plus, room_minus = room.get(1.0, clearance), room.get(-1.0, clearance)
    opening = 0.5 * (h_hi - h_lo + room_plus + room_minus)
    if opening > gripper.max_opening:
        return None
    return {"shift": 0.5 * (h_hi + h_lo + room_plus - room_minus), "opening": opening,
            "pad_thickness": thickness, "clearance": clearance}


#: A pad comes down on something when a surface stands this far (m) above its fingertips' level where it
#: lands (less is contact noise, and a handle's own base the tips are planned to touch).
LANDING_MARGIN = 0.004


def pad_landing(mesh, point: np.ndarray, outward: np.ndarray, closing: np.ndarray, long_axis: np.ndarray,
                opening: float, pad_thickness: float, gripper: GripperConfig) -> float:
    """How far (m) above the fingertips' level a surface of ``mesh`` stands where an open pad comes down
    (0 when none): rays down the approach through each pad's middle and its two ends along the handle,
    from the palm's level to :data:`LANDING_MARGIN` above the tips'. A grasp on a piece of a wide plate
    (a safe's keypad, picked for a handle) lands one pad on the plate itself: the hand stops short.

    :param mesh: the object's mesh (world, at rest: the grasped part's own included)
    :param point: the grasp point (TCP)
    :param opening: finger opening per side the pads come down with, m
    :param pad_thickness: the pads' thickness, m
    """
    top = gripper.finger_length - gripper.tip_beyond_tcp  # the palm's level above the TCP
    span = top + gripper.tip_beyond_tcp - LANDING_MARGIN  # palm level down to just above the tips
    lines = np.array([point + top * outward + side * (opening + 0.5 * pad_thickness) * closing + h * long_axis
                      for side in (-1.0, 1.0) for h in (-0.5 * gripper.pad_height, 0.0, 0.5 * gripper.pad_height)])
    triangles = np.asarray(mesh.triangles)
    if len(triangles) == 0:
        return 0.0
    ends = lines - outward * span  # the rays' box: only triangles meeting it can be hit
    lo, hi = np.minimum(lines, ends).min(0) - 1e-6, np.maximum(lines, ends).max(0) + 1e-6
    boxed = (triangles.min(1) <= hi).all(1) & (triangles.max(1) >= lo).all(1)
    hit = first_hit(triangles[boxed], lines, -outward, 0.0, span)
    return 0.0 if hit is None else span - hit + LANDING_MARGIN


def approach_blocked(asset, grasp, gripper: GripperConfig, clear: float) -> tuple[str, float, bool] | None:
    """What of the object stands in the hand's way in: rays from the pads' places as they come in (open,
    or pre-closed to ``grasp.opening``) along the outward direction, from the palm's level (what stands
    lower is the pads' business, :func:`~spark_bench.manipulation.pads.plan_pads`) out to ``clear`` (m).
    Returns ``(the first link hit, its distance m, whether the ray from the grasp point itself is blocked
    too)`` or None. A part whose joint opens into the object has the object across its whole way in; a
    neighbouring feature (a dial beside a safe's lever) stands beside the grasp, in one pad's way.

    :param asset: the object (a :class:`~spark_bench.manipulation.rest_meshes.RestMeshes`)
    :param grasp: the planned :class:`~spark_bench.manipulation.grasp_target.GraspTarget`
    :param clear: how far (m) in front of the grasp nothing may stand
    """
    opening = gripper.max_opening if grasp.opening is None else grasp.opening
    across = grasp.closing * opening
    origins = np.stack([grasp.point + across, grasp.point - across])
    near, best, through = gripper.finger_length - gripper.tip_beyond_tcp, None, False
    # only triangles whose bounding box meets the rays' box can be hit (a real link holds 10^5 triangles)
    ends = np.concatenate([origins, grasp.point[None]])[:, None] + np.array([near, clear])[:, None] * grasp.outward
    lo, hi = ends.reshape(-1, 3).min(0) - 1e-6, ends.reshape(-1, 3).max(0) + 1e-6
    for name, link in asset.links.items():
        if not link.has_geometry:
            continue
        triangles = np.asarray(asset.mesh(links=[name]).triangles)
        triangles = triangles[(triangles.min(1) <= hi).all(1) & (triangles.max(1) >= lo).all(1)]
        hit = first_hit(triangles, origins, grasp.outward, near, clear if best is None else best[1])
        if hit is not None:
            best = (name, hit)
        through = through or first_hit(triangles, grasp.point, grasp.outward, near, clear) is not None
    return None if best is None else (*best, through)
