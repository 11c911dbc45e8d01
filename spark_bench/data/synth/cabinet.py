"""Carcasses with a grid of fronts: drawers, doors, flaps, open shelves and control panels.

The carcass is a box of panels (sides, top, bottom, back, dividers); its front face is split into
columns (full-height vertical dividers) and each column into cells (horizontal dividers). Fronts
overlay the carcass edges with a small gap between them and a small standoff in front of it.

Clearance rules that make every motion collision-free:

- drawers are boxes inside their opening with a gap on every side; they slide along +Z;
- a door's hinge axis lies on the door's *front face* along its hinge edge: for angles up to 90 degrees
  the door never crosses the hinge line nor goes behind its own back face, and beyond 90 degrees it is
  entirely in front of its front face. Doors hinged on the carcass's outer edge may therefore open to
  135 degrees; doors hinged on an inner edge stop at 90 degrees;
- flaps (bottom- or top-hinged) follow the same rule about a horizontal axis and stop at 90 degrees;
- the gap between fronts covers the few millimetres a door's back corner swings past its free edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.data.synth import palette
from spark_bench.data.synth.handles import front_panel
from spark_bench.data.synth.primitives import RGBA, Solid, box
from spark_bench.data.synth.spec import JointSpec, ObjectSpec

X, Y, Z = np.eye(3)
CELL_KINDS = ("drawer", "door", "door_left", "door_right", "double_door", "flap_down", "flap_up", "open", "panel")


@dataclass
class CabinetStyle:
    """Materials, thicknesses and handle choices of one cabinet.

    :param handle_style: a style of :data:`~spark_bench.data.synth.handles.HANDLE_STYLES`
    :param handle_link: handles become their own links (fixed joint, label ``handle``) rather than
        part of the moving link
    :param door_upper: range of the opening angle of doors hinged on the carcass's outer edge
    :param glass: doors and flaps get a glass window
    """

    body_color: RGBA
    front_color: RGBA
    handle_color: RGBA
    body_density: float = palette.DENSITY["wood"]
    front_density: float = palette.DENSITY["wood"]
    handle_density: float = palette.DENSITY["metal"]
    panel: float = 0.018
    back: float = 0.008
    front: float = 0.019
    gap: float = 0.004
    standoff: float = 0.002
    handle_style: str = "bar"
    handle_link: bool = True
    door_label: str = "rotation_door"
    flap_label: str = "door"
    drawer_label: str = "drawer"
    door_upper: tuple[float, float] = (np.pi / 2, 3 * np.pi / 4)
    drawer_fraction: tuple[float, float] = (0.75, 0.9)
    glass: bool = False
    front_jitter: float = 0.025


@dataclass
class Cell:
    """One compartment of a column: ``kind`` in :data:`CELL_KINDS`, ``weight`` its relative height."""

    kind: str
    weight: float = 1.0


@dataclass
class Column:
    """A full-height column of cells listed bottom to top; ``weight`` is its relative width."""

    weight: float
    cells: list[Cell]


@dataclass
class CellResult:
    """What was built for a cell: its front rectangle, front-face z, and the parts it created."""

    kind: str
    rect: tuple[float, float, float, float]
    face_z: float
    parts: list[str] = field(default_factory=list)


def _splits(lo: float, hi: float, weights) -> np.ndarray:
    w = np.asarray(weights, dtype=float)
    return lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(w) / w.sum()])


def add_cabinet(spec: ObjectSpec, rng: np.random.Generator, lo, hi, columns: list[Column],
                style: CabinetStyle, body: str = "body", prefix: str = "") -> list[CellResult]:
    """Add a carcass (to the part ``body``) and its fronts (new parts) to ``spec``.

    :param lo: (x, y, z) minimum corner of the carcass; ``hi`` the maximum corner (front at ``hi[2]``)
    :param columns: the front layout, left to right
    :returns: one :class:`CellResult` per cell, column by column, bottom to top
    """
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    t, tb = style.panel, style.back
    color, dens = style.body_color, style.body_density
    xs = _splits(x0, x1, [c.weight for c in columns])
    panels = [box((x0, y0, z0), (x0 + t, y1, z1), color, dens), box((x1 - t, y0, z0), (x1, y1, z1), color, dens),
              box((x0 + t, y0, z0 + tb), (x1 - t, y0 + t, z1), color, dens),
              box((x0 + t, y1 - t, z0 + tb), (x1 - t, y1, z1), color, dens),
              box((x0 + t, y0 + t, z0), (x1 - t, y1 - t, z0 + tb), color, dens)]
    panels += [box((x - 0.5 * t, y0 + t, z0 + tb), (x + 0.5 * t, y1 - t, z1), color, dens) for x in xs[1:-1]]
    gap = _front_gap(columns, xs, y0, y1, style)
    results = []
    for i, column in enumerate(columns):
        ys = _splits(y0, y1, [c.weight for c in column.cells])
        inner_x0 = xs[i] + (t if i == 0 else 0.5 * t)
        inner_x1 = xs[i + 1] - (t if i == len(columns) - 1 else 0.5 * t)
        panels += [box((inner_x0, y - 0.5 * t, z0 + tb), (inner_x1, y + 0.5 * t, z1), color, dens)
                   for y in ys[1:-1]]
        for j, cell in enumerate(column.cells):
            inner_y0 = ys[j] + (t if j == 0 else 0.5 * t)
            inner_y1 = ys[j + 1] - (t if j == len(column.cells) - 1 else 0.5 * t)
            rect = (xs[i] + 0.5 * gap, xs[i + 1] - 0.5 * gap, ys[j] + 0.5 * gap, ys[j + 1] - 0.5 * gap)
            opening = (inner_x0, inner_x1, inner_y0, inner_y1, z0 + tb, z1)
            outer = (i == 0, i == len(columns) - 1)
            name = f"{prefix}{cell.kind}_{i}_{j}"
            results.append(_add_cell(spec, rng, body, cell.kind, rect, opening, outer, style, name))
    spec.part(body).solids.extend(panels)
    return results


def _front_gap(columns, xs, y0, y1, style: CabinetStyle) -> float:
    """Gap between fronts: wide enough for a door's back corner to swing past its free edge."""
    widths = []
    for i, column in enumerate(columns):
        for cell in column.cells:
            if cell.kind.startswith("door"):
                widths.append(xs[i + 1] - xs[i])
            elif cell.kind == "double_door":
                widths.append(0.5 * (xs[i + 1] - xs[i]))
            elif cell.kind.startswith("flap"):
                widths.append((y1 - y0) * cell.weight / sum(c.weight for c in column.cells))
    if not widths:
        return style.gap
    # a corner at depth t behind the hinge face swings t^2 / 2w past the free edge; doors meet in pairs
    return max(style.gap, style.front ** 2 / min(widths) + 0.003)


