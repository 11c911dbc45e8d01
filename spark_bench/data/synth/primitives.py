"""Convex solids the generator builds every object from: boxes, cylinders and frustums.

A :class:`Solid` lives in object coordinates (metres, Y up, front +Z) at the rest pose. It knows its
visual mesh (through manifold3d, so unions stay watertight), its URDF collision primitive, its mass
properties, and a convex polytope that contains it (for the separating-axis clearance checks).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import manifold3d
import numpy as np

RGBA = tuple[float, float, float, float]

#: Segments of a cylinder's visual mesh (inscribed polygon).
VISUAL_SECTIONS = 32
#: Segments of the polytope that contains a cylinder in clearance checks (circumscribed polygon).
HULL_SECTIONS = 24


@dataclass(frozen=True)
class Solid:
    """One convex primitive of a part, at rest, in object coordinates.

    :param kind: ``box``, ``cylinder`` or ``frustum``
    :param center: centre of the primitive
    :param size: box: full extents (local x, y, z); cylinder: (radius, length); frustum:
        (radius at local -z, radius at local +z, length); cylinder and frustum axes are local z
    :param rotation: 3x3 rotation from the primitive's local frame to object coordinates
    :param color: display colour of this solid
    :param density: kg/m^3, for the link's inertial
    """

    kind: str
    center: np.ndarray
    size: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    color: RGBA = (0.7, 0.7, 0.7, 1.0)
    density: float = 600.0

    def __post_init__(self):
        color = tuple(round(float(c), 4) for c in self.color)
        object.__setattr__(self, "color", color + (1.0,) if len(color) == 3 else color)

    @property
    def pose(self) -> np.ndarray:
        """4x4 pose of the local frame in object coordinates."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.center
        return out

    def transformed(self, transform: np.ndarray) -> Solid:
        """This solid moved by the rigid 4x4 ``transform``."""
        rot = transform[:3, :3]
        return replace(self, center=rot @ self.center + transform[:3, 3], rotation=rot @ self.rotation)

    def recolored(self, color: RGBA, density: float | None = None) -> Solid:
        """This solid with another colour (and density)."""
        return replace(self, color=color, density=self.density if density is None else density)

    # ----- geometry -------------------------------------------------------------------------
    def volume(self) -> float:
        if self.kind == "box":
            return float(np.prod(self.size))
        if self.kind == "cylinder":
            return float(np.pi * self.size[0] ** 2 * self.size[1])
        r0, r1, length = self.size
        return float(np.pi * length * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0)

    def local_inertia(self, mass: float) -> np.ndarray:
        """3x3 inertia about the centre, in the local frame (frustum: as a cylinder of mean radius)."""
        if self.kind == "box":
            x, y, z = self.size
            return mass / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
        radius = self.size[0] if self.kind == "cylinder" else 0.5 * (self.size[0] + self.size[1])
        length = self.size[1] if self.kind == "cylinder" else self.size[2]
        side = mass * (3 * radius * radius + length * length) / 12.0
        return np.diag([side, side, 0.5 * mass * radius * radius])

    def manifold(self, grow: float = 0.0) -> manifold3d.Manifold:
        """The visual solid as a manifold3d object in object coordinates, ``grow`` metres larger each way.

        Growing by a fraction of a millimetre turns faces and edges that merely touch into overlaps, so
        a union of touching solids is one shell, not several shells sharing vertices.
        """
        if self.kind == "box":
            shape = manifold3d.Manifold.cube(tuple(float(v) + 2 * grow for v in self.size), True)
        elif self.kind == "cylinder":
            r, length = (float(v) for v in self.size)
            shape = manifold3d.Manifold.cylinder(length + 2 * grow, r + grow, r + grow, VISUAL_SECTIONS, True)
        else:
            r0, r1, length = (float(v) for v in self.size)
            shape = manifold3d.Manifold.cylinder(length + 2 * grow, r0 + grow, r1 + grow, VISUAL_SECTIONS, True)
        return shape.transform(self.pose[:3, :4])

    def hull_points(self) -> np.ndarray:
        """Vertices (local frame) of a convex polytope that contains the solid."""
        if self.kind == "box":
            return box_corners(self.size)
        if self.kind == "cylinder":
            return prism_points(self.size[0], self.size[0], self.size[1])
        return prism_points(self.size[0], self.size[1], self.size[2])


def box_corners(size) -> np.ndarray:
    """The 8 corners of a centred box of full extents ``size``."""
    half = 0.5 * np.asarray(size, dtype=float)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return signs * half


def prism_points(r_bottom: float, r_top: float, length: float, sections: int = HULL_SECTIONS) -> np.ndarray:
    """Vertices of the polygonal prism (or frustum) circumscribing a circular one, axis local z."""
    angles = (np.arange(sections) + 0.5) * (2 * np.pi / sections)
    scale = 1.0 / np.cos(np.pi / sections)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1) * scale
    bottom = np.column_stack([ring * r_bottom, np.full(sections, -0.5 * length)])
    top = np.column_stack([ring * r_top, np.full(sections, 0.5 * length)])
    return np.concatenate([bottom, top])


# ----- constructors ---------------------------------------------------------------------------
def box(lo, hi, color: RGBA, density: float = 600.0) -> Solid:
    """Axis-aligned box between the corners ``lo`` and ``hi``."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if np.any(hi - lo <= 0):
        raise ValueError(f"empty box {lo} .. {hi}")
    return Solid("box", 0.5 * (lo + hi), hi - lo, np.eye(3), color, density)


def oriented_box(center, size, rotation, color: RGBA, density: float = 600.0) -> Solid:
    """Box of full extents ``size`` (local frame) with the given centre and rotation."""
    return Solid("box", np.asarray(center, float), np.asarray(size, float), np.asarray(rotation, float), color, density)


def frame_with_z(axis) -> np.ndarray:
    """A rotation whose third column is the unit vector ``axis`` (deterministic choice of the others)."""
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def cylinder(center, radius: float, length: float, axis, color: RGBA, density: float = 600.0) -> Solid:
    """Cylinder of ``radius`` and ``length`` along ``axis`` (a vector), centred at ``center``."""
    return Solid("cylinder", np.asarray(center, float), np.array([radius, length], float), frame_with_z(axis),
                 color, density)


def frustum(center, r_bottom: float, r_top: float, length: float, axis, color: RGBA,
            density: float = 600.0) -> Solid:
    """Truncated cone along ``axis``: radius ``r_bottom`` at the -axis end, ``r_top`` at the +axis end."""
    return Solid("frustum", np.asarray(center, float), np.array([r_bottom, r_top, length], float),
                 frame_with_z(axis), color, density)


def translation(offset) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = offset
    return out


def rotation_about(axis, angle: float, pivot=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 rotation by ``angle`` about the line through ``pivot`` with direction ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    rot = np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)
    p = np.asarray(pivot, dtype=float)
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = p - rot @ p
    return out


def place(solids: list[Solid], transform: np.ndarray) -> list[Solid]:
    """Every solid moved by ``transform``."""
    return [s.transformed(transform) for s in solids]
