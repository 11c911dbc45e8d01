"""Hinge relief: bevel a door's hull where it sweeps into its neighbour right next to its hinge.

PartNet-Mobility axes are annotated by hand, often a centimetre or two inside the part (a lid hinged
2.7 cm in from its back edge, an oven door whose lower edge swings into the door below). A real door
has its edge bevelled or its hinge set out so that it clears; the mesh has neither, so the hull of the
edge digs into the neighbour and the door jams after a few degrees. A real blocking (a door hitting a
wall half a metre from its hinge) happens far from the axis.

So for every revolute joint the moving part is swept kinematically over its range; each penetration
whose contact lies within ``zone`` of the axis (a fraction of the part's radius about it) and is at most
``max_depth`` deep is removed by cutting the moving hull with the plane of the neighbour's surface
(a convex hull cut by a plane stays convex). Cuts that would remove more than half of a hull, one by one or
together, are not made: that is a blocking, and the sweep check reports it.

A contact whose normal lies along the hinge axis (cosine at least :data:`AXIAL_COS`) is relieved wherever it
is, provided the moving part already touches that neighbour along the axis at rest and at every sample
up to there (per pair of parts, not of hulls: which hulls touch changes along the turn; per moving
hull, faucet 1646 kept 5 of its 57 cuts and jammed): a part
turning about an axis moves across such a contact, never into it (a faucet lever on its base, a knob
on its panel), so it cannot block the turn. Left in, its penetration pushes the part along the axis
its joint holds; no motion of the joint resolves it, the solver's normal force grows without bound,
and friction jams the part (a lever whose hulls overlap its base by 0.3 mm, 0.01 % of the object's
size, did not turn at all). A contact that only appears during the turn was moved into, whatever its
normal: a door swinging into a low sill overlaps it less along the axis than across, so its contact
normal lies along the axis although the sill blocks it (``tests/sim/test_relief_axial.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.shapes import CollisionShape

#: Contacts within this fraction of the part's radius from the hinge axis are hinge-zone contacts.
HINGE_ZONE = 0.15
#: Deepest hinge-zone penetration that is relieved, as a fraction of the part's radius.
MAX_DEPTH = 0.08
#: A cut may remove at most this fraction of a hull's volume.
MAX_REMOVED = 0.5
#: A contact whose normal is within 5 degrees of the hinge axis (this cosine) is relieved at any distance.
AXIAL_COS = float(np.cos(np.radians(5.0)))
SAMPLES_PER_RADIAN = 16
PASSES = 3


@dataclass
class ReliefCut:
    """One bevel: ``geom`` of ``link`` cut where it met ``other`` while ``joint`` turned."""

    joint: str
    link: str
    geom: str
    other: str
    depth: float
    removed: float  # fraction of the hull's volume

    def to_dict(self) -> dict:
        return {"joint": self.joint, "geom": self.geom, "other": self.other, "depth": round(self.depth, 5),
                "removed": round(self.removed, 4)}


def cut_hull(shape: CollisionShape, normal: np.ndarray, offset: float) -> tuple[CollisionShape, float] | None:
    """``shape`` (a mesh hull) intersected with ``normal . x <= offset``; None when nothing changes."""
    mesh = trimesh.Trimesh(shape.vertices, shape.faces, process=False)
    if np.max(shape.vertices @ normal) <= offset + 1e-9:
        return None
    volume = float(mesh.volume)
    origin = normal * offset / float(np.dot(normal, normal))
    kept = mesh.slice_plane(origin, -normal, cap=True)
    if kept is None or len(kept.faces) < 4 or kept.volume <= 0:
        return shape, 1.0
    hull = trimesh.convex.convex_hull(kept.vertices)
    removed = 1.0 - float(hull.volume) / volume if volume > 0 else 1.0
    return CollisionShape("mesh", shape.method, vertices=np.asarray(hull.vertices, float),
                          faces=np.asarray(hull.faces, np.int64)), removed


def hinge_radius(model, data, bodies: set[int], anchor: np.ndarray, axis: np.ndarray) -> float:
    """Largest distance of the moving geoms' bounding spheres from the axis line."""
    best = 0.0
    for g in range(model.ngeom):
        if model.geom_bodyid[g] in bodies and model.geom_contype[g]:
            d = data.geom_xpos[g] - anchor
            best = max(best, float(np.linalg.norm(d - np.dot(d, axis) * axis)) + float(model.geom_rbound[g]))
    return best


