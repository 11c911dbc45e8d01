"""Furniture and building parts: StorageFurniture, Table, Safe, Box, Door, Window."""

from __future__ import annotations

import numpy as np

from spark_bench.data.synth import palette
from spark_bench.data.synth.cabinet import CabinetStyle, Cell, Column, add_cabinet
from spark_bench.data.synth.common import X, Y, Z, choice, handle_style, legs, new_object, wood_style_colors
from spark_bench.data.synth.handles import handle_solids, place_on_face, rotary_knob
from spark_bench.data.synth.primitives import RGBA, Solid, box, cylinder
from spark_bench.data.synth.spec import JointSpec, ObjectSpec

STORAGE_LAYOUTS = ("mixed", "dresser", "sideboard", "cupboard", "wardrobe", "apothecary", "nightstand", "wall")


def _drawers(k: int, rng) -> list[Cell]:
    return [Cell("drawer", rng.uniform(0.8, 1.2)) for _ in range(k)]


def _storage_columns(rng, layout: str) -> tuple[tuple[float, float, float], list[Column]]:
    """(width, height, depth) and front columns of a storage-furniture layout."""
    if layout == "mixed":
        doors = Column(rng.uniform(0.9, 1.3), [Cell("door", 1.0)])
        drawers = Column(1.0, _drawers(int(rng.integers(2, 5)), rng))
        cols = [doors, drawers] if rng.uniform() < 0.5 else [drawers, doors]
        return (rng.uniform(0.7, 1.2), rng.uniform(0.7, 1.0), rng.uniform(0.4, 0.6)), cols
    if layout == "dresser":
        k = int(rng.integers(3, 6))
        cols = [Column(1.0, _drawers(k, rng)) for _ in range(int(rng.integers(1, 3)))]
        return (rng.uniform(0.55, 1.2), rng.uniform(0.7, 1.2), rng.uniform(0.4, 0.55)), cols
    if layout == "sideboard":
        middle = choice(rng, [_drawers(int(rng.integers(2, 4)), rng), [Cell("open")], [Cell("door_left")]])
        cols = [Column(1.0, [Cell("door")]), Column(rng.uniform(0.7, 1.2), middle), Column(1.0, [Cell("door")])]
        return (rng.uniform(1.2, 1.8), rng.uniform(0.65, 0.9), rng.uniform(0.4, 0.55)), cols
    if layout == "cupboard":
        doors = choice(rng, [Cell("double_door", 3.0), Cell("door", 3.0)])
        cells = [doors, Cell("drawer", 1.0)] if rng.uniform() < 0.6 else [doors]
        return (rng.uniform(0.5, 1.0), rng.uniform(0.7, 1.0), rng.uniform(0.4, 0.6)), [Column(1.0, cells)]
    if layout == "wardrobe":
        if rng.uniform() < 0.5:
            cols = [Column(1.0, [Cell("drawer", 1.0), Cell("drawer", 1.0), Cell("double_door", 7.0)])]
        else:
            cols = [Column(1.0, [Cell("drawer", 1.0), Cell("door", 5.0)]) for _ in range(2)]
        return (rng.uniform(0.8, 1.3), rng.uniform(1.7, 2.1), rng.uniform(0.5, 0.62)), cols
    if layout == "apothecary":
        rows = int(rng.integers(3, 6))
        cols = [Column(1.0, [Cell("drawer") for _ in range(rows)]) for _ in range(int(rng.integers(2, 5)))]
        return (rng.uniform(0.5, 1.0), rng.uniform(0.5, 1.1), rng.uniform(0.35, 0.45)), cols
    if layout == "nightstand":
        lower = choice(rng, [Cell("open", 1.2), Cell("door", 1.5), Cell("drawer", 1.0)])
        return (rng.uniform(0.4, 0.55), rng.uniform(0.45, 0.65), rng.uniform(0.35, 0.45)), \
            [Column(1.0, [lower, Cell("drawer", 1.0)])]
    if layout == "wall":
        cells = choice(rng, [[Cell("double_door")], [Cell("flap_up")], [Cell("open", 0.8), Cell("door", 1.5)]])
        return (rng.uniform(0.5, 1.0), rng.uniform(0.45, 0.8), rng.uniform(0.28, 0.36)), [Column(1.0, cells)]
    raise ValueError(layout)


