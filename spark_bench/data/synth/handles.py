"""Handles, pulls and knobs, and the front panels they sit on.

Handles are built in a canonical frame (mounting face at local z = 0, protruding towards +z, length
along local x, local y up) and placed on a face with :func:`place_on_face`. Every style stays inside
the front it is mounted on, seen from the front, so moving fronts never carry a handle into a neighbour.
"""

from __future__ import annotations

import numpy as np

from spark_bench.data.synth.primitives import RGBA, Solid, box, cylinder, place

HANDLE_STYLES = ("bar", "square_bar", "loop", "knob", "edge", "recessed")
X, Y, Z = np.eye(3)


def place_on_face(solids: list[Solid], center, along, normal) -> list[Solid]:
    """Move canonical-frame solids onto a face: local x -> ``along``, local z -> ``normal``."""
    u = np.asarray(along, float) / np.linalg.norm(along)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    transform = np.eye(4)
    transform[:3, :3] = np.column_stack([u, np.cross(n, u), n])
    transform[:3, 3] = center
    return place(solids, transform)


def bar_handle(length: float, rng: np.random.Generator, color: RGBA, density: float,
               square: bool = False) -> list[Solid]:
    """Two posts and a bar; ``square`` gives a rectangular bar."""
    standoff = rng.uniform(0.022, 0.034)
    radius = rng.uniform(0.005, 0.008)
    post = radius * 0.8
    span = 0.5 * length - max(0.012, 0.1 * length)
    out = [cylinder((sx * span, 0, 0.5 * (standoff - 0.001)), post, standoff + 0.001, Z, color, density)
           for sx in (-1, 1)]
    if square:
        out.append(box((-0.5 * length, -radius, standoff - 0.001), (0.5 * length, radius, standoff + 2 * radius),
                       color, density))
    else:
        out.append(cylinder((0, 0, standoff + radius - 0.001), radius, length, X, color, density))
    return out


def loop_handle(length: float, rng: np.random.Generator, color: RGBA, density: float) -> list[Solid]:
    """A flat U-shaped strap pull."""
    standoff = rng.uniform(0.025, 0.035)
    width, thick = rng.uniform(0.012, 0.02), rng.uniform(0.004, 0.007)
    h = 0.5 * length
    return [
        box((-h, -0.5 * width, -0.001), (-h + thick, 0.5 * width, standoff), color, density),
        box((h - thick, -0.5 * width, -0.001), (h, 0.5 * width, standoff), color, density),
        box((-h, -0.5 * width, standoff - thick), (h, 0.5 * width, standoff), color, density),
    ]


def knob_handle(rng: np.random.Generator, color: RGBA, density: float) -> list[Solid]:
    """A small mushroom knob: stem and cap."""
    stem_r, stem_l = rng.uniform(0.005, 0.007), rng.uniform(0.012, 0.02)
    cap_r, cap_l = rng.uniform(0.012, 0.019), rng.uniform(0.008, 0.014)
    return [
        cylinder((0, 0, 0.5 * (stem_l - 0.001)), stem_r, stem_l + 0.001, Z, color, density),
        cylinder((0, 0, stem_l + 0.5 * cap_l - 0.001), cap_r, cap_l, Z, color, density),
    ]


def edge_lip(length: float, rng: np.random.Generator, color: RGBA, density: float) -> list[Solid]:
    """A lip along an edge of the front (local y = 0 is the edge, the lip lies below it)."""
    depth, thick = rng.uniform(0.016, 0.026), rng.uniform(0.004, 0.007)
    return [box((-0.5 * length, -thick - 0.001, -0.001), (0.5 * length, -0.001, depth), color, density)]


def handle_solids(style: str, length: float, rng: np.random.Generator, color: RGBA, density: float) -> list[Solid]:
    """Canonical-frame solids of a handle style (``recessed`` has none)."""
    if style == "bar":
        return bar_handle(length, rng, color, density)
    if style == "square_bar":
        return bar_handle(length, rng, color, density, square=True)
    if style == "loop":
        return loop_handle(length, rng, color, density)
    if style == "knob":
        return knob_handle(rng, color, density)
    if style == "edge":
        return edge_lip(length, rng, color, density)
    if style == "recessed":
        return []
    raise ValueError(f"unknown handle style {style!r}")


