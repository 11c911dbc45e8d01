"""The object as prepared for the simulators (:class:`PreparedObject`): collision shapes, masses, joint
dynamics and the contact decisions, computed once by :func:`spark_bench.sim.mjcf.prepare` and read by the
contact filters, the hinge relief, the MJCF and PyBullet writers and the checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.mesh import drop_degenerate_faces
from spark_bench.asset.model import ArticulatedAsset, Link
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.physical import JointDynamics, MassProperties
from spark_bench.sim.shapes import CollisionReport, CollisionShape


@dataclass
class PreparedObject:
    """Everything computed before the spec is assembled (reused by the checks and the PyBullet writer).

    :param asset: the object
    :param options: the options used
    :param shapes: collision shapes per link (link frame)
    :param mass: mass properties per link (link frame)
    :param dynamics: joint parameters per movable joint
    :param size: the object's bounding-box diagonal at rest (every relative tolerance refers to it)
    :param report: how the collision shapes were made
    :param excluded: parent-child body pairs that do not collide, with their overlap depth at rest: hulls
        that overlap by construction (no rest-trimming cut resolves them) or block where the surfaces do not
        (``phantom``)
    :param trim: rest-trimming cuts made (:class:`~spark_bench.sim.rest_trim.TrimCut`)
    :param relief: hinge-relief cuts made (:class:`~spark_bench.sim.relief.ReliefCut`)
    :param visuals: per link, its merged visual mesh ``(vertices, faces, rgba)`` or None, filled on
        first use by :meth:`visual` (merging and cleaning a 300k-face watertight remesh costs seconds;
        every spec and the PyBullet URDF reuse it)
    :param phantom: parent-child pairs excluded because only the hulls, not the meshes, block the
        child's joint (:class:`~spark_bench.sim.phantom.PhantomBlock`)
    :param solids: per link, its closed pieces ready for inside tests, or None where it is not closed
        (:func:`~spark_bench.sim.solid.closed_solid`), filled on first use by :meth:`solid`
    """

    asset: ArticulatedAsset
    options: ConvertOptions
    shapes: dict[str, list[CollisionShape]]
    mass: dict[str, MassProperties]
    dynamics: dict[str, JointDynamics]
    size: float
    report: CollisionReport
    excluded: dict[tuple[str, str], float] = field(default_factory=dict)
    trim: list = field(default_factory=list)
    relief: list = field(default_factory=list)
    visuals: dict = field(default_factory=dict)
    phantom: list = field(default_factory=list)
    solids: dict = field(default_factory=dict)

    def visual(self, name: str) -> tuple[np.ndarray, np.ndarray, list[float]] | None:
        """:func:`link_visual_mesh` of link ``name``, computed once."""
        if name not in self.visuals:
            self.visuals[name] = link_visual_mesh(self.asset.links[name])
        return self.visuals[name]

    def solid(self, name: str):
        """:func:`~spark_bench.sim.solid.closed_solid` of link ``name``'s visuals, computed once."""
        if name not in self.solids:
            from spark_bench.sim.solid import closed_solid

            self.solids[name] = closed_solid([(v.mesh.vertices, v.mesh.faces) for v in self.asset.links[name].visuals])
        return self.solids[name]


def link_visual_mesh(link: Link) -> tuple[np.ndarray, np.ndarray, list[float]] | None:
    """The link's visuals merged into one mesh in the link frame without degenerate faces, and their
    area-weighted colour; None when it has none."""
    if not link.has_geometry:
        return None
    merged = link.merged_mesh()
    cleaned = drop_degenerate_faces(merged.vertices, merged.faces)
    if cleaned is None:
        return None
    areas = np.array([max(float(v.mesh.area), 1e-12) for v in link.visuals])
    rgba = np.average(np.array([v.rgba for v in link.visuals], dtype=float), axis=0, weights=areas)
    return cleaned[0], cleaned[1], [float(c) for c in rgba[:3]] + [1.0]
