"""Whether a broken twin is a clean break: does its part, moved as the broken joint moves it, pass through the rest
of the object before it reaches the sweep's :data:`~spark_bench.sim.sweep.SWEEP_REACH` of its range?

Judged on the object's own surfaces (its visual meshes as the files give them), never on the collision hulls the
sim checks use, so that the judge and the judged do not share an artefact. Points sampled on the moving part's
surface are carried along the joint's path, step by step; each step is a segment, cast as a ray against every
surface the joint does not move (MuJoCo's ``mj_ray`` on the triangles). A point has *entered* the object when one
of its segments meets a surface after the point has travelled :data:`START_TOLERANCE` of the object's size from
rest: a surface met at once is one the part rests against (a door on its frame), which a part leaving the right
way meets too; a surface the segment runs along is looked past (:mod:`spark_bench.sim.crossing`, whose ray casts
the converter uses too, on a part and its parent, with its own threshold: :mod:`spark_bench.sim.phantom`).
PartNet-Mobility meshes are triangle soups, so the judge counts surfaces crossed, not depth inside a solid.

A twin is a clean break when at least :data:`MIN_ENTERED` more of the part's points enter the object along the twin's
path than along the intact joint's own path (the control: a hinge's knuckles interleave with their bracket on the
right path too, and those crossings say nothing of the break). :data:`MIN_ENTERED` was set on partnet_dev's tune half
(``benchmarks/partnet_dev_split.json``) and is reported on the holdout half, ``real_objects`` and synth-v1 by
``measure_check_validity``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.crossing import crossing_steps, inset_samples, surface_model
from spark_bench.sim.free_path import crossing_values
from spark_bench.sim.prepared import link_visual_mesh
from spark_bench.sim.sweep import SWEEP_REACH

#: Points sampled on the moving part's surface.
SAMPLES = 2000
#: A surface met before the point has moved this fraction of the object's size does not count (rest contact).
START_TOLERANCE = 0.005
#: Sampled points sit this fraction of the object's size inside the part's surface (:func:`inset_samples`).
INSET = 0.0002
#: Fraction of the part's points that must enter the object along the twin's path beyond those along the intact's.
MIN_ENTERED = 0.02


@dataclass
class PathCrossing:
    """How a joint's part meets the rest of the object along the first ``reach`` of its range.

    :param entered: fraction of the part's sampled points that met a surface after :data:`START_TOLERANCE`
    :param first: fraction of the range where the earliest such meeting happened (None: none)
    :param reach: the fraction of the range followed
    """

    entered: float
    first: float | None
    reach: float

    def to_dict(self) -> dict:
        return {"entered": round(self.entered, 4), "first": None if self.first is None else round(self.first, 4),
                "reach": self.reach}


def _static_scene(asset: ArticulatedAsset, moving: set[str]):
    """``(model, data)`` of the visual meshes of the links not in ``moving``, in the world at rest."""
    poses = asset.link_poses()
    meshes = []
    for name in asset.links:
        visual = None if name in moving else link_visual_mesh(asset.links[name])
        if visual is not None:
            meshes.append((visual[0] @ poses[name][:3, :3].T + poses[name][:3, 3], visual[1]))
    return surface_model(meshes)


def _moving_samples(asset: ArticulatedAsset, links: list[str], count: int, inset: float) -> dict[str, np.ndarray]:
    """Surface points of each moving link (link frame), about ``count`` in all, area-weighted across links, each
    ``inset`` inside its surface (:func:`~spark_bench.sim.crossing.inset_samples`)."""
    meshes = {}
    for name in links:
        visual = link_visual_mesh(asset.links[name])
        if visual is not None:
            meshes[name] = trimesh.Trimesh(visual[0], visual[1], process=False)
    total = sum(float(m.area) for m in meshes.values()) or 1.0
    return {name: inset_samples(mesh, max(8, int(round(count * float(mesh.area) / total))), inset, seed=index)
            for index, (name, mesh) in enumerate(sorted(meshes.items()))}


def path_crossing(asset: ArticulatedAsset, joint_name: str, reach: float = SWEEP_REACH,
                  samples: int = SAMPLES) -> PathCrossing:
    """How the part of ``joint_name`` meets the rest of ``asset`` along the first ``reach`` of its range.

    :param asset: the object (intact or a twin)
    :param joint_name: a movable joint of it
    :param reach: the fraction of the range followed (from rest)
    :param samples: points sampled on the moving part
    """
    size = float(np.linalg.norm(np.ptp(asset.bounds(), axis=0)))
    moving = asset.moving_links(joint_name)
    points = _moving_samples(asset, moving, samples, INSET * size)
    model, data = _static_scene(asset, set(moving))
    values = crossing_values(asset.joints[joint_name], reach)  # as the converter steps a part's own path

    def world(value: float) -> np.ndarray:
        poses = asset.link_poses({joint_name: float(value)})
        return np.concatenate([p @ poses[n][:3, :3].T + poses[n][:3, 3] for n, p in points.items()])

    crossed = crossing_steps(model, data, np.stack([world(v) for v in values]), START_TOLERANCE * size)
    first = int(crossed[crossed > 0].min()) if np.any(crossed > 0) else None
    span = float(values[-1] - values[0]) / reach if values[-1] != values[0] else 1.0
    where = None if first is None else float((values[first] - values[0]) / span)
    return PathCrossing(float(np.mean(crossed > 0)), where, reach)


@dataclass
class BreakJudgement:
    """A twin judged: is it a clean break, and why (one line)."""

    clean: bool
    reason: str
    twin: PathCrossing
    intact: PathCrossing

    def to_dict(self) -> dict:
        return {"clean": self.clean, "reason": self.reason, "twin": self.twin.to_dict(),
                "intact": self.intact.to_dict()}


def judge_break(intact: ArticulatedAsset, twin: ArticulatedAsset, joint_name: str,
                intact_path: PathCrossing | None = None) -> BreakJudgement:
    """Whether ``twin`` (``intact`` with ``joint_name`` broken) moves its part into the object (see the module
    docstring).

    :param intact_path: :func:`path_crossing` of ``intact``'s ``joint_name``, where the caller judges several twins
        of one joint (computed here otherwise)
    """
    twin_path = path_crossing(twin, joint_name)
    intact_path = intact_path or path_crossing(intact, joint_name)
    if twin_path.entered - intact_path.entered < MIN_ENTERED:
        return BreakJudgement(False, f"free space: {twin_path.entered:.1%} of the part's points meet the object "
                                     f"within {SWEEP_REACH:.0%} of the range, {intact_path.entered:.1%} on the intact "
                                     f"path (a clean break needs {MIN_ENTERED:.0%} more)", twin_path, intact_path)
    return BreakJudgement(True, f"{twin_path.entered:.1%} of the part's points enter the object ("
                                f"{intact_path.entered:.1%} on the intact path), the first at {twin_path.first:.0%} "
                                f"of the range", twin_path, intact_path)