def storage_furniture(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("StorageFurniture")
    layout = choice(rng, STORAGE_LAYOUTS, [3, 2, 2, 2, 1, 1, 1, 1])
    (w, h, d), columns = _storage_columns(rng, layout)
    body_c, front_c, handle_c = wood_style_colors(rng)
    style = CabinetStyle(body_c, front_c, handle_c, panel=rng.uniform(0.015, 0.022), front=rng.uniform(0.016, 0.022),
                         handle_style=handle_style(rng), handle_link=bool(rng.uniform() < 0.7))
    base = "none" if layout == "wall" else choice(rng, ["plinth", "legs", "none"], [2, 1, 1])
    base_h = {"plinth": rng.uniform(0.05, 0.1), "legs": rng.uniform(0.1, 0.2), "none": 0.0}[base]
    body = spec.part("body")
    if base == "plinth":
        body.solids.append(box((-0.5 * w + 0.015, 0, -0.5 * d + 0.015), (0.5 * w - 0.015, base_h, 0.5 * d - 0.04),
                               body_c, style.body_density))
    elif base == "legs":
        body.solids += legs(rng, -0.5 * w, 0.5 * w, -0.5 * d, 0.5 * d, base_h + 0.001, body_c, style.body_density)
    top_h = h
    if rng.uniform() < 0.5:  # a top board overhanging sides and front
        side, front, thick = rng.uniform(0.0, 0.03), rng.uniform(0.01, 0.035), rng.uniform(0.018, 0.035)
        top_h = h - thick
        body.solids.append(box((-0.5 * w - side, top_h, -0.5 * d), (0.5 * w + side, h, 0.5 * d + front),
                               body_c, style.body_density))
    add_cabinet(spec, rng, (-0.5 * w, base_h, -0.5 * d), (0.5 * w, top_h, 0.5 * d), columns, style)
    spec.params = {"layout": layout, "size": [w, h, d], "base": base, "handle_style": style.handle_style,
                   "handle_link": style.handle_link}
    return spec


def table(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Table")
    body = spec.part("body")
    kind = choice(rng, ["writing", "desk"], [1, 1])
    w, d = rng.uniform(0.9, 1.6), rng.uniform(0.5, 0.8)
    h, top_t = rng.uniform(0.72, 0.78), rng.uniform(0.02, 0.04)
    body_c, front_c, handle_c = wood_style_colors(rng)
    style = CabinetStyle(body_c, front_c, handle_c, handle_style=handle_style(rng), handle_link=bool(rng.uniform() < 0.6),
                         front=rng.uniform(0.016, 0.02))
    dens = style.body_density
    overhang = rng.uniform(0.02, 0.06)
    y_top = h - top_t
    body.solids.append(box((-0.5 * w, y_top, -0.5 * d), (0.5 * w, h, 0.5 * d), body_c, dens))
    leg = rng.uniform(0.04, 0.06)
    zx0, zx1 = -0.5 * d + overhang, 0.5 * d - overhang - style.standoff - style.front - 0.03
    if kind == "writing":
        hx = 0.5 * w - overhang - leg
        apron = rng.uniform(0.1, 0.16)
        n = int(rng.integers(1, 4))
        add_cabinet(spec, rng, (-hx, y_top - apron, zx0), (hx, y_top, zx1),
                    [Column(1.0, [Cell("drawer")]) for _ in range(n)], style)
        for x in (-hx - leg, hx):
            for z in (zx0, zx1 - leg):
                body.solids.append(box((x, 0, z), (x + leg, y_top, z + leg), body_c, dens))
    else:
        pw = rng.uniform(0.35, 0.5)
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        outer = 0.5 * w - overhang
        px0, px1 = sorted((side * outer, side * (outer - pw)))
        k = int(rng.integers(2, 5))
        add_cabinet(spec, rng, (px0, 0.0, zx0), (px1, y_top, zx1), [Column(1.0, _drawers(k, rng))], style)
        x = -side * outer if side > 0 else -side * outer - leg
        for z in (zx0, zx1 - leg):
            body.solids.append(box((x, 0, z), (x + leg, y_top, z + leg), body_c, dens))
    spec.params = {"kind": kind, "size": [w, h, d], "handle_style": style.handle_style}
    return spec


def safe(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Safe")
    w, h, d = rng.uniform(0.3, 0.6), rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.5)
    shell = palette.jitter(rng, choice(rng, [(0.15, 0.15, 0.16), (0.35, 0.36, 0.38), (0.78, 0.74, 0.64),
                                             (0.2, 0.25, 0.2)]))
    metal = palette.contrasting(rng, shell)
    t = rng.uniform(0.025, 0.045)
    style = CabinetStyle(shell, shell, metal, body_density=palette.DENSITY["metal"] * 0.3,
                         front_density=palette.DENSITY["metal"] * 0.3, panel=t, back=t, front=rng.uniform(0.04, 0.06),
                         handle_style="recessed", handle_link=False, door_label="door",
                         door_upper=(np.pi / 2, 2.1))
    cell = choice(rng, ["door_left", "door_right"])
    (door_cell,) = add_cabinet(spec, rng, (-0.5 * w, 0.0, -0.5 * d), (0.5 * w, h, 0.5 * d),
                               [Column(1.0, [Cell(cell)])], style)
    door = door_cell.parts[0]
    x0, x1, y0, y1 = door_cell.rect
    face = door_cell.face_z
    dial_r = min(0.04, 0.12 * (x1 - x0))
    hinge_left = cell == "door_left"
    dial_c = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1) + 0.2 * (y1 - y0), face])
    spec.add("dial", "knob", rotary_knob(dial_c, Z, dial_r, 0.02, 0.0015, metal, palette.DENSITY["metal"]),
             door, JointSpec("continuous", dial_c, Z))
    lever_c = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1) - 0.2 * (y1 - y0), face])
    arm = min(0.09, 0.18 * (y1 - y0), 0.35 * (x1 - x0))
    lever = [cylinder(lever_c + [0, 0, 0.0015 + 0.01], 0.018, 0.02, Z, metal, palette.DENSITY["metal"]),
             box(lever_c + [-0.01, -arm, 0.0015 + 0.012], lever_c + [0.01, arm, 0.0015 + 0.024], metal,
                 palette.DENSITY["metal"])]
    upper = rng.uniform(0.6, 1.2)
    spec.add("lever", "handle", lever, door, JointSpec("revolute", lever_c, Z if hinge_left else -Z, 0.0, upper,
                                                      min_upper=0.5))
    spec.params = {"size": [w, h, d], "hinge": cell, "wall": t}
    return spec