def _front_color(rng, style: CabinetStyle) -> RGBA:
    return palette.jitter(rng, style.front_color, style.front_jitter)


def _add_cell(spec, rng, body, kind, rect, opening, outer, style: CabinetStyle, name) -> CellResult:
    face0 = opening[5] + style.standoff
    face1 = face0 + style.front
    result = CellResult(kind, rect, face1)
    if kind == "open":
        return result
    if kind == "panel":
        plate = box((rect[0], rect[2], opening[5]), (rect[1], rect[3], face1), _front_color(rng, style),
                    style.front_density)
        spec.part(body).solids.append(plate)
        return result
    if kind == "drawer":
        result.parts += _add_drawer(spec, rng, body, rect, opening, style, name)
    elif kind == "double_door":
        xm = 0.5 * (rect[0] + rect[1])
        result.parts += _add_door(spec, rng, body, (rect[0], xm - 0.5 * style.gap, rect[2], rect[3]), "left",
                                  outer[0], style, name + "_l", face0)
        result.parts += _add_door(spec, rng, body, (xm + 0.5 * style.gap, rect[1], rect[2], rect[3]), "right",
                                  outer[1], style, name + "_r", face0)
    elif kind.startswith("door"):
        if kind == "door":
            hinge = "left" if outer[0] and not outer[1] else "right" if outer[1] and not outer[0] else \
                ("left", "right")[int(rng.integers(2))]
        else:
            hinge = kind.split("_")[1]
        result.parts += _add_door(spec, rng, body, rect, hinge, outer[0] if hinge == "left" else outer[1], style,
                                  name, face0)
    elif kind in ("flap_down", "flap_up"):
        result.parts += _add_flap(spec, rng, body, rect, kind == "flap_down", style, name, face0)
    else:
        raise ValueError(f"unknown cell kind {kind!r}")
    return result


def _handle_parts(spec, rng, parent: str, handle: list[Solid], style: CabinetStyle, pivot) -> list[str]:
    if not handle:
        return []
    if style.handle_link:
        part = spec.add(parent + "_handle", "handle", handle, parent, JointSpec("fixed", pivot))
        return [part.name]
    spec.part(parent).solids.extend(handle)
    return []


