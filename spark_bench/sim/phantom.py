"""Phantom blockings: a part stopped by its parent's convex hulls where the parent's own surface leaves it room,
and the rule that decides which parts and parents do not collide.

Convex hulls fill holes and recesses and bulge past the surface they wrap. A button sits in a hole of its keypad,
a suitcase's latch button in a slot of the shell: the parent's hull covers the hole, so the button cannot be
pressed by even a millimetre, although nothing in the object stops it; a door's hulls overlap its cabinet's along
the frame at rest. A real blocking (a drawer pushed backwards into its carcass, a door turned the wrong way, a
button longer than its hole) has the parent's *surface* in the way.

So for every link whose geometric parent (:func:`~spark_bench.sim.contacts.geometric_parents`) is moved against by
exactly one joint, and for every link a joint carries beyond its child (a handle on a door) against the link that
child hangs on (:func:`phantom_candidates`), that joint is stepped kinematically over its range. Where the link's
hulls meet the parent's (deeper than ``tolerance`` at some step, or overlapping at rest) while the link's own path
is free of the parent's surface, the pair is excluded from collision (:mod:`spark_bench.sim.contacts`). The path is
free when

- the parent's visual surface (its vertices and area samples near the link's path) enters the link no deeper than
  :func:`allowed_depth` (a fraction of the object's, the link's and its travel's size) at every step up to
  :data:`~spark_bench.sim.free_path.DEPTH_REACH` of the range (conv-10: what the part meets beyond, shallowly, is
  its stop), inside the link's hulls and no farther from the link's own surface than that (:func:`surface_depth`);
- and fewer than :data:`CROSSING_BLOCK` of the link's own surface points cross the parent's surface on the way
  (:func:`part_crossing`): the depth is bounded by how thick the link is, and a thin door turned through its
  cabinet's wall shows a shallow depth while most of its surface crosses the wall.

Every exclusion is recorded (:class:`PhantomBlock`) and reported by the checks. The exclusion is decided on the
joint's own path, so a part that moves the wrong way keeps colliding with its body.

Next to a hinge's axis (the hinge relief's zone, :mod:`spark_bench.sim.relief`) a surface sample counts only
when it enters deeper than the relief's depth limit (:func:`zone_depth`): a handle's knuckle sits in its bracket
with no modelled clearance, and a triangle soup's inside cannot be told there (box 48492's side handle: the body's
surface 1.17 mm "inside" the handle's hulls at one of 60 000 samples, 8-10 mm from the axis; elsewhere 0.59 mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from spark_bench.asset.model import ArticulatedAsset, Joint
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.bounds import body_pose
from spark_bench.sim.contacts import geometric_parents
from spark_bench.sim.free_path import DEPTH_REACH, allowed_depth, part_crossing
from spark_bench.sim.relief import HINGE_ZONE, MAX_DEPTH, hinge_radius, joint_bodies
from spark_bench.sim.solid import Solid, inside_pieces

#: Joint values tried per range (at least; hinges get one per ``1 / STEPS_PER_RADIAN`` rad).
STEPS = 12
STEPS_PER_RADIAN = 16
#: Most surface points of the parent tested against the link's hulls per pair.
MAX_POINTS = 60_000
#: Points whose distance to the moving part's surface is computed at once (:func:`surface_depth`).
SURFACE_CHUNK = 256
#: Points tested at once for lying inside a closed part, deepest first (:func:`surface_depth`).
INSIDE_BATCH = 16
#: A part whose own path takes at least this fraction of its surface points across its neighbour's surface passes
#: through it: the pair collides (:func:`part_crossing`). Chosen on partnet_dev's tune half, between the crossings
#: of intact parts and those of the same parts turned into their bodies; a turned part that crosses less is caught
#: by its depth (:func:`allowed_depth`) instead. Its effect is measured in benchmarks/results/check_validity.md.
CROSSING_BLOCK = 0.2


@dataclass
class PhantomBlock:
    """``child``'s hulls meet ``parent``'s, at rest or while ``joint`` moves, and ``child``'s own path is free of
    ``parent``'s surface (:func:`find_phantom_blocks`).

    :param first: fraction of the joint's range where the hulls first meet deeper than the tolerance (0: at rest)
    :param depth: deepest hull-hull penetration, at rest or along the range (m)
    :param surface_depth: deepest entry of the parent's surface into the child (m; see :func:`surface_depth`),
        resolved only above the tolerance: a value equal to it means "at most the tolerance"
    :param crossing: fraction of the child's surface points that cross the parent's surface along the path
        (:func:`part_crossing`)
    """

    parent: str
    child: str
    joint: str
    first: float
    depth: float
    surface_depth: float
    crossing: float = 0.0

    def to_dict(self) -> dict:
        return {"parent": self.parent, "child": self.child, "joint": self.joint, "first": round(self.first, 4),
                "depth": round(self.depth, 6), "surface_depth": round(self.surface_depth, 6),
                "crossing": round(self.crossing, 4)}


def single_joint(asset: ArticulatedAsset, parent: str, child: str) -> Joint | None:
    """The one movable joint between ``parent`` and its descendant ``child`` (None if none or several)."""
    movable, link = [], child
    while link != parent:
        joint = asset.joint_of_child(link)
        if joint is None:
            return None
        if joint.is_movable:
            movable.append(joint)
        link = joint.parent
    return movable[0] if len(movable) == 1 else None


def joint_steps(joint: Joint) -> np.ndarray:
    """The joint values tried: its range from rest, rest excluded."""
    lower, upper = float(joint.lower), float(joint.upper)
    span = upper - lower
    count = max(STEPS, int(np.ceil(abs(span) * STEPS_PER_RADIAN))) if joint.is_rotational else STEPS
    return lower + span * np.linspace(0.0, 1.0, count + 1)[1:]


def _hull_depth(model, data, body_a: int, body_b: int) -> float:
    """Deepest contact between collision geoms of two bodies (m, positive = penetration)."""
    deepest = 0.0
    for contact in data.contact[: data.ncon]:
        pair = {int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])}
        if pair == {body_a, body_b}:
            deepest = max(deepest, -float(contact.dist))
    return deepest


def _halfspaces(prepared, link: str) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per hull of ``link`` (link frame): its ``(k, 4)`` face planes ``n . x + d <= 0`` and its box."""
    out = []
    for shape in prepared.shapes.get(link, []):
        vertices = np.asarray(shape.to_trimesh().vertices, float)
        try:
            out.append((ConvexHull(vertices).equations, vertices.min(0), vertices.max(0)))
        except (QhullError, ValueError):
            continue
    return out


