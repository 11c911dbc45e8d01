"""Which handle candidates a parallel gripper can pinch, and where on them (:mod:`spark_bench.manipulation.grasp`
finds the candidates).

A candidate is a cluster of surface points standing out of a part's front. It is pinchable whole when
its extent across the fingers' closing direction (perpendicular to its own long direction) leaves
:data:`PINCH_MARGIN` to each open pad. A wider one (a rosette knob, a safe's wheel) may still hold a
pinchable piece:

- a *raised* piece standing out of the rest of it (a rosette's central boss): the candidate's points above
  successively higher levels, clustered again (:func:`raised_piece`); the pads then reach down to that
  level, not to the front;
- a *local* piece: the points within a radius of a seed point (a stretch of a wheel's rim), seeds tried
  from the best placed (:func:`local_patches`); the radius is more than half the open fingers' span, so a
  flat panel never counts. Several such pieces are kept: the planner takes a further one where an open pad
  would land on the feature's wider parts beside the first (a wheel's hub).

A handle on a hinge of its own (a safe's lever, a spinning wheel) is held as close to that hinge's axis as
it can be: a pull there does not turn it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.manipulation.features import MIN_CLUSTER, Front, clusters, long_axis
from spark_bench.manipulation.gripper import GripperConfig

#: Room (m) kept between the fingertips and the level the pads reach down to (the front's level is known
#: to a histogram bin, 2 mm).
TIP_CLEARANCE = 0.0
#: Room (m) kept between a handle and each open pad across the closing direction: a feature wider than
#: the open fingers less twice this cannot be pinched.
PINCH_MARGIN = 0.004
#: Seed points tried when looking for a pinchable piece of a wide feature (:func:`local_patches`).
MAX_PATCH_SEEDS = 12
#: Pinchable pieces kept per wide feature: its first, and alternates tried when an open pad would land on
#: the feature's own wider parts there (a wheel's hub beside the first piece; a stretch further out along a
#: spoke is clear).
MAX_PATCHES = 4
#: Level step (m) of the search for a raised piece of a wide feature, and how far (m) the piece must stand
#: out of the level it is cut at for the pads to hold it.
RAISED_STEP = 0.004
RAISED_MIN = 0.008


@dataclass
class Candidate:
    """A pinchable handle piece.

    :param points: its surface points (world)
    :param center: the 2-D point (front plane) to centre the pads on along the handle; None: its middle
    :param base: the level (along the outward direction) the fingertips may reach down to; None: the
        feature stands free (nothing of the part around it)
    :param along: its long direction (world, in the front plane), when it is not that of its points (a
        piece cut out of a wider feature across its own long direction); None: from its points
    :param alternate: a further piece of a wide feature (:func:`local_patches`), tried only after the
        feature's first piece and every other feature's first piece standing out as far
    """

    points: np.ndarray
    center: np.ndarray | None
    base: float | None
    along: np.ndarray | None = None
    alternate: bool = False

    def long_axis(self, front: Front) -> np.ndarray:
        """The long direction the fingers close across."""
        return self.along if self.along is not None else long_axis(self.points, front.basis)


def pinch_width(points: np.ndarray, outward: np.ndarray, along: np.ndarray) -> float:
    """A feature's extent (m) across the fingers' closing direction (perpendicular to ``outward`` and to its
    long direction ``along``): what the open fingers must span."""
    closing = np.cross(outward, along)
    return float(np.ptp(points @ (closing / np.linalg.norm(closing))))


def fits(points: np.ndarray, front: Front, span: float) -> bool:
    """Whether the open fingers (``span`` m apart, margins taken) close around ``points``."""
    return pinch_width(points, front.outward, long_axis(points, front.basis)) <= span


def reach_depth(base: float | None, top: float, bottom: float, gripper: GripperConfig) -> float:
    """The TCP's level along the outward direction for a pinch on a feature spanning levels ``bottom`` to
    ``top``: the fingertips :data:`TIP_CLEARANCE` above the surface it stands on (level ``base``), or just
    below its bottom when it stands free (``base`` None: a bucket's bail); or, for a feature standing out
    further than the pads are long, the pads' back at its top."""
    floor = bottom - TIP_CLEARANCE if base is None else base + TIP_CLEARANCE
    tips = max(floor, top - gripper.finger_length + TIP_CLEARANCE)
    return tips + gripper.tip_beyond_tcp


#: Holding a sloped feature (a dome-shaped knob): the pads hold by friction only where the feature's sides
#: rise no more steeply than this (lateral change per side per unit height, 0.5: 27 degrees from the pull)
#: over :data:`WALL_BAND` (m) above the fingertips; below a steeper flange (the dome's wide foot) the pads,
#: pulled, slide up the slope and off the cap. Widths are measured in :data:`WALL_BIN` (m) slices.
MAX_WALL_SLOPE = 0.5
WALL_BAND = 0.006
WALL_BIN = 0.003


def _width_at(depth: np.ndarray, across: np.ndarray, level: float) -> float | None:
    """The feature's width across the closing direction in the :data:`WALL_BIN` slice above ``level``."""
    s = across[(depth >= level) & (depth < level + WALL_BIN)]
    return float(np.ptp(s)) if len(s) >= 4 else None


def holding_level(candidate: Candidate, front: Front, gripper: GripperConfig) -> float | None:
    """The level the fingertips should reach down to so that the pads close on sides they can hold: the
    candidate's own when its sides there are steep (a bar, a boss, a knob's neck), else the lowest level
    (in :data:`WALL_BIN` steps) above it whose sides over :data:`WALL_BAND` rise by at most
    :data:`MAX_WALL_SLOPE` and above which the feature still stands :data:`RAISED_MIN` (a dome's upper cap,
    not its wide foot). None: keep the candidate as it is (too few points to tell, or no such level)."""
    n = front.outward
    closing = np.cross(n, candidate.long_axis(front))
    closing = closing / max(float(np.linalg.norm(closing)), 1e-12)
    depth, across = candidate.points @ n, candidate.points @ closing
    top, bottom = float(depth.max()), float(depth.min())
    tips = reach_depth(candidate.base, top, bottom, gripper) - gripper.tip_beyond_tcp
    start = level = max(tips, bottom)  # the pads close on nothing below the feature's bottom
    while level <= top - RAISED_MIN:
        low, high = _width_at(depth, across, level), _width_at(depth, across, level + WALL_BAND)
        if low is None or high is None:
            return None
        if (low - high) / (2 * WALL_BAND) <= MAX_WALL_SLOPE:
            return None if level <= start + 1e-9 else level
        level += WALL_BIN
    return None


def sides_hold(mesh, point: np.ndarray, outward: np.ndarray, closing: np.ndarray, long_axis: np.ndarray,
                         tips: float, gripper: GripperConfig) -> bool:
    """Whether the pads can hold ``mesh``'s sides at a pinch. Given the grasped part's collision shapes (world
    frame, at rest), which the physics squeezes, not the visual surface the candidate was read from: a convex
    hull taken of a whole rosette knob (its dome and its boss in one) is a cone, its sides rise like the
    dome's, the boss's wall is gone, and the pads, squeezed and pulled, slide off it.

    Inside the open pads' sweep (across the closing direction out to the open pads' outer faces, along the
    handle the pads' height), the shape's width is measured in :data:`WALL_BIN` slices from one above the
    fingertips' level ``tips`` (that one holds the surface the handle stands on, which the tips reach down
    to) up to its top there; it fails to hold only when its sides rise by more than
    :data:`MAX_WALL_SLOPE` over :data:`WALL_BAND` at every level where that can be measured (a slice as
    wide as the sweep is a surface the pads come down on, not a side, and is not measured; the upper slice
    of a pair may be the feature's crest, cut short by its top). Nothing to measure (no collision shape at
    the handle, a handle reaching less than :data:`WALL_BIN` + :data:`WALL_BAND` above the tips): True,
    nothing to judge: this check passes a candidate over only on evidence.

    The same check on the part's *visual* surface (``mesh`` the part's own, :mod:`spark_bench.manipulation.grasp`)
    judges the candidate's sides over the whole height the pads grip, the part below the handle search's
    proud cut (:data:`~spark_bench.manipulation.handle_search.HANDLE_MIN_PROUD`) included: a low rounded rib on a
    lid, 13 mm proud, is a candidate by its top 3 mm, but its flanks rise 1.5 sideways per unit of height
    all the way down, and the pads slide off them.

    :param point: the grasp point (TCP)
    :param tips: the fingertips' level along ``outward``
    """
    from spark_bench.manipulation.pads import clipped_vertices, near_box

    frame = np.stack([closing, long_axis, outward])
    reach = gripper.max_opening + gripper.pad_thickness
    half = 0.5 * gripper.pad_height
    base = tips - float(point @ outward)
    near = near_box(mesh, point, frame, [-reach, -half, base], [reach, half, np.inf])
    if near is None:
        return True
    inside = clipped_vertices(near, point, frame, [-reach, -half, base], [reach, half, np.inf])
    if len(inside) == 0:
        return True
    top = float(inside[:, 2].max())

    def width(level: float) -> float | None:
        s = clipped_vertices(near, point, frame, [-reach, -half, level], [reach, half, level + WALL_BIN])
        if len(s) == 0:
            return None
        w = float(np.ptp(s[:, 0]))
        return None if w >= 2 * reach - 1e-4 else w

    # the tips' own slice holds the surface they reach down to; the upper slice of a pair need only reach
    # into the feature (a low rounded rib, 12 mm proud, is measured from 3 to 9 mm: what the pads grip)
    level, measured = base + WALL_BIN, False
    while level + WALL_BAND < top - 1e-9:
        low, high = width(level), width(level + WALL_BAND)
        if low is not None and high is not None:
            if (low - high) / (2 * WALL_BAND) <= MAX_WALL_SLOPE:
                return True
            measured = True
        level += WALL_BIN
    return not measured


def local_patches(points: np.ndarray, order: np.ndarray, front: Front, span: float, radius: float,
                  gripper: GripperConfig, limit: int = MAX_PATCHES) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Pinchable pieces of a feature too wide to pinch whole (a safe's wheel: stretches of its spokes):
    around a seed point, tried in ``order`` (seeds at least ``radius`` apart, at most
    :data:`MAX_PATCH_SEEDS`), the feature's points within ``radius`` (in the front plane) give the piece's
    long direction; the piece is then everything of the feature inside the open pads' sweep there (the
    pads' height along it, their reach across it), and it fits when that is narrower than ``span``: no
    other stretch of the feature stands where a pad comes down. ``radius`` is larger than half the span,
    so a flat panel never fits. Returns up to ``limit`` pieces, in seed order, each
    ``(piece, seed, long direction)``."""
    uv = points @ front.basis.T
    reach = gripper.max_opening + gripper.pad_thickness + PINCH_MARGIN
    half_height = 0.5 * gripper.pad_height + PINCH_MARGIN
    seeds: list[np.ndarray] = []
    out = []
    for i in order:
        if any(np.linalg.norm(uv[i] - s) < radius for s in seeds):
            continue
        seeds.append(uv[i])
        near = np.linalg.norm(uv - uv[i], axis=1) < radius
        if near.sum() >= MIN_CLUSTER:
            along = long_axis(points[near], front.basis) @ front.basis.T
            across = np.array([-along[1], along[0]])
            rel = uv - uv[i]
            sweep = (np.abs(rel @ along) <= half_height) & (np.abs(rel @ across) <= reach)
            if sweep.sum() >= MIN_CLUSTER and np.ptp(rel[sweep] @ across) <= span:
                out.append((points[sweep], points[i], along @ front.basis))
                if len(out) >= limit:
                    break
        if len(seeds) >= MAX_PATCH_SEEDS:
            break
    return out


def raised_piece(points: np.ndarray, front: Front, span: float) -> list[Candidate]:
    """Pieces of a feature too wide to pinch whole that stand out of the rest of it (a rosette's boss):
    at the lowest level (in :data:`RAISED_STEP` steps) where the points above it split into clusters that
    fit and stand :data:`RAISED_MIN` above the level, those clusters, gripped down to that level."""
    depth = points @ front.outward
    top = float(depth.max())
    level = float(depth.min()) + RAISED_STEP
    while level <= top - RAISED_MIN:
        above = np.flatnonzero(depth > level)
        found = [Candidate(points[above[g]], None, level) for g in clusters(points[above])
                 if len(g) >= MIN_CLUSTER and float(depth[above[g]].max()) - level >= RAISED_MIN
                 and fits(points[above[g]], front, span)]
        if found:
            return found
        level += RAISED_STEP
    return []


def candidates(points: np.ndarray, groups: list[tuple], front: Front, gripper: GripperConfig, on_handle
               ) -> tuple[list[Candidate], float | None]:
    """Pinchable candidates among ``groups`` (``(indices into points, anchor, base)``: anchor the ``(origin,
    axis)`` of the handle's own hinge or None, base the level the pads may reach down to), and the width of
    the widest feature with no pinchable piece (or None).

    :param on_handle: maps a group's points to those to grasp (a bail's far end)
    """
    span = 2 * gripper.max_opening - 2 * PINCH_MARGIN
    radius = 0.5 * span + gripper.pad_thickness
    out, widest = [], None
    for g, anchor, base in groups:
        whole = on_handle(points[g])
        if anchor is None and fits(whole, front, span):
            out.append(Candidate(whole, None, base))
            continue
        if anchor is not None:  # held near its own hinge's axis, where the pull does not turn it
            o, a = anchor
            r = points[g] - o
            order = np.argsort(np.linalg.norm(r - np.outer(r @ a, a), axis=1))
        else:
            raised = raised_piece(points[g], front, span)
            if raised:
                out.extend(raised)
                continue
            order = np.argsort(front.point_scores(points[g]))
        patches = local_patches(points[g], order, front, span, radius, gripper)
        out.extend(Candidate(piece, seed @ front.basis.T, base, along, alternate=k > 0)
                   for k, (piece, seed, along) in enumerate(patches))
        if not patches:
            widest = max(widest or 0.0, pinch_width(whole, front.outward, long_axis(whole, front.basis)))
    for candidate in out:  # a dome: pinch its cap above the steep foot, where the sides hold the pads
        level = holding_level(candidate, front, gripper)
        if level is not None:
            candidate.base = level
    return out, widest


def pad_center(candidate: Candidate, front: Front, gripper: GripperConfig) -> np.ndarray:
    """The 2-D point (front plane) the pads are centred on: the middle of the candidate across its long
    direction; along it, its middle or its seed, moved in so that the pads lie on the handle."""
    axis2 = candidate.long_axis(front) @ front.basis.T
    uv = candidate.points @ front.basis.T
    middle = 0.5 * (uv.min(0) + uv.max(0))
    if candidate.center is None:
        return middle
    along = uv @ axis2 - float(middle @ axis2)
    half = 0.5 * float(along.max() - along.min())
    mid = 0.5 * float(along.max() + along.min())
    room = max(half - 0.5 * gripper.pad_height - PINCH_MARGIN, 0.0)
    return middle + axis2 * (mid + float(np.clip((candidate.center - middle) @ axis2 - mid, -room, room)))


#: Edge pinch: how far (m) behind the front face the fingertips go to hold the front's edges, deepest
#: first, and the room (m) kept between the pads' sweep and any other part.
EDGE_GRIP_DEPTHS = (0.015, 0.01, 0.006)
EDGE_CLEARANCE = 0.002


def edge_pinch(front: Front, others, gripper: GripperConfig) -> tuple[np.ndarray, np.ndarray, float] | None:
    """A pinch across the whole front, by its two edges (a table's shallow drawer front standing out of
    its apron): when the front face is narrower one way than the open fingers (margins taken) and nothing
    of the other parts stands in the pads' sweep beside those edges down to a grip depth of
    :data:`EDGE_GRIP_DEPTHS`. Returns ``(point, long_axis, depth)`` (the TCP, the direction along the
    edges, the grip depth) or None.

    :param front: the part's front
    :param others: the rest of the object's mesh (world, at rest), or None
    """
    from spark_bench.manipulation.features import LEVEL_BIN
    from spark_bench.manipulation.pads import clipped_vertices, near_box

    n, basis = front.outward, front.basis
    face_points = front.points[np.abs(front.points @ n - front.face) < 2 * LEVEL_BIN]
    if len(face_points) < MIN_CLUSTER:
        return None
    uv = face_points @ basis.T
    _, vectors = np.linalg.eigh(np.cov((uv - uv.mean(0)).T))
    span = 2 * gripper.max_opening - 2 * PINCH_MARGIN
    for across in (vectors[:, 0], vectors[:, 1]):  # the narrow way first
        extent = uv @ across
        if np.ptp(extent) > span:
            continue
        along = np.array([-across[1], across[0]])
        closing, long3 = across @ basis, along @ basis
        middle = 0.5 * (extent.min() + extent.max()) * across + 0.5 * ((uv @ along).min() + (uv @ along).max()) * along
        half, reach = 0.5 * float(np.ptp(extent)), gripper.max_opening + gripper.pad_thickness + EDGE_CLEARANCE
        height = 0.5 * gripper.pad_height + EDGE_CLEARANCE
        frame = np.stack([closing, long3, n])
        low = -gripper.tip_beyond_tcp - EDGE_CLEARANCE
        # what of the other parts may stand in any of the sweeps below, cut out once (a real object's 10^6
        # triangles): the deepest grip's sweep holds the shallower ones'
        deepest = middle @ basis + (front.face - max(EDGE_GRIP_DEPTHS) + gripper.tip_beyond_tcp) * n
        near = near_box(others, deepest, frame, [-reach, -height, low], [reach, height, np.inf])
        for depth in EDGE_GRIP_DEPTHS:
            center = middle @ basis + (front.face - depth + gripper.tip_beyond_tcp) * n
            blocked = any(len(clipped_vertices(near, center, frame, lo, hi)) for lo, hi in (
                ([half + EDGE_CLEARANCE, -height, low], [reach, height, np.inf]),
                ([-reach, -height, low], [-half - EDGE_CLEARANCE, height, np.inf])))
            if not blocked:
                return center, long3, depth
    return None
