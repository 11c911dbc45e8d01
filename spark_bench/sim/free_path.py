"""Is a part's own path free? How deep its neighbour's surface may enter it, and how much of it crosses that surface.

The two measures the contact rule (:mod:`spark_bench.sim.phantom`) judges a part's path by, as the joint moves it
from rest, every other joint at rest: :func:`allowed_depth`, how deep the neighbour's surface may enter the part
over the part of its range the sweep asks it to reach (:data:`DEPTH_REACH`) and the path still count as free
(zero-gap modelling), and :func:`part_crossing`, the fraction of the part's own surface points that cross the
neighbour's surface over its whole range (:mod:`spark_bench.sim.crossing`).
"""

from __future__ import annotations

import numpy as np
import trimesh

from spark_bench.asset.model import Joint
from spark_bench.sim.crossing import crossing_steps, inset_samples, surface_model
from spark_bench.sim.sweep import SWEEP_REACH

#: The neighbour's surface may enter the moving part this deep along its path, as a fraction of the object's size
#: (the rest check's own tolerance for an overlap) and of the part's own size, whichever is less, and the path still
#: count as free: PartNet-Mobility models parts with zero gap (`spark-bench check` on partnet_dev 101623, a safe:
#: its link_1 brushes its neighbour 2.4 mm deep on its path, 4.8 % of its points crossing; the depth alone does
#: not block microwave 7263's buttons, 0.6 mm into their panel, but more than half of their points cross it).
OBJECT_DEPTH = 0.005
PART_DEPTH = 0.05
#: ... and never deeper than this fraction of how far the part travels: a drawer with 3 mm of travel that meets a
#: wall after 1 mm is blocked, however shallow that is.
TRAVEL_DEPTH = 0.1
#: How deep the neighbour's surface enters the part is judged over this fraction of the range from rest: the part of
#: it the joint sweep asks the part to reach (:data:`~spark_bench.sim.sweep.SWEEP_REACH`), as the check-validity
#: benchmark judges a break. A shallow entry beyond is the part lying on its stop: PartNet-Mobility annotates ranges
#: to where a part lies against its body (a bucket's handle on the rim), a few millimetres into it (conv-10, on
#: partnet_dev's tune half: 7 of its 10 buckets' handles enter their bucket deepest at their upper limit, 100441's
#: 2.35 mm right at its allowance). How many of its points cross the body (:func:`part_crossing`) still counts over
#: the whole range: a part that passes through its body on its last tenth passes through it (synth-v1 Door_00046's
#: door turned the wrong way: 21 % of its points over the whole range, 17 % over nine tenths of it).
DEPTH_REACH = SWEEP_REACH
#: Points sampled on the moving part for :func:`part_crossing`, their inset into its surface and the steps of the
#: path (per radian of a hinge, per slide; the check-validity benchmark's judge steps its paths the same way).
CROSSING_SAMPLES = 1000
CROSSING_INSET = 0.0002
CROSSING_STEPS_PER_RADIAN = 60
CROSSING_SLIDE_STEPS = 60
#: A surface met before the point has moved this fraction of the object's size (or a tenth of the part's travel,
#: whichever is less) is one it rests against.
CROSSING_START = 0.005


def crossing_values(joint: Joint, reach: float = 1.0) -> np.ndarray:
    """The joint values :func:`part_crossing` steps through: from rest over ``reach`` of the range (all of it)."""
    span = reach * float(joint.upper - joint.lower)
    steps = max(8, int(np.ceil(abs(span) * CROSSING_STEPS_PER_RADIAN))) if joint.is_rotational else CROSSING_SLIDE_STEPS
    return joint.rest_value + span * np.linspace(0.0, 1.0, steps + 1)


def part_crossing(prepared, joint: Joint, moving: str, other: str, enough: float | None = None) -> float:
    """Fraction of ``moving``'s surface points that cross ``other``'s surface (their visual meshes) while ``joint``
    moves from rest over its whole range, every other joint at rest (:mod:`spark_bench.sim.crossing`).

    :param prepared: the prepared object
    :param joint: the joint that moves ``moving`` relative to ``other``
    :param enough: stop counting once this fraction has crossed (the result is then at least ``enough``, not
        the whole fraction): a caller that only compares with a bound need not cast the rest
    """
    own, theirs = prepared.visual(moving), prepared.visual(other)
    if own is None or theirs is None:
        return 0.0
    asset = prepared.asset
    mesh = trimesh.Trimesh(own[0], own[1], process=False)
    points = inset_samples(mesh, CROSSING_SAMPLES, CROSSING_INSET * prepared.size)
    path = []
    for value in crossing_values(joint):
        poses = asset.link_poses({joint.name: float(value)})
        relative = np.linalg.inv(poses[other]) @ poses[moving]
        path.append(points @ relative[:3, :3].T + relative[:3, 3])
    path = np.stack(path)
    longest = float(np.max(np.linalg.norm(np.diff(path, axis=0), axis=2).sum(axis=0), initial=0.0))
    model, data = surface_model([(theirs[0], theirs[1])])
    start = min(CROSSING_START * prepared.size, 0.1 * longest)
    stop = None if enough is None else int(np.ceil(enough * len(points)))
    return float(np.mean(crossing_steps(model, data, path, start, stop) >= 0))


def travel(prepared, joint: Joint, link: str) -> float:
    """How far ``joint`` moves ``link`` over its range (m): a slide's range; a hinge's range times the distance of
    the link's farthest hull vertex from the axis."""
    span = abs(float(joint.upper - joint.lower))
    if not joint.is_rotational:
        return span
    poses = prepared.asset.link_poses()
    frame = poses[joint.parent] @ joint.origin
    axis = frame[:3, :3] @ (np.asarray(joint.axis, float) / np.linalg.norm(joint.axis))
    offset = np.concatenate([s.to_trimesh().vertices @ poses[link][:3, :3].T + poses[link][:3, 3]
                             for s in prepared.shapes[link]]) - frame[:3, 3]
    return span * float(np.max(np.linalg.norm(offset - np.outer(offset @ axis, axis), axis=1)))


def allowed_depth(prepared, joint: Joint, link: str, tolerance: float) -> float:
    """How deep a neighbour's surface may enter ``link`` along ``joint``'s path and the path still be free: the least
    of :data:`OBJECT_DEPTH` of the object's size, :data:`PART_DEPTH` of the link's (its hulls' diagonal) and
    :data:`TRAVEL_DEPTH` of its :func:`travel`, at least ``tolerance``."""
    vertices = np.concatenate([s.to_trimesh().vertices for s in prepared.shapes[link]])
    part = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    limits = (OBJECT_DEPTH * prepared.size, PART_DEPTH * part, TRAVEL_DEPTH * travel(prepared, joint, link))
    return max(tolerance, min(limits))