def _glass(rect, face1: float, where: str) -> Solid:
    x0, x1, y0, y1 = rect
    m = max(0.04, 0.15 * min(x1 - x0, y1 - y0))
    extra = 0.045  # keep the handle side clear
    gx0 = x0 + m + (extra if where == "left" else 0.0)
    gx1 = x1 - m - (extra if where == "right" else 0.0)
    gy1 = y1 - m - (extra if where == "top" else 0.0)
    gy0 = y0 + m + (extra if where == "bottom" else 0.0)
    return box((gx0, gy0, face1 - 0.001), (gx1, gy1, face1 + 0.002), palette.GLASS, palette.DENSITY["glass"])


def _add_drawer(spec, rng, body, rect, opening, style: CabinetStyle, name) -> list[str]:
    ox0, ox1, oy0, oy1, oz0, oz1 = opening
    face0 = oz1 + style.standoff
    face1 = face0 + style.front
    color = _front_color(rng, style)
    panel, handle = front_panel(rect, face0, face1, style.handle_style, "center", rng, color, style.front_density,
                                style.handle_color, style.handle_density)
    side, gap = 0.012, 0.006
    bx0, bx1 = ox0 + gap, ox1 - gap
    by0, by1 = oy0 + 0.004, oy1 - max(0.012, 0.15 * (oy1 - oy0))
    bz0 = oz0 + max(0.015, 0.04 * (oz1 - oz0))
    if bx1 - bx0 < 4 * side or by1 - by0 < 2 * side:
        raise ValueError(f"drawer opening too small: {opening}")
    inner = palette.jitter(rng, style.body_color, 0.02)
    dens = style.front_density
    drawer_box = [box((bx0, by0, bz0), (bx1, by0 + 0.01, face0), inner, dens),
                  box((bx0, by0, bz0), (bx0 + side, by1, face0), inner, dens),
                  box((bx1 - side, by0, bz0), (bx1, by1, face0), inner, dens),
                  box((bx0 + side, by0, bz0), (bx1 - side, by1, bz0 + side), inner, dens)]
    depth = face0 - bz0
    fraction = rng.uniform(*style.drawer_fraction)
    pivot = np.array([0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3]), face1])
    joint = JointSpec("prismatic", pivot, Z, 0.0, fraction * depth, min_upper=style.drawer_fraction[0] * depth)
    part = spec.add(name, style.drawer_label, panel + drawer_box, body, joint)
    return [part.name] + _handle_parts(spec, rng, part.name, handle, style, pivot)


def _add_door(spec, rng, body, rect, hinge: str, outer_hinge: bool, style: CabinetStyle, name, face0) -> list[str]:
    face1 = face0 + style.front
    color = _front_color(rng, style)
    free = "right" if hinge == "left" else "left"
    panel, handle = front_panel(rect, face0, face1, style.handle_style, free, rng, color, style.front_density,
                                style.handle_color, style.handle_density)
    if style.glass:
        panel.append(_glass(rect, face1, free))
    pivot = np.array([rect[0] if hinge == "left" else rect[1], 0.5 * (rect[2] + rect[3]), face1])
    axis = -Y if hinge == "left" else Y  # the free edge swings towards +Z
    upper = rng.uniform(*style.door_upper) if outer_hinge else np.pi / 2
    joint = JointSpec("revolute", pivot, axis, 0.0, upper, min_upper=min(1.4, upper))
    part = spec.add(name, style.door_label, panel, body, joint)
    return [part.name] + _handle_parts(spec, rng, part.name, handle, style, pivot)


def _add_flap(spec, rng, body, rect, down: bool, style: CabinetStyle, name, face0) -> list[str]:
    face1 = face0 + style.front
    color = _front_color(rng, style)
    where = "top" if down else "bottom"
    panel, handle = front_panel(rect, face0, face1, style.handle_style, where, rng, color, style.front_density,
                                style.handle_color, style.handle_density)
    if style.glass:
        panel.append(_glass(rect, face1, where))
    pivot = np.array([0.5 * (rect[0] + rect[1]), rect[2] if down else rect[3], face1])
    axis = X if down else -X  # the free edge swings towards +Z
    upper = rng.uniform(1.45, np.pi / 2)
    joint = JointSpec("revolute", pivot, axis, 0.0, upper, min_upper=1.3)
    part = spec.add(name, style.flap_label, panel, body, joint)
    return [part.name] + _handle_parts(spec, rng, part.name, handle, style, pivot)