def surface_points(vertices: np.ndarray, faces: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                   spacing: float, seed: int = 0) -> np.ndarray:
    """Vertices and area samples (about ``spacing`` apart, at most :data:`MAX_POINTS`) of the triangles
    whose bounding box meets the box ``[lo, hi]``."""
    tri = vertices[faces]
    near = np.all(tri.min(1) <= hi, axis=1) & np.all(tri.max(1) >= lo, axis=1)
    tri = tri[near]
    if len(tri) == 0:
        return np.zeros((0, 3))
    corners = np.unique(tri.reshape(-1, 3), axis=0)
    rng = np.random.default_rng(seed)
    if len(corners) > MAX_POINTS:  # a random subset: ``np.unique`` sorts, a slice would keep one side only
        corners = corners[np.sort(rng.choice(len(corners), size=MAX_POINTS, replace=False))]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = float(area.sum())
    count = int(min(MAX_POINTS - len(corners), total / max(spacing, 1e-9) ** 2))
    if count <= 0 or total <= 0:
        return corners
    pick = rng.choice(len(tri), size=count, p=area / total)
    u, v = rng.random((2, count))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[pick]
    samples = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    return np.concatenate([corners, samples])


def surface_depth(points: np.ndarray, hulls: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                  surface=None, floor: float = 0.0, solid: Solid | None = None) -> float:
    """How deep the deepest of ``points`` lies inside the moving part; 0 when none is inside.

    Without ``surface``: the depth inside any of the part's convex ``hulls`` (planes and box, as
    :func:`_halfspaces` gives them). With ``surface`` (the part's own mesh, a :class:`trimesh.Trimesh` in
    the same frame): each point counts as deep as the smaller of its hull depth and its distance to that
    surface. A hull bulges out of the part it wraps (CoACD's by up to about 1 % of the part's size), so
    a point can lie inside a hull and just outside the part; a point inside the part's solid is inside a
    hull too, and its distance to the surface is its penetration. The smaller of the two is thus an
    upper bound of the true penetration, exact for points inside the solid. (Whether a point is inside
    the solid cannot be told reliably for most parts: PartNet-Mobility meshes are triangle soups with
    faces wound either way, so a winding number says 0 inside a closed plank. A point in a recess the
    hull fills still counts, as deep as it is far from the surface.) Where the part's mesh is closed
    (``solid``, :func:`~spark_bench.sim.solid.closed_solid`), only the points inside it count: the
    bound is then the penetration itself (conv-11).

    :param floor: depths at or below this are not worth resolving (the caller's tolerance): the result
        is exact above it, and at most ``floor`` otherwise
    :param solid: the part's closed pieces (same frame as ``surface``), or None where it is not closed
    """
    depth = np.zeros(len(points))
    if not hulls:
        return 0.0
    # most points lie outside the part's box altogether: test only the others against each hull's box
    near = np.flatnonzero(((points >= np.min([h[1] for h in hulls], axis=0))
                           & (points <= np.max([h[2] for h in hulls], axis=0))).all(axis=1))
    candidates = points[near]
    for planes, lo, hi in hulls:
        inside = near[((candidates >= lo) & (candidates <= hi)).all(axis=1)]  # outside the box: outside
        if len(inside):
            signed = points[inside] @ planes[:, :3].T + planes[:, 3]  # <= 0 inside every face
            depth[inside] = np.maximum(depth[inside], -signed.max(axis=1))
    deepest = float(max(depth.max(initial=0.0), 0.0))
    if surface is None or deepest <= floor:
        return deepest
    # the deepest points first; a point's bound is at most its hull depth, so stop once the best
    # bound found is at least the hull depth of every point left
    order = np.argsort(-depth)
    order = order[depth[order] > floor]
    best = 0.0
    for start in range(0, len(order), SURFACE_CHUNK):
        chunk = order[start:start + SURFACE_CHUNK]
        if depth[chunk[0]] <= best:
            break
        _, distance, _ = surface.nearest.on_surface(points[chunk])
        bound = np.minimum(depth[chunk], distance)
        if solid is not None:  # only a point that would raise ``best`` needs the (costly) inside test
            bound = _inside_bound(points[chunk], bound, best, solid)
        best = max(best, float(np.max(bound)))
    return best if best > floor else min(deepest, floor)