def find_cuts(model, data, asset, gap: float) -> list[tuple]:
    """One kinematic sweep per revolute joint; returns ``(joint, link, index, normal, offset, depth,
    other)`` for every penetration in the hinge zone or face-on along the axis (plane in the link
    frame; see the module docstring)."""
    mujoco = mujoco_module()

    cuts = []
    for joint in asset.movable_joints():
        if not joint.is_rotational:
            continue
        jid = model.joint(joint.name).id
        moving = joint_bodies(model, jid)
        span = joint.upper - joint.lower if joint.type != JointType.CONTINUOUS else 2 * np.pi
        samples = max(8, int(abs(span) * SAMPLES_PER_RADIAN))
        # (moving body, other body) pairs in contact along the axis at rest and at every sample since
        held: set[tuple[int, int]] = set()
        for step, value in enumerate(joint.rest_value + span * np.linspace(0, 1, samples + 1)):
            mujoco.mj_resetData(model, data)
            data.qpos[model.jnt_qposadr[jid]] = value
            mujoco.mj_forward(model, data)
            anchor, axis = data.xanchor[jid].copy(), data.xaxis[jid].copy()
            radius = hinge_radius(model, data, moving, anchor, axis)
            found, axial = [], set()
            for contact in data.contact[: data.ncon]:
                g1, g2 = contact.geom1, contact.geom2
                in1, in2 = model.geom_bodyid[g1] in moving, model.geom_bodyid[g2] in moving
                if in1 == in2 or contact.dist >= 0:
                    continue
                mine, other, normal = (g1, g2, contact.frame[:3].copy()) if in1 else (g2, g1, -contact.frame[:3])
                pair = (int(model.geom_bodyid[mine]), int(model.geom_bodyid[other]))
                if abs(float(np.dot(normal, axis))) >= AXIAL_COS:
                    axial.add(pair)
                found.append((contact, mine, other, normal, pair))
            held = axial if step == 0 else held & axial
            if step == 0:  # the rest pose only starts the axial contacts held since rest
                continue
            for contact, mine, other, normal, pair in found:
                depth = -float(contact.dist)
                d = contact.pos - anchor
                near_axis = np.linalg.norm(d - np.dot(d, axis) * axis) <= HINGE_ZONE * radius
                if not (near_axis or pair in held) or depth > MAX_DEPTH * radius:
                    continue
                name = model.geom(mine).name
                link = model.body(model.geom_bodyid[mine]).name
                if not name.startswith(f"{link}_collision_"):
                    continue
                rotation, origin = data.xmat[model.geom_bodyid[mine]].reshape(3, 3), data.xpos[model.geom_bodyid[mine]]
                local_normal = rotation.T @ normal
                offset = float(normal @ contact.pos) - 0.5 * depth - gap - float(normal @ origin)
                cuts.append((joint.name, link, int(name.rsplit("_", 1)[1]), local_normal, offset, depth,
                             model.geom(other).name))
    return cuts


def under(model, body: int, ancestor: int) -> bool:
    """Whether ``body`` is ``ancestor`` or one of its descendants (never true of the world body 0).

    :param model: the compiled ``MjModel``
    :param body: a body id
    :param ancestor: a body id
    """
    while body > 0:
        if body == ancestor:
            return True
        body = model.body_parentid[body]
    return False


def joint_bodies(model, jid: int) -> set[int]:
    """The bodies that joint ``jid`` moves: its body and every descendant.

    :param model: the compiled ``MjModel``
    :param jid: a joint id
    """
    body = int(model.jnt_bodyid[jid])
    return {b for b in range(model.nbody) if under(model, b, body)}


def relieve(prepared, compile_model, gap: float) -> list[ReliefCut]:
    """Cut the hulls of ``prepared.shapes`` in place until no hinge-zone penetration is left.

    :param prepared: a :class:`~spark_bench.sim.prepared.PreparedObject`
    :param compile_model: ``() -> MjModel`` of the current shapes, contact filters applied
    :param gap: clearance left behind a cut (m)
    """
    mujoco = mujoco_module()

    done: list[ReliefCut] = []
    refused: set[tuple[str, int]] = set()
    # what each hull was before any relief: cuts together may take at most MAX_REMOVED of it (a door turned the
    # wrong way meets its body near the hinge at every sample, and sample by sample small cuts add up)
    original = {(link, k): shape.volume() for link, shapes in prepared.shapes.items() for k, shape in enumerate(shapes)}
    for _ in range(PASSES):
        model = compile_model()
        data = mujoco.MjData(model)
        cuts = [c for c in find_cuts(model, data, prepared.asset, gap) if (c[1], c[2]) not in refused]
        if not cuts:
            break
        for joint, link, index, normal, offset, depth, other in cuts:
            shape = prepared.shapes[link][index]
            if shape.kind != "mesh":
                refused.add((link, index))
                continue
            result = cut_hull(shape, normal, offset)
            if result is None:
                continue
            new, removed = result
            if removed > MAX_REMOVED or new.volume() < (1.0 - MAX_REMOVED) * original[(link, index)]:
                refused.add((link, index))
                continue
            prepared.shapes[link][index] = new
            done.append(ReliefCut(joint, link, f"{link}_collision_{index}", other, depth, removed))
    return done


def as_mesh(shape: CollisionShape) -> CollisionShape:
    """``shape`` as a mesh hull (a primitive becomes its polyhedron), so that a plane can cut it."""
    if shape.kind == "mesh":
        return shape
    mesh = shape.to_trimesh()
    return CollisionShape("mesh", shape.method, vertices=np.asarray(mesh.vertices, float),
                          faces=np.asarray(mesh.faces, np.int64))


def summarize_cuts(cuts, by: str, digits: int) -> dict:
    """Hull cuts grouped by their attribute ``by`` (a joint, a link): the hulls cut, how many cuts, the deepest
    penetration removed (m, rounded to ``digits``); each cut has ``geom`` and ``depth``."""
    out: dict[str, dict] = {}
    for cut in cuts:
        entry = out.setdefault(getattr(cut, by), {"geoms": [], "cuts": 0, "max_depth": 0.0})
        if cut.geom not in entry["geoms"]:
            entry["geoms"].append(cut.geom)
        entry["cuts"] += 1
        entry["max_depth"] = round(max(entry["max_depth"], cut.depth), digits)
    return out


def summarize_relief(cuts) -> dict:
    """Hinge-relief cuts per joint: the hulls bevelled, the deepest penetration removed (m)."""
    return summarize_cuts(cuts, "joint", 5)
