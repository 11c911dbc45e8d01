"""Rest trimming: the hulls of a part and of its parent cut apart where they overlap at rest.

Convex hulls bulge past the surface they wrap (CoACD's by up to about 1 % of a part's size), so on a real object a
door's hulls overlap its cabinet's along the frame, a lid's its box's along the rim. A pair that collides
(:mod:`spark_bench.sim.phantom` decides which do, from the part's own path, judged on hulls cut this way as if
every pair collided; the cuts are then made again for the pairs that collide only, so that an excluded pair keeps
its hulls whole, as they meet the other parts and a gripper too) must not start pushed apart: each of
its hull pairs that overlaps at rest by more than ``ConvertOptions.trim_overlap`` of the object's size (by
default: at all) is cut apart along the direction of least penetration (the contact normal MuJoCo finds), leaving
half the clearance between them: the part's hull is cut back to the plane of the parent hull's nearest extent, or,
where that would remove more than :data:`MAX_REMOVED` of the part's hull, the parent's hull is cut back to the
part's instead (a convex hull cut by a plane stays convex: :func:`~spark_bench.sim.relief.cut_hull`); where both
would, the cut that removes less volume is made, a hull cut down to nothing is dropped, as long as the link keeps
all but :data:`TRIM_BUDGET` of its hull volume. A slab as thick as the overlap is all a cut removes: a part that
moves into its body (a door turned the wrong way, a drawer pushed instead of pulled) meets the body's hulls as it
would meet the body.

An overlap that no cut within that budget resolves is by construction (a knob's shaft through its panel, a cap
screwed over a bottle neck): that pair is excluded body-wide, and the report names it (``excluded`` in
``conversion.json`` and the checks' details)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.bounds import body_pose
from spark_bench.sim.contacts import geometric_parents
from spark_bench.sim.relief import MAX_REMOVED, as_mesh, cut_hull, summarize_cuts
from spark_bench.sim.shapes import CollisionShape

#: Passes of find-overlaps-then-cut (a cut can leave a shallower overlap with a neighbouring hull; a hull is cut
#: once per pass).
PASSES = 8
#: Rest trimming may take at most this fraction of a link's hull volume, all cuts together; within it a hull may be
#: cut by more than :data:`MAX_REMOVED`, down to nothing (a sliver of a lid's rim buried in the box wall's hull, an
#: edge strip of a safe door inset in its frame: what is cut away lay inside the neighbour's hull). An overlap
#: beyond it is by construction (a knob's shaft through its panel).
TRIM_BUDGET = 0.25


@dataclass
class RestOverlap:
    """The deepest contact of one hull pair of a parent and its child at rest.

    :param parent: the parent link
    :param child: the child link
    :param parent_hull: index of the parent's hull
    :param child_hull: index of the child's hull
    :param depth: penetration (m)
    :param normal: unit direction of least penetration, from the child's hull towards the parent's (world)
    """

    parent: str
    child: str
    parent_hull: int
    child_hull: int
    depth: float
    normal: np.ndarray


@dataclass
class TrimCut:
    """One cut: ``link``'s hull ``geom`` cut back from ``other`` where the two overlapped at rest.

    :param depth: the overlap removed (m)
    :param removed: fraction of the hull's volume removed
    """

    link: str
    geom: str
    other: str
    depth: float
    removed: float

    def to_dict(self) -> dict:
        return {"link": self.link, "geom": self.geom, "other": self.other, "depth": round(self.depth, 6),
                "removed": round(self.removed, 4)}


def _hull_index(name: str, link: str) -> int | None:
    prefix = f"{link}_collision_"
    rest = name[len(prefix):]
    return int(rest) if name.startswith(prefix) and rest.isdigit() else None


def rest_overlaps(model, data, pairs: set[tuple[str, str]], limit: float = 0.0) -> list[RestOverlap]:
    """The hull pairs of the ``(parent, child)`` body ``pairs`` that overlap deeper than ``limit`` (m) at the
    model's rest pose, deepest first (one entry per hull pair: its deepest contact).

    :param model: the compiled model (every parent-child contact on)
    :param data: its ``MjData``
    """
    mujoco = mujoco_module()
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    found: dict[tuple, RestOverlap] = {}
    for contact in data.contact[: data.ncon]:
        depth = -float(contact.dist)
        if depth <= limit:
            continue
        g1, g2 = int(contact.geom1), int(contact.geom2)
        b1, b2 = (model.body(model.geom_bodyid[g]).name for g in (g1, g2))
        normal = np.array(contact.frame[:3], float)  # from geom1 towards geom2
        if (b2, b1) in pairs:  # geom1 is the child's
            parent, child, gp, gc = b2, b1, g2, g1
        elif (b1, b2) in pairs:
            parent, child, gp, gc, normal = b1, b2, g1, g2, -normal
        else:
            continue
        hp, hc = _hull_index(model.geom(gp).name, parent), _hull_index(model.geom(gc).name, child)
        if hp is None or hc is None:
            continue
        key = (parent, child, hp, hc)
        if key not in found or depth > found[key].depth:
            found[key] = RestOverlap(parent, child, hp, hc, depth, normal)
    return sorted(found.values(), key=lambda o: (-o.depth, o.parent, o.child, o.parent_hull, o.child_hull))


def _world_vertices(shape: CollisionShape, pose: np.ndarray) -> np.ndarray:
    vertices = np.asarray(shape.to_trimesh().vertices, float)
    return vertices @ pose[:3, :3].T + pose[:3, 3]


def _cut_back(shape: CollisionShape, pose: np.ndarray, normal: np.ndarray, limit: float):
    """``shape`` (at world ``pose``) cut to the half-space ``normal . x <= limit`` (world), as
    :func:`~spark_bench.sim.relief.cut_hull` returns it: ``(shape, removed fraction)`` or None."""
    local_normal = pose[:3, :3].T @ normal
    return cut_hull(as_mesh(shape), local_normal, float(limit - normal @ pose[:3, 3]))


def _part(o: RestOverlap, data, model, prepared, gap: float) -> list[tuple]:
    """The ways to part the two hulls of ``o``, the part's hull first: ``(link, hull index, shape, pose, normal,
    bound, other geom)``, each a cut of one hull to ``normal . x <= bound`` (world)."""
    child_pose, parent_pose = body_pose(data, model.body(o.child).id), body_pose(data, model.body(o.parent).id)
    child_shape = prepared.shapes[o.child][o.child_hull]
    parent_shape = prepared.shapes[o.parent][o.parent_hull]
    nearest_parent = float(np.min(_world_vertices(parent_shape, parent_pose) @ o.normal))
    farthest_child = float(np.max(_world_vertices(child_shape, child_pose) @ o.normal))
    return [(o.child, o.child_hull, child_shape, child_pose, o.normal, nearest_parent - gap,
             f"{o.parent}_collision_{o.parent_hull}"),
            (o.parent, o.parent_hull, parent_shape, parent_pose, -o.normal, -(farthest_child + gap),
             f"{o.child}_collision_{o.child_hull}")]


def _choose_cut(ways: list[tuple], budget: dict[str, float]) -> tuple | None:
    """The cut to make of ``ways`` (:func:`_part`): the first that removes at most :data:`MAX_REMOVED` of its hull,
    else the one that removes the least volume; None when it would exceed its link's ``budget`` (m^3 left).
    Returns ``(way, new shape or None to drop the hull, removed fraction, removed volume)``."""
    options = []
    for way in ways:
        link, _, shape, pose, normal, bound, _ = way
        result = _cut_back(shape, pose, normal, bound)
        if result is None:
            return None
        before = shape.volume()
        removed = float(result[1])
        kept = None if removed >= 1.0 - 1e-9 else result[0]
        options.append((way, kept, removed, removed * before))
    fitting = [o for o in options if o[3] <= budget[o[0][0]]]
    gentle = [o for o in fitting if o[2] <= MAX_REMOVED]
    if gentle:
        return gentle[0]
    return min(fitting, key=lambda o: o[3]) if fitting else None


def trim_rest_overlaps(prepared, compile_model, limit: float, gap: float) -> tuple[list[TrimCut], dict]:
    """Cut the hulls of ``prepared.shapes`` in place until no parent-child hull pair overlaps at rest deeper
    than ``limit``; returns the cuts and the pairs left overlapping (``{(parent, child): depth}``, to be
    excluded: no cut within a link's :data:`TRIM_BUDGET` parts them).

    :param prepared: a :class:`~spark_bench.sim.prepared.PreparedObject`
    :param compile_model: ``() -> MjModel`` of the current shapes, every parent-child contact on
    :param limit: overlaps this deep or shallower are left as they are (m)
    :param gap: clearance left between the two hulls by a cut (m)
    """
    mujoco = mujoco_module()
    pairs = {(parent, child) for child, parent in geometric_parents(prepared).items()}
    budget = {link: TRIM_BUDGET * float(sum(s.volume() for s in shapes)) for link, shapes in prepared.shapes.items()}
    cuts: list[TrimCut] = []
    unresolved: dict[tuple[str, str], float] = {}
    for _ in range(PASSES):
        model = compile_model()
        data = mujoco.MjData(model)
        overlaps = [o for o in rest_overlaps(model, data, pairs, limit) if (o.parent, o.child) not in unresolved]
        if not overlaps:
            break
        touched: set[tuple[str, int]] = set()  # a hull cut in this pass: its other overlaps wait for the next
        dropped: set[tuple[str, int]] = set()
        for o in overlaps:
            if {(o.child, o.child_hull), (o.parent, o.parent_hull)} & touched:
                continue
            chosen = _choose_cut(_part(o, data, model, prepared, gap), budget)
            if chosen is None:
                pair = (o.parent, o.child)
                unresolved[pair] = max(unresolved.get(pair, 0.0), o.depth)
                continue
            (link, index, _, _, _, _, other), kept, removed, volume = chosen
            budget[link] -= volume
            touched.add((link, index))
            if kept is None:
                dropped.add((link, index))
            else:
                prepared.shapes[link][index] = kept
            cuts.append(TrimCut(link, f"{link}_collision_{index}", other, o.depth, removed))
        for link in {link for link, _ in dropped}:  # hull indices shift once a pass is done with them
            gone = {index for name, index in dropped if name == link}
            prepared.shapes[link] = [s for k, s in enumerate(prepared.shapes[link]) if k not in gone]
    else:  # what the last pass's cuts left
        model = compile_model()
        for o in rest_overlaps(model, mujoco.MjData(model), pairs, limit):
            pair = (o.parent, o.child)
            unresolved[pair] = max(unresolved.get(pair, 0.0), o.depth)
    return cuts, unresolved


def summarize_trim(cuts: list[TrimCut]) -> dict:
    """Rest-trimming cuts per link: the hulls cut, the deepest overlap removed (m)."""
    return summarize_cuts(cuts, "link", 6)