def _inside_bound(points: np.ndarray, bound: np.ndarray, best: float, solid: Solid) -> np.ndarray:
    """``bound`` where the point lies inside the ``solid``, else 0, for the points whose bound exceeds ``best``
    (the others are left as they are: they cannot raise it). Tested deepest first, a few at a time, up to the first
    inside: no point after it can raise the maximum past its bound."""
    out = np.where(bound > best, 0.0, bound)
    order = np.argsort(-bound)
    order = order[bound[order] > best]
    for start in range(0, len(order), INSIDE_BATCH):
        batch = order[start:start + INSIDE_BATCH]
        found = inside_pieces(points[batch], solid)
        if found.any():
            out[batch[found]] = bound[batch[found]]
            break
    return out


@dataclass
class HingeZone:
    """Where a turning part's pivot is, in the moving link's frame: surface samples within ``reach``
    of the axis line count only when deeper than ``depth`` (:func:`zone_depth`).

    :param anchor: a point of the hinge axis
    :param axis: its unit direction
    :param reach: the zone's radius about the axis (``HINGE_ZONE`` of the part's radius, as the relief's)
    :param depth: deepest entry ignored there (``MAX_DEPTH`` of the part's radius, as the relief's)
    """

    anchor: np.ndarray
    axis: np.ndarray
    reach: float
    depth: float

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which of ``points`` lie within ``reach`` of the axis line."""
        offset = points - self.anchor
        return np.linalg.norm(offset - np.outer(offset @ self.axis, self.axis), axis=1) <= self.reach


def zone_depth(points: np.ndarray, hulls, surface, tolerance: float, zone: HingeZone | None,
               solid: Solid | None = None) -> float:
    """:func:`surface_depth` of ``points`` with the hinge zone exempt, as the hinge relief exempts hull
    contacts there (:mod:`spark_bench.sim.relief`).

    Next to a pivot the two parts interleave by construction (a handle's knuckle in its bracket, a
    lid's hinge leaf in the box's back wall) with no modelled clearance, and the hulls there are
    relieved rather than trusted. A surface sample within ``zone.reach`` of the axis therefore counts
    only when it enters deeper than ``zone.depth``, the depth the relief would refuse to cut; a sample
    farther out counts from ``tolerance``, as before. ``zone=None`` (a slide): every sample counts.
    """
    if zone is None:
        return surface_depth(points, hulls, surface, tolerance, solid)
    near = zone.contains(points)
    out = surface_depth(points[~near], hulls, surface, tolerance, solid)
    if near.any():
        pivot = surface_depth(points[near], hulls, surface, max(tolerance, zone.depth), solid)
        if pivot > max(tolerance, zone.depth):
            out = max(out, pivot)
    return out


@dataclass
class Trace:
    """One link's hulls against another link along one joint's range (:func:`trace`).

    :param steps: the joint values tried
    :param hull_depth: per step, the deepest hull-hull penetration between the two links (m)
    :param surface_depth: per step up to the first real one, how deep the other link's surface enters
        the moving link's hulls (m); shorter than ``steps`` when it stopped there
    """

    steps: np.ndarray
    hull_depth: list[float]
    surface_depth: list[float]

    def first(self, depths: list[float], tolerance: float) -> int | None:
        return next((k for k, d in enumerate(depths) if d > tolerance), None)


def trace(prepared, model, joint: Joint, moving: str, other: str, tolerance: float, stop: bool = True,
          surface_tolerance: float | None = None) -> Trace:
    """Step ``joint`` over its range (every other joint at rest) and measure, at each step, how deep the
    hulls of links ``moving`` and ``other`` interpenetrate, and, where they do, how deep the surface
    of ``other`` (its visual mesh) enters the hulls of ``moving``.

    :param prepared: the prepared object
    :param model: its compiled model (contacts between the two links on)
    :param joint: the joint that moves ``moving`` relative to ``other``
    :param tolerance: hull penetration ignored (m)
    :param stop: stop measuring the surface at the first step where it enters deeper than ``surface_tolerance``
    :param surface_tolerance: surface entry ignored (m; None: ``tolerance``)
    """
    surface_tolerance = tolerance if surface_tolerance is None else surface_tolerance
    mujoco = mujoco_module()
    data = mujoco.MjData(model)
    body_o, body_m = model.body(other).id, model.body(moving).id
    jid = model.joint(joint.name).id
    qadr = model.jnt_qposadr[jid]
    steps = joint_steps(joint)
    turning = joint_bodies(model, jid)
    poses, depths, zones = [], [], []
    for value in steps:
        mujoco.mj_resetData(model, data)
        data.qpos[qadr] = value
        mujoco.mj_forward(model, data)
        depths.append(_hull_depth(model, data, body_o, body_m))
        to_moving = np.linalg.inv(body_pose(data, body_m))
        poses.append(to_moving @ body_pose(data, body_o))  # other -> moving frame
        if joint.is_rotational:  # the hinge zone, in the moving link's frame
            anchor, axis = data.xanchor[jid].copy(), data.xaxis[jid].copy()
            radius = hinge_radius(model, data, turning, anchor, axis)
            zones.append(HingeZone(to_moving[:3, :3] @ anchor + to_moving[:3, 3], to_moving[:3, :3] @ axis,
                                   HINGE_ZONE * radius, MAX_DEPTH * radius))
        else:
            zones.append(None)
    result = Trace(steps, depths, [])
    surface = prepared.visual(other)
    hulls = _halfspaces(prepared, moving)
    if surface is None or not hulls or max(depths, default=0.0) <= tolerance:
        return result
    own = prepared.visual(moving)
    solid = prepared.solid(moving)
    own = None if own is None else trimesh.Trimesh(own[0], own[1], process=False)
    # the other link's surface near the moving link's path, in the other link's frame
    hull_points = np.concatenate([s.to_trimesh().vertices for s in prepared.shapes[moving]])
    path = np.concatenate([hull_points @ np.linalg.inv(p)[:3, :3].T + np.linalg.inv(p)[:3, 3] for p in poses])
    # samples closer than the thinnest hull is thick (at most MAX_POINTS of them)
    spacing = max(tolerance, 0.25 * min(float(np.min(hi - lo)) for _, lo, hi in hulls))
    points = surface_points(surface[0], surface[1], path.min(0) - tolerance, path.max(0) + tolerance, spacing)
    for pose, zone in zip(poses, zones):
        moved = points @ pose[:3, :3].T + pose[:3, 3]
        result.surface_depth.append(zone_depth(moved, hulls, own, surface_tolerance, zone, solid))
        if stop and result.surface_depth[-1] > surface_tolerance:
            break
    return result


def _carried(asset: ArticulatedAsset, joint: Joint) -> list[str]:
    """The links that ``joint`` moves besides its child: the child's descendants."""
    out, todo = [], [joint.child]
    while todo:
        link = todo.pop()
        for j in asset.joints.values():
            if j.parent == link:
                out.append(j.child)
                todo.append(j.child)
    return sorted(out)


