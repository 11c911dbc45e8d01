"""Physical properties: mass and inertia from the collision hulls and a density, joint dynamics defaults.

The hulls are the solid model of a link (thin panels already thickened). A part of a thin-walled
material (:class:`~spark_bench.sim.options.Material`) is a shell: a suitcase, a microwave door or a chest
lid that PartNet-Mobility models as a closed solid weighs what walls of the material's thickness over its
outer surface weigh. The mass is ``density * min(sum(hull volumes), area * wall)``, ``area`` the area of
the convex hull of the link's hulls (:func:`shell_fraction`): a panel thinner than two walls stays solid,
a closed box becomes its walls. The hulls keep their shares of that mass (an effective density: a shell's
inertia about its center is up to ~1.7 times that of the same mass spread as a solid, which this
understates), and the inertia is the sum of the hulls' inertias about the common center of mass. A sum of physical inertias is physical, so the principal moments satisfy the triangle
inequality up to rounding; :func:`principal_inertia` enforces it with a small margin anyway, because
MuJoCo rejects a body whose moments violate it by more than its tolerance.

Joint defaults scale with the part they move, so that a 50 g camera button and a 20 kg oven door get
the same time constants (the defaults were checked on the seven shared objects and the synth set):

- damping ``c = joint_damping * m * s`` for a slide (N s/m) and ``joint_damping * I_axis`` for a hinge
  (N m s/rad), where ``s = 1/s`` makes ``c / m`` a rate: with ``joint_damping = 1`` a part coasting
  at speed ``v`` stops within about ``v * 1 s``;
- armature ``joint_armature * m`` (slides) or ``joint_armature * I_axis`` (hinges);
- friction loss ``joint_frictionloss * m * g`` (slides) or ``joint_frictionloss * m * g * r`` (hinges,
  ``r`` the distance of the part's center of mass from the axis, at least a tenth of its size), and at
  least :data:`HOLD_FACTOR` times the gravity pull away from the rest limit (a drop-down oven door, a
  button on top of a camera), as latches, magnets and springs hold real parts shut.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from spark_bench.sim.shapes import CollisionShape

GRAVITY = 9.81
#: Mass (kg) given to a link with no geometry (PartNet-Mobility's ``*_helper`` links): MuJoCo needs a
#: positive mass on every moving body.
HELPER_MASS = 1e-3
#: Friction loss of a joint that gravity pulls away from its rest limit, times that pull.
HOLD_FACTOR = 1.5
#: Relative margin kept on the triangle inequality of principal moments.
TRIANGLE_MARGIN = 1e-6


@dataclass
class MassProperties:
    """Mass, center of mass and inertia of a body in its own (link) frame.

    :param mass: kg
    :param com: (3,) center of mass
    :param inertia: (3, 3) inertia tensor about the center of mass, link axes
    :param volume: m^3 of the link's solid model (0 for a helper link): its mass is less than
        ``density * volume`` for a shell
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    volume: float

    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """``(moments (3,), rotation (3, 3))``: principal moments and the axes as columns."""
        return principal_inertia(self.inertia)


def shape_mass_properties(shape: CollisionShape, density: float) -> tuple[float, np.ndarray, np.ndarray, float]:
    """``(mass, com, inertia about com, volume)`` of one convex shape in the link frame."""
    if shape.kind == "box":
        x, y, z = shape.size
        volume = x * y * z
        local = volume / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
    elif shape.kind == "cylinder":
        r, h = shape.size
        volume = np.pi * r * r * h
        side = volume * (3 * r * r + h * h) / 12.0
        local = np.diag([side, side, volume * r * r / 2.0])
    elif shape.kind == "sphere":
        r = shape.size[0]
        volume = 4.0 / 3.0 * np.pi * r ** 3
        local = np.eye(3) * 0.4 * volume * r * r
    else:
        mesh = trimesh.Trimesh(shape.vertices, shape.faces, process=False)
        volume = abs(float(mesh.volume))
        if volume <= 0:
            return 0.0, np.zeros(3), np.zeros((3, 3)), 0.0
        if mesh.volume < 0:
            mesh.invert()
        # trimesh's moment_inertia is about the center of mass for unit density
        return (density * volume, np.asarray(mesh.center_mass, float),
                density * np.asarray(mesh.moment_inertia, float) * (volume / float(mesh.mass)), volume)
    rotation = shape.origin[:3, :3]
    return density * volume, shape.origin[:3, 3].copy(), density * rotation @ local @ rotation.T, volume


def shell_fraction(volume: float, points: np.ndarray, wall: float | None) -> float:
    """The fraction of a link's solid that walls of thickness ``wall`` fill: ``min(1, area * wall /
    volume)``, ``area`` the area of the convex hull of ``points``.

    1 for a solid material (``wall`` None), for no volume, and for points that span no volume.

    :param volume: the link's solid volume, m^3 (the sum of its hulls')
    :param points: (N, 3) vertices of the link's collision shapes (link frame)
    :param wall: wall thickness (m) of the link's material
    """
    if wall is None or volume <= 0 or len(points) < 4:
        return 1.0
    try:
        area = float(ConvexHull(np.asarray(points, np.float64), qhull_options="Qt").area)
    except QhullError:  # coplanar points: no shell to speak of
        return 1.0
    return float(min(1.0, area * wall / volume)) if np.isfinite(area) else 1.0


