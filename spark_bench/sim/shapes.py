"""The collision shapes of a link (:class:`CollisionShape`) and the report of how an object's were made
(:class:`CollisionReport`): the records that the hulls, the shape cache, the hinge relief, the masses and
the model builders share.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from spark_bench.sim.decompose import DecomposeStats


@dataclass
class CollisionShape:
    """One convex collision geom of a link, in the link frame.

    :param kind: ``box``, ``cylinder``, ``sphere`` (``origin`` and ``size`` as in
        :class:`~spark_bench.asset.model.Collision`) or ``mesh`` (``vertices``/``faces`` of a convex hull)
    :param method: where it came from: ``primitive``, ``convex`` (given convex mesh), ``hull`` (the
        hull of a near-convex part), ``boxes`` (an orthogonal part's exact boxes) or ``coacd``
    """

    kind: str
    method: str
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))
    size: np.ndarray = field(default_factory=lambda: np.zeros(0))
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None

    def volume(self) -> float:
        """Volume in m^3."""
        if self.kind == "box":
            return float(np.prod(self.size))
        if self.kind == "cylinder":
            return float(np.pi * self.size[0] ** 2 * self.size[1])
        if self.kind == "sphere":
            return float(4.0 / 3.0 * np.pi * self.size[0] ** 3)
        return float(abs(self.to_trimesh().volume))

    def to_trimesh(self) -> trimesh.Trimesh:
        """The shape as a closed mesh in the link frame."""
        if self.kind == "mesh":
            return trimesh.Trimesh(self.vertices, self.faces, process=False)
        if self.kind == "box":
            shape = trimesh.creation.box(extents=self.size)
        elif self.kind == "cylinder":
            shape = trimesh.creation.cylinder(radius=self.size[0], height=self.size[1], sections=24)
        else:
            shape = trimesh.creation.icosphere(subdivisions=2, radius=self.size[0])
        shape.apply_transform(self.origin)
        return shape


@dataclass
class CollisionReport:
    """Per-object summary of how the collision shapes were made; ``coacd_failures`` has one line per
    part CoACD failed on (its link, and why), which got its convex hull instead; ``seconds`` the wall
    seconds of making the shapes (``shapes``) and of deciding the contacts (``contacts``)."""

    hulls: dict[str, int] = field(default_factory=dict)
    methods: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    coacd: DecomposeStats = field(default_factory=DecomposeStats)
    merged: int = 0
    cached_links: int = 0
    coacd_failures: list[str] = field(default_factory=list)