def phantom_candidates(prepared) -> list[tuple[str, str, Joint]]:
    """``(parent, link, joint)``: the pairs whose blocking :func:`find_phantom_blocks` examines.

    Each link with its geometric parent, when one movable joint moves it against that parent (a
    button in its keypad); and each link a joint carries beyond its child with the link the joint's
    child hangs on (a safe's handle, mounted on the door, against the safe's body as the door swings).
    """
    asset = prepared.asset
    parents = geometric_parents(prepared)
    out = []
    for child, parent in sorted(parents.items()):
        joint = single_joint(asset, parent, child)
        if joint is not None:
            out.append((parent, child, joint))
    seen = {(p, c) for p, c, _ in out}
    for joint in asset.movable_joints():
        base = parents.get(joint.child)
        if base is None:
            continue
        for link in _carried(asset, joint):
            if prepared.shapes.get(link) and (base, link) not in seen:
                seen.add((base, link))
                out.append((base, link, joint))
    return out


def find_phantom_blocks(prepared, model, tolerance: float, at_rest: dict[tuple[str, str], float] | None = None,
                        skip: set[tuple[str, str]] | frozenset = frozenset(),
                        decided: set[tuple[str, str]] | None = None) -> list[PhantomBlock]:
    """The pairs (:func:`phantom_candidates`) whose hulls meet, at rest or along the joint's path, while the part's
    own path is free of its neighbour's surface: over the :data:`~spark_bench.sim.free_path.DEPTH_REACH` of its
    range that the sweep asks for, that neighbour's surface enters it no deeper than :func:`allowed_depth`, and
    over its whole range fewer than :data:`CROSSING_BLOCK` of its surface points cross that surface
    (:func:`part_crossing`). Such a pair is excluded from collision; any other pair collides (see the module
    docstring).

    :param prepared: a :class:`~spark_bench.sim.prepared.PreparedObject` (its exclusions so far applied
        in ``model``)
    :param model: the compiled model of ``prepared`` with every parent-child contact on
    :param tolerance: hull penetration ignored (m)
    :param at_rest: the deepest hull overlap at rest of each ``(parent, child)`` pair (m)
    :param skip: ``(parent, child)`` pairs not to judge (decided already)
    :param decided: where given, every pair whose hulls meet (and which is thus judged here) is added to it
    """
    at_rest = at_rest or {}
    found = []
    for parent, child, joint in phantom_candidates(prepared):
        if (parent, child) in prepared.excluded or (parent, child) in skip or joint.upper - joint.lower < 1e-9:
            continue
        allowed = allowed_depth(prepared, joint, child, tolerance)
        path = trace(prepared, model, joint, child, parent, tolerance, surface_tolerance=allowed)
        # any meeting counts, however shallow: a shallow bump of a carcass's hull a few mm along a drawer's path
        # held table 31601's drawer against its drive
        blocked = path.first(path.hull_depth, 0.0)
        overlap = at_rest.get((parent, child), 0.0)
        if blocked is None and overlap <= 0.0:
            continue  # the hulls never meet: nothing to decide
        if decided is not None:
            decided.add((parent, child))
        span = joint.upper - joint.lower
        judged = path.steps[:len(path.surface_depth)] - joint.lower <= DEPTH_REACH * span * (1 + 1e-9)
        surface = max(np.asarray(path.surface_depth)[judged], default=0.0)
        if surface > allowed:
            continue  # the neighbour's surface enters the part on the path the sweep asks for: a real blocking
        crossing = part_crossing(prepared, joint, child, parent, enough=CROSSING_BLOCK)
        if crossing >= CROSSING_BLOCK:
            continue  # the part passes through its neighbour
        first = 0.0 if blocked is None or overlap > 0.0 else float((path.steps[blocked] - joint.lower) / span)
        found.append(PhantomBlock(parent, child, joint.name, first, float(max(max(path.hull_depth), overlap)),
                                  float(surface), crossing))
    return found