def link_mass_properties(shapes: Sequence[CollisionShape], density: float,
                         wall: float | None = None) -> MassProperties:
    """Mass properties of a link made of ``shapes`` of a material of ``density`` (kg/m^3) built with
    walls of thickness ``wall`` (m, None: solid; see the module docstring).

    :param shapes: the link's collision shapes (link frame)
    :param density: kg/m^3 of the material
    :param wall: wall thickness of the material, None for a solid part
    """
    parts = [p for p in (shape_mass_properties(s, 1.0) for s in shapes) if p[0] > 0]  # unit density
    if not parts:
        inertia = np.eye(3) * HELPER_MASS * 1e-4  # a 1 g point with a 1 cm radius of gyration
        return MassProperties(HELPER_MASS, np.zeros(3), inertia, 0.0)
    volume = float(sum(p[3] for p in parts))
    if wall is not None:
        density *= shell_fraction(volume, np.concatenate([s.to_trimesh().vertices for s in shapes]), wall)
    masses = np.array([p[0] for p in parts]) * density
    coms = np.array([p[1] for p in parts])
    mass = float(masses.sum())
    com = (masses[:, None] * coms).sum(0) / mass
    inertia = np.zeros((3, 3))
    for m, (_, c, inert, _) in zip(masses, parts):
        d = c - com
        inertia += density * inert + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return MassProperties(mass, com, 0.5 * (inertia + inertia.T), volume)


def principal_inertia(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending, positive, satisfying ``I1 + I2 >= I3``) and a right-handed rotation
    whose columns are the principal axes."""
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    scale = max(float(moments.max()), 1e-12)
    moments = np.maximum(moments, 1e-9 * scale)
    if moments[0] + moments[1] < moments[2] * (1 + TRIANGLE_MARGIN):
        # a degenerate (flat or rod-like) sum of hulls: lift the two small moments just enough
        lift = 0.5 * (moments[2] * (1 + TRIANGLE_MARGIN) - moments[0] - moments[1])
        moments[:2] += lift
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    return moments, axes


def inertia_is_valid(moments: np.ndarray, tolerance: float = 1e-9) -> bool:
    """Positive principal moments that satisfy the triangle inequality (within ``tolerance``)."""
    a, b, c = np.sort(np.asarray(moments, dtype=float))
    return bool(a > 0 and a + b >= c * (1 - tolerance) and np.all(np.isfinite([a, b, c])))


def axis_inertia(props: MassProperties, point: np.ndarray, axis: np.ndarray) -> float:
    """Moment of inertia of a body about the line through ``point`` along unit ``axis`` (link frame)."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    d = props.com - np.asarray(point, float)
    d_perp = d - np.dot(d, axis) * axis
    return float(axis @ props.inertia @ axis + props.mass * np.dot(d_perp, d_perp))


@dataclass
class JointDynamics:
    """MuJoCo joint parameters: damping, armature and friction loss."""

    damping: float
    armature: float
    frictionloss: float


def joint_dynamics(kind: str, mass: float, inertia_axis: float, lever: float, size: float,
                   damping: float, armature: float, frictionloss: float,
                   urdf_damping: float | None = None, urdf_friction: float | None = None,
                   gravity_load: float = 0.0) -> JointDynamics:
    """Joint parameters scaled to the moving part (see the module docstring).

    :param kind: ``slide`` or ``hinge``
    :param mass: mass of everything the joint moves (kg)
    :param inertia_axis: their moment of inertia about the joint axis (kg m^2, hinges)
    :param lever: distance of their center of mass from the axis (m, hinges)
    :param size: the moving part's size (m), a floor for ``lever``
    :param damping: :attr:`ConvertOptions.joint_damping`
    :param armature: :attr:`ConvertOptions.joint_armature`
    :param frictionloss: :attr:`ConvertOptions.joint_frictionloss`
    :param urdf_damping: the URDF's ``<dynamics damping>``, used when given
    :param urdf_friction: the URDF's ``<dynamics friction>``, used when given
    :param gravity_load: generalized gravity force (N or N m) that pulls the part away from its rest
        limit (0 when gravity holds it there); the friction loss is raised to
        :data:`HOLD_FACTOR` times it, as the latch, magnet or spring of a real drop-down door or
        push button holds it at rest
    """
    if kind == "slide":
        out = JointDynamics(damping * mass, armature * mass, frictionloss * mass * GRAVITY)
    else:
        inertia_axis = max(inertia_axis, 1e-9)
        out = JointDynamics(damping * inertia_axis, armature * inertia_axis,
                            frictionloss * mass * GRAVITY * max(lever, 0.1 * size))
    if urdf_damping is not None and urdf_damping > 0:
        out.damping = float(urdf_damping)
    if urdf_friction is not None and urdf_friction > 0:
        out.frictionloss = float(urdf_friction)
    out.frictionloss = max(out.frictionloss, HOLD_FACTOR * abs(gravity_load))
    return out