def front_panel(rect, z0: float, z1: float, style: str, where: str, rng: np.random.Generator,
                panel_color: RGBA, panel_density: float, handle_color: RGBA, handle_density: float
                ) -> tuple[list[Solid], list[Solid]]:
    """A front (drawer front, door, flap) facing +Z and its handle.

    :param rect: (x0, x1, y0, y1) of the front
    :param z0: back face of the front; ``z1`` its front face
    :param style: one of :data:`HANDLE_STYLES`
    :param where: ``center`` (drawers: horizontal, centred), ``top`` (flaps: horizontal near the top edge),
        ``bottom`` (horizontal near the bottom edge), ``left`` / ``right`` (doors: vertical near that free edge)
    :returns: (panel solids, handle solids), in object coordinates
    """
    x0, x1, y0, y1 = rect
    w, h = x1 - x0, y1 - y0
    vertical = where in ("left", "right")
    span = h if vertical else w
    length = float(np.clip(rng.uniform(0.3, 0.55) * span, 0.08, 0.6 if vertical else 0.45))
    length = min(length, span - 0.05)
    margin = rng.uniform(0.035, 0.05)
    if vertical:
        cx = x0 + margin if where == "left" else x1 - margin
        cy = float(np.clip(1.0, y0 + 0.5 * length + 0.03, y1 - 0.5 * length - 0.03))
        along = -Y if where == "right" else Y
    else:
        cx = 0.5 * (x0 + x1)
        cy = {"center": 0.5 * (y0 + y1) + 0.1 * h, "top": y1 - max(0.035, 0.12 * h),
              "bottom": y0 + max(0.035, 0.12 * h)}[where]
        along = X
    if style == "recessed":
        return notched_panel(rect, z0, z1, where, min(0.5 * span, max(0.08, 0.25 * span)), panel_color,
                             panel_density), []
    panel = [box((x0, y0, z0), (x1, y1, z1), panel_color, panel_density)]
    face = np.array([cx, cy, z1])
    if style == "edge":  # a lip on the edge itself
        if vertical:
            face = np.array([x0 if where == "left" else x1, cy, z1])
            along = Y if where == "left" else -Y
        else:
            face = np.array([cx, y0 if where == "bottom" else y1, z1])
            along = -X if where == "bottom" else X
        return panel, place_on_face(edge_lip(length, rng, handle_color, handle_density), face, along, Z)
    if style == "knob" and not vertical and w > 0.6:  # wide drawers get two knobs
        out = []
        for sx in (-0.25, 0.25):
            out += place_on_face(knob_handle(rng, handle_color, handle_density), face + sx * w * X, X, Z)
        return panel, out
    return panel, place_on_face(handle_solids(style, length, rng, handle_color, handle_density), face, along, Z)


def notched_panel(rect, z0: float, z1: float, where: str, notch: float, color: RGBA, density: float
                  ) -> list[Solid]:
    """A front with a finger-pull notch cut through it at the middle of the ``where`` edge."""
    x0, x1, y0, y1 = rect
    depth = 0.028
    if where in ("center", "top"):
        a, b = 0.5 * (x0 + x1) - 0.5 * notch, 0.5 * (x0 + x1) + 0.5 * notch
        return [box((x0, y0, z0), (x1, y1 - depth, z1), color, density),
                box((x0, y1 - depth, z0), (a, y1, z1), color, density),
                box((b, y1 - depth, z0), (x1, y1, z1), color, density)]
    if where == "bottom":
        a, b = 0.5 * (x0 + x1) - 0.5 * notch, 0.5 * (x0 + x1) + 0.5 * notch
        return [box((x0, y0 + depth, z0), (x1, y1, z1), color, density),
                box((x0, y0, z0), (a, y0 + depth, z1), color, density),
                box((b, y0, z0), (x1, y0 + depth, z1), color, density)]
    a = float(np.clip(1.0, y0 + 0.5 * notch + 0.02, y1 - 0.5 * notch - 0.02)) - 0.5 * notch
    b = a + notch
    if where == "left":
        return [box((x0 + depth, y0, z0), (x1, y1, z1), color, density),
                box((x0, y0, z0), (x0 + depth, a, z1), color, density),
                box((x0, b, z0), (x0 + depth, y1, z1), color, density)]
    return [box((x0, y0, z0), (x1 - depth, y1, z1), color, density),
            box((x1 - depth, y0, z0), (x1, a, z1), color, density),
            box((x1 - depth, b, z0), (x1, y1, z1), color, density)]


def rotary_knob(center, normal, radius: float, depth: float, gap: float, color: RGBA, density: float,
                pointer_color: RGBA | None = None) -> list[Solid]:
    """A control knob standing ``gap`` off a face at ``center`` (on the face), with a pointer ridge.

    It rotates about ``normal`` through ``center``; every piece stays within ``radius`` of that axis.
    """
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    body = cylinder((0, 0, gap + 0.5 * depth), radius, depth, Z, color, density)
    ridge = box((-0.75 * radius, -0.12 * radius, gap + depth - 0.001), (0.75 * radius, 0.12 * radius,
                gap + depth + 0.004), pointer_color or color, density)
    along = X if abs(n[0]) < 0.9 else Y
    along = along - n * float(along @ n)
    return place_on_face([body, ridge], center, along, n)