def explain_blocking(prepared, model, joint_name: str, moving: str, other: str, tolerance: float) -> str:
    """One sentence on a blocked joint: whether ``other``'s surface, not only its hulls, is in the way
    of ``moving`` (and from where, how deep), or ``moving`` passes through it (:func:`part_crossing`, the
    converter's own rule: a thin part turned through a wall enters it shallowly), so that a person knows what
    to fix.

    :param model: the object's model (no actuators needed)
    """
    joint = prepared.asset.joints[joint_name]
    path = trace(prepared, model, joint, moving, other, tolerance, stop=False)
    span = joint.upper - joint.lower
    hull = path.first(path.hull_depth, tolerance)
    real = path.first(path.surface_depth, tolerance)

    def at(k: int) -> str:
        value = path.steps[k]
        where = f"{np.degrees(value):.0f} deg" if joint.is_rotational else f"{1000 * value:.1f} mm"
        return f"{where} ({(value - joint.lower) / span:.0%} of the range)"

    if hull is None:
        return f"{moving} and {other} do not meet when {joint_name} alone moves (another part is in the way)"
    if real is None:
        crossing = part_crossing(prepared, joint, moving, other, enough=CROSSING_BLOCK)
        if crossing >= CROSSING_BLOCK:
            return (f"{moving} passes through {other}: {crossing:.0%} or more of its surface points cross the "
                    f"surface of {other} over the range of {joint_name}, whose hulls meet from {at(hull)}: the "
                    f"object itself blocks {joint_name} there (its joint or its geometry is wrong)")
        return (f"only the hulls of {moving} and {other} meet (from {at(hull)}): the surfaces stay apart, "
                f"a collision-hull artefact")
    return (f"the surface of {other} enters {moving} from {at(real)}, {1000 * max(path.surface_depth):.1f} mm "
            f"deep at most: the object itself blocks {joint_name} there (its range or its geometry is wrong)")