def storage_box(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Box", semantic="free")
    w, h, d = rng.uniform(0.2, 0.6), rng.uniform(0.1, 0.35), rng.uniform(0.15, 0.45)
    t = rng.uniform(0.006, 0.015)
    material = choice(rng, ["wood", "plastic", "metal"])
    table_ = {"wood": palette.WOOD, "plastic": palette.PLASTIC, "metal": palette.METAL}[material]
    color = palette.jitter(rng, table_[palette.pick(rng, table_)])
    dens = palette.DENSITY[material]
    body = spec.part("body")
    body.solids += [box((-0.5 * w, 0, -0.5 * d), (0.5 * w, t, 0.5 * d), color, dens),
                    box((-0.5 * w, t, -0.5 * d), (-0.5 * w + t, h, 0.5 * d), color, dens),
                    box((0.5 * w - t, t, -0.5 * d), (0.5 * w, h, 0.5 * d), color, dens),
                    box((-0.5 * w + t, t, -0.5 * d), (0.5 * w - t, h, -0.5 * d + t), color, dens),
                    box((-0.5 * w + t, t, 0.5 * d - t), (0.5 * w - t, h, 0.5 * d), color, dens)]
    lid_c = palette.jitter(rng, color[:3], 0.03)
    lt, gap, over = rng.uniform(0.008, 0.02), 0.002, rng.uniform(0.0, 0.01)
    y0 = h + gap
    lid = [box((-0.5 * w - over, y0, -0.5 * d), (0.5 * w + over, y0 + lt, 0.5 * d + over), lid_c, dens)]
    skirt = rng.uniform() < 0.5
    if skirt:  # front and side skirts hanging outside the walls
        sk, st = rng.uniform(0.015, 0.04), 0.006
        lid += [box((-0.5 * w - over - st - gap, y0 - sk, -0.5 * d + 0.01), (-0.5 * w - gap, y0 + lt, 0.5 * d + over),
                    lid_c, dens),
                box((0.5 * w + gap, y0 - sk, -0.5 * d + 0.01), (0.5 * w + over + st + gap, y0 + lt, 0.5 * d + over),
                    lid_c, dens),
                box((-0.5 * w - gap, y0 - sk, 0.5 * d + gap), (0.5 * w + gap, y0 + lt, 0.5 * d + gap + st),
                    lid_c, dens)]
    front_z = max(s.center[2] + 0.5 * s.size[2] for s in lid)
    style = handle_style(rng, ("knob", "edge", "loop"))
    handle_c = palette.contrasting(rng, lid_c)
    length = min(0.12, 0.4 * w)
    if style == "edge":
        grip = place_on_face(handle_solids("edge", length, rng, handle_c, palette.DENSITY["metal"]),
                             (0, y0 + lt, front_z), X, Z)
    else:  # on the front face of the lid (skirt) or, without a skirt, on its top near the front
        face = (0, y0 + lt, 0.5 * d + over - 0.03) if not skirt else (0, y0 - 0.005, front_z)
        grip = place_on_face(handle_solids(style, length, rng, handle_c, palette.DENSITY["metal"]), face, X,
                             Y if not skirt else Z)
    pivot = np.array([0.0, y0 + lt, -0.5 * d])
    upper = rng.uniform(np.pi / 2, 2.2)
    spec.add("lid", "rotation_lid", lid + grip, "body", JointSpec("revolute", pivot, -X, 0.0, upper, min_upper=1.4))
    spec.params = {"size": [w, h, d], "material": material, "skirt": skirt, "handle_style": style}
    return spec


def _frame(w: float, h: float, fw: float, fd: float, bottom: tuple[float, float], color: RGBA,
           density: float) -> list[Solid]:
    """A door or window frame around the opening ``|x| < w / 2``, ``bottom[1] < y < h``: two posts of
    width ``fw`` from ``bottom[0]`` up to ``h + fw``, the head above the opening and the sill (or
    bottom rail) from ``bottom[0]`` to ``bottom[1]`` between the posts; ``fd`` deep, centered on z = 0.
    """
    y0, y1 = bottom
    return [box((-0.5 * w - fw, y0, -0.5 * fd), (-0.5 * w, h + fw, 0.5 * fd), color, density),
            box((0.5 * w, y0, -0.5 * fd), (0.5 * w + fw, h + fw, 0.5 * fd), color, density),
            box((-0.5 * w, h, -0.5 * fd), (0.5 * w, h + fw, 0.5 * fd), color, density),
            box((-0.5 * w, y0, -0.5 * fd), (0.5 * w, y1, 0.5 * fd), color, density)]


def door(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Door", semantic="static")
    body = spec.part("body")
    w, h = rng.uniform(0.75, 0.95), rng.uniform(1.95, 2.1)
    fw, fd = rng.uniform(0.05, 0.1), rng.uniform(0.1, 0.15)
    frame_c = palette.jitter(rng, palette.WOOD[palette.pick(rng, palette.WOOD)])
    leaf_c = frame_c if rng.uniform() < 0.5 else palette.jitter(rng, palette.WOOD[palette.pick(rng, palette.WOOD)])
    dens = palette.DENSITY["wood"]
    sill = 0.01
    body.solids += _frame(w, h, fw, fd, (0, sill), frame_c, dens)
    gap, t = 0.004, rng.uniform(0.035, 0.045)
    hinge = choice(rng, ["left", "right"])
    x0, x1, y0, y1 = -0.5 * w + gap, 0.5 * w - gap, sill + 0.008, h - gap
    z1 = 0.5 * fd
    leaf = [box((x0, y0, z1 - t), (x1, y1, z1), leaf_c, dens)]
    if rng.uniform() < 0.5:  # raised panels
        for py0, py1 in ((y0 + 0.15, 0.5 * (y0 + y1) - 0.1), (0.5 * (y0 + y1) + 0.1, y1 - 0.15)):
            leaf.append(box((x0 + 0.12, py0, z1 - 0.001), (x1 - 0.12, py1, z1 + 0.006), leaf_c, dens))
    pivot = np.array([x0 if hinge == "left" else x1, 0.5 * (y0 + y1), z1])
    spec.add("leaf", "rotation_door", leaf, "body",
             JointSpec("revolute", pivot, -Y if hinge == "left" else Y, 0.0, rng.uniform(np.pi / 2, 1.95),
                       min_upper=1.4))
    metal = palette.contrasting(rng, leaf_c)
    md = palette.DENSITY["metal"]
    hx = x1 - 0.065 if hinge == "left" else x0 + 0.065
    hy = rng.uniform(0.95, 1.05)
    sign = -1.0 if hinge == "left" else 1.0  # the lever points towards the hinge
    kind = choice(rng, ["lever", "knob"], [2, 1])
    pieces = []
    for face, normal in ((z1, 1.0), (z1 - t, -1.0)):
        base = face + normal * 0.0015
        if kind == "lever":
            pieces += [cylinder((hx, hy, base + normal * 0.006), 0.025, 0.012, Z, metal, md),
                       cylinder((hx, hy, base + normal * 0.03), 0.009, 0.04, Z, metal, md),
                       box((min(hx, hx + sign * 0.13), hy - 0.008, base + normal * 0.045 - 0.008),
                           (max(hx, hx + sign * 0.13), hy + 0.008, base + normal * 0.045 + 0.008), metal, md)]
        else:
            pieces += [cylinder((hx, hy, base + normal * 0.005), 0.028, 0.01, Z, metal, md),
                       cylinder((hx, hy, base + normal * 0.025), 0.011, 0.03, Z, metal, md),
                       cylinder((hx, hy, base + normal * 0.05), 0.027, 0.022, Z, metal, md)]
    pivot_h = np.array([hx, hy, z1])
    if kind == "lever":
        joint = JointSpec("revolute", pivot_h, Z if hinge == "left" else -Z, 0.0, rng.uniform(0.5, 0.8), min_upper=0.4)
    else:
        joint = JointSpec("continuous", pivot_h, Z)
    spec.add("handle", "handle", pieces, "leaf", joint)
    spec.params = {"size": [w, h], "frame": [fw, fd], "hinge": hinge, "handle": kind}
    return spec


def window(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Window", semantic="static")
    body = spec.part("body")
    w, h = rng.uniform(0.6, 1.4), rng.uniform(0.6, 1.4)
    fw, fd = rng.uniform(0.04, 0.07), rng.uniform(0.08, 0.12)
    frame_c = palette.jitter(rng, choice(rng, [palette.WOOD["white"], palette.WOOD["oak"], palette.METAL["graphite"],
                                               palette.WOOD["walnut"]]))
    dens = palette.DENSITY["wood"]
    body.solids += _frame(w, h, fw, fd, (-fw, 0), frame_c, dens)
    kind = choice(rng, ["casement", "double_casement", "sliding", "awning"])
    gap, t, rail = 0.004, rng.uniform(0.035, 0.05), rng.uniform(0.04, 0.06)
    z1 = 0.5 * fd

    def sash(x0, x1, y0, y1, za, zb):
        return [box((x0, y0, za), (x0 + rail, y1, zb), frame_c, dens), box((x1 - rail, y0, za), (x1, y1, zb), frame_c, dens),
                box((x0 + rail, y0, za), (x1 - rail, y0 + rail, zb), frame_c, dens),
                box((x0 + rail, y1 - rail, za), (x1 - rail, y1, zb), frame_c, dens),
                box((x0 + rail - 0.002, y0 + rail - 0.002, 0.5 * (za + zb) - 0.003),
                    (x1 - rail + 0.002, y1 - rail + 0.002, 0.5 * (za + zb) + 0.003), palette.GLASS, 2500.0)]

    y0, y1 = gap, h - gap
    if kind in ("casement", "double_casement"):
        hinges = ["left"] if kind == "casement" and rng.uniform() < 0.5 else ["right"] if kind == "casement" \
            else ["left", "right"]
        mid = max(gap, t * t / (0.5 * w) + 0.003)  # the free edges' back corners swing towards each other
        edges = [(-0.5 * w + gap, 0.5 * w - gap)] if len(hinges) == 1 else \
            [(-0.5 * w + gap, -0.5 * mid), (0.5 * mid, 0.5 * w - gap)]
        for hinge, (x0, x1) in zip(hinges, edges):
            pivot = np.array([x0 if hinge == "left" else x1, 0.5 * (y0 + y1), z1])
            spec.add("sash", "window", sash(x0, x1, y0, y1, z1 - t, z1), "body",
                     JointSpec("revolute", pivot, -Y if hinge == "left" else Y, 0.0, rng.uniform(1.2, np.pi / 2),
                               min_upper=1.0))
    elif kind == "awning":
        pivot = np.array([0.0, y1, z1])
        spec.add("sash", "window", sash(-0.5 * w + gap, 0.5 * w - gap, y0, y1, z1 - t, z1), "body",
                 JointSpec("revolute", pivot, -X, 0.0, rng.uniform(0.5, 1.0), min_upper=0.4))
    else:  # two sashes in two tracks; the front one slides over the fixed back one
        t = min(t, 0.5 * (fd - 0.012))
        half = 0.5 * w + 0.5 * rail
        back = sash(0.5 * w - gap - half, 0.5 * w - gap, y0, y1, z1 - 2 * t - 0.006, z1 - t - 0.006)
        body.solids += back
        x0 = -0.5 * w + gap
        travel = (0.5 * w - gap) - (x0 + half) - 0.002
        spec.add("sash", "window", sash(x0, x0 + half, y0, y1, z1 - t, z1), "body",
                 JointSpec("prismatic", (x0 + 0.5 * half, 0.5 * (y0 + y1), z1), X, 0.0, rng.uniform(0.8, 0.95) * travel,
                           min_upper=0.6 * travel))
    spec.params = {"size": [w, h], "kind": kind, "frame": [fw, fd]}
    return spec


BUILDERS = {"StorageFurniture": storage_furniture, "Table": table, "Safe": safe, "Box": storage_box, "Door": door,
            "Window": window}
