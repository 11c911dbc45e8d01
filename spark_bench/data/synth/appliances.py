"""Appliances: Refrigerator, Microwave, Oven, Dishwasher, WashingMachine (front- and top-loading), CoffeeMachine,
Toaster, Printer."""

from __future__ import annotations

import numpy as np

from spark_bench.data.synth import palette
from spark_bench.data.synth.cabinet import CabinetStyle, Cell, Column, add_cabinet
from spark_bench.data.synth.common import X, Y, Z, appliance_colors, choice, new_object
from spark_bench.data.synth.handles import handle_solids, place_on_face, rotary_knob
from spark_bench.data.synth.primitives import box, cylinder
from spark_bench.data.synth.spec import JointSpec, ObjectSpec

APPLIANCE = palette.DENSITY["appliance"]
METAL = palette.DENSITY["metal"]
PLASTIC = palette.DENSITY["plastic"]


def _style(rng, shell, handle, **kwargs) -> CabinetStyle:
    base = dict(body_density=APPLIANCE, front_density=APPLIANCE, handle_density=METAL, door_label="door",
                handle_link=bool(rng.uniform() < 0.5), front_jitter=0.01)
    base.update(kwargs)
    return CabinetStyle(shell, shell, handle, **base)


def _knob(spec, rng, center, radius: float, color, parent: str = "body") -> None:
    depth = rng.uniform(0.012, 0.022)
    solids = rotary_knob(center, Z, radius, depth, 0.0015, color, PLASTIC, palette.contrasting(rng, color, palette.PLASTIC))
    spec.add("knob", "knob", solids, parent, JointSpec("continuous", center, Z))


def _panel_knobs(spec, rng, rect, face_z: float, count: int, color, vertical: bool = False) -> None:
    """``count`` control knobs spread over a panel rectangle (a row, or a column if ``vertical``)."""
    x0, x1, y0, y1 = rect
    span = (y1 - y0) if vertical else (x1 - x0)
    other = (x1 - x0) if vertical else (y1 - y0)
    radius = float(min(0.03, 0.3 * other, 0.35 * span / count))
    for k in range(count):
        t = (k + 0.5) / count
        center = (0.5 * (x0 + x1), y0 + t * (y1 - y0), face_z) if vertical else (x0 + t * (x1 - x0), 0.5 * (y0 + y1),
                                                                                face_z)
        _knob(spec, rng, np.array(center), radius, color)


def _feet(w, d, height, color, inset=0.03) -> list:
    return [cylinder((sx * (0.5 * w - inset), 0.5 * height, sz * (0.5 * d - inset)), 0.012, height + 0.001, Y, color,
                     PLASTIC) for sx in (-1, 1) for sz in (-1, 1)]


def refrigerator(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Refrigerator")
    w, h, d = rng.uniform(0.55, 0.9), rng.uniform(1.5, 1.9), rng.uniform(0.6, 0.75)
    shell, handle = appliance_colors(rng)
    style = _style(rng, shell, handle, panel=0.04, back=0.03, front=rng.uniform(0.045, 0.07), gap=0.006,
                   handle_style=choice(rng, ["bar", "square_bar", "recessed", "edge"]), door_upper=(np.pi / 2, 2.2))
    layout = choice(rng, ["top_freezer", "bottom_freezer", "side_by_side", "french", "single"])
    hinge = choice(rng, ["door_left", "door_right"])
    columns = {"top_freezer": [Column(1.0, [Cell(hinge, 2.2), Cell(hinge, 1.0)])],
               "bottom_freezer": [Column(1.0, [Cell("drawer", 1.0), Cell(hinge, 2.2)])],
               "side_by_side": [Column(rng.uniform(0.8, 1.0), [Cell("door")]), Column(1.0, [Cell("door")])],
               "french": [Column(1.0, [Cell("drawer", 1.0), Cell("double_door", 2.2)])],
               "single": [Column(1.0, [Cell(hinge)])]}[layout]
    foot = rng.uniform(0.015, 0.04)
    spec.part("body").solids += _feet(w, d, foot, palette.DARK)
    add_cabinet(spec, rng, (-0.5 * w, foot, -0.5 * d), (0.5 * w, h, 0.5 * d), columns, style)
    spec.params = {"layout": layout, "size": [w, h, d], "handle_style": style.handle_style}
    return spec


def microwave(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Microwave", semantic="free")
    w, h, d = rng.uniform(0.45, 0.6), rng.uniform(0.26, 0.36), rng.uniform(0.33, 0.45)
    shell, handle = appliance_colors(rng)
    style = _style(rng, shell, handle, panel=0.015, back=0.01, front=rng.uniform(0.022, 0.032), glass=True,
                   handle_style=choice(rng, ["bar", "square_bar", "recessed", "edge"]), door_upper=(np.pi / 2, 2.0))
    mirrored = rng.uniform() < 0.15
    door, panel = Column(rng.uniform(0.7, 0.78), [Cell("door_right" if mirrored else "door_left")]), \
        Column(0.25, [Cell("panel")])
    foot = 0.01
    spec.part("body").solids += _feet(w, d, foot, palette.DARK)
    cells = add_cabinet(spec, rng, (-0.5 * w, foot, -0.5 * d), (0.5 * w, h, 0.5 * d),
                        [panel, door] if mirrored else [door, panel], style)
    plate = next(c for c in cells if c.kind == "panel")
    _panel_knobs(spec, rng, plate.rect, plate.face_z, int(rng.integers(1, 3)), palette.PLASTIC["grey"], vertical=True)
    spec.params = {"size": [w, h, d], "mirrored": mirrored, "handle_style": style.handle_style}
    return spec


def oven(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Oven")
    w, h, d = rng.uniform(0.55, 0.76), rng.uniform(0.8, 0.92), rng.uniform(0.55, 0.65)
    shell, handle = appliance_colors(rng)
    style = _style(rng, shell, handle, panel=0.03, back=0.02, front=rng.uniform(0.03, 0.045), glass=True,
                   handle_style=choice(rng, ["bar", "square_bar"]))
    drawer = rng.uniform() < 0.5
    cells = ([Cell("drawer", 0.22)] if drawer else []) + [Cell("flap_down", 1.0), Cell("panel", 0.22)]
    plinth = rng.uniform(0.0, 0.05)
    body = spec.part("body")
    if plinth > 0.01:
        body.solids.append(box((-0.5 * w + 0.02, 0, -0.5 * d + 0.02), (0.5 * w - 0.02, plinth + 0.001, 0.5 * d - 0.05),
                               palette.DARK, APPLIANCE))
    else:
        plinth = 0.0
    built = add_cabinet(spec, rng, (-0.5 * w, plinth, -0.5 * d), (0.5 * w, h, 0.5 * d), [Column(1.0, cells)], style)
    plate = next(c for c in built if c.kind == "panel")
    _panel_knobs(spec, rng, plate.rect, plate.face_z, int(rng.integers(2, 7)), palette.PLASTIC["black"])
    burners = []
    for sx in (-0.22, 0.22):
        for sz in (-0.22, 0.22):
            r = rng.uniform(0.06, 0.1)
            burners.append(cylinder((sx * w, h + 0.004, sz * d), r, 0.01, Y, palette.DARK, METAL))
    body.solids += burners
    spec.params = {"size": [w, h, d], "storage_drawer": drawer, "movable_parts": len(spec.movable_parts())}
    return spec


def dishwasher(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Dishwasher")
    w, h, d = rng.uniform(0.45, 0.6), rng.uniform(0.82, 0.87), rng.uniform(0.55, 0.62)
    shell, handle = appliance_colors(rng)
    style = _style(rng, shell, handle, panel=0.025, back=0.02, front=rng.uniform(0.03, 0.05),
                   handle_style=choice(rng, ["bar", "square_bar", "recessed", "edge"]))
    built = add_cabinet(spec, rng, (-0.5 * w, 0.0, -0.5 * d), (0.5 * w, h, 0.5 * d),
                        [Column(1.0, [Cell("panel", 0.12), Cell("flap_down", 1.0)])], style)
    door = next(c for c in built if c.kind == "flap_down")
    if rng.uniform() < 0.7:  # a program knob on the door, near its top corner
        x0, x1, y0, y1 = door.rect
        _knob(spec, rng, np.array([x1 - 0.06, y1 - 0.045, door.face_z]), 0.018, palette.PLASTIC["grey"], door.parts[0])
    spec.params = {"size": [w, h, d], "handle_style": style.handle_style}
    return spec


def washing_machine(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("WashingMachine")
    w, h, d = rng.uniform(0.55, 0.62), rng.uniform(0.8, 0.9), rng.uniform(0.5, 0.62)
    shell, handle = appliance_colors(rng)
    style = _style(rng, shell, handle, panel=0.02, back=0.02, front=0.02, handle_link=False,
                   handle_style=choice(rng, ["recessed", "edge"]), drawer_label="drawer")
    top = rng.uniform(0.16, 0.2)
    cols = [Column(0.4, [Cell("panel", 1.0 - top), Cell("drawer", top)]),
            Column(0.6, [Cell("panel", 1.0 - top), Cell("panel", top)])]
    built = add_cabinet(spec, rng, (-0.5 * w, 0.0, -0.5 * d), (0.5 * w, h, 0.5 * d), cols, style)
    control = built[3]
    _panel_knobs(spec, rng, control.rect, control.face_z, int(rng.integers(1, 3)), palette.PLASTIC["grey"])
    face = built[0].face_z
    lower_top = built[0].rect[3]
    r = min(rng.uniform(0.16, 0.21), 0.4 * w, 0.5 * lower_top - 0.04)
    yc = 0.5 * lower_top + rng.uniform(0.0, 0.04)
    depth = rng.uniform(0.035, 0.06)
    ring_c = palette.jitter(rng, choice(rng, [shell[:3], palette.METAL["chrome"], palette.PLASTIC["grey"]]))
    z0 = face + 0.003
    hinge_left = rng.uniform() < 0.8
    free = 1.0 if hinge_left else -1.0
    pieces = [cylinder((0, yc, z0 + 0.5 * depth), r, depth, Z, ring_c, APPLIANCE),
              cylinder((0, yc, z0 + depth + 0.003), 0.72 * r, 0.008, Z, palette.GLASS, palette.DENSITY["glass"]),
              box((free * r - 0.012 if free > 0 else -r - 0.018, yc - 0.04, z0 + 0.005),
                  (r + 0.018 if free > 0 else -r + 0.012, yc + 0.04, z0 + depth - 0.005), handle, PLASTIC)]
    front = z0 + depth + 0.007
    pivot = np.array([-free * r, yc, front])
    spec.add("door", "door", pieces, "body",
             JointSpec("revolute", pivot, -Y if hinge_left else Y, 0.0, rng.uniform(np.pi / 2, 2.2), min_upper=1.4))
    spec.params = {"size": [w, h, d], "door_radius": r, "hinge_left": hinge_left}
    return spec


def top_loading_washer(rng: np.random.Generator) -> ObjectSpec:
    """A top-loading washing machine: its lid lies in the top deck, hinged at its back edge, the control console
    standing behind it with its knobs facing the user; the lid's front is its top face, not the body's front."""
    spec = new_object("WashingMachine")
    w, h, d = rng.uniform(0.55, 0.68), rng.uniform(0.82, 0.95), rng.uniform(0.55, 0.68)
    shell, handle = appliance_colors(rng)
    foot = rng.uniform(0.01, 0.03)
    body = spec.part("body")
    body.solids += _feet(w, d, foot, palette.DARK) + [box((-0.5 * w, foot, -0.5 * d), (0.5 * w, h, 0.5 * d), shell,
                                                         APPLIANCE)]
    console_d, console_h = rng.uniform(0.08, 0.13), rng.uniform(0.1, 0.17)
    console_front = -0.5 * d + console_d
    body.solids.append(box((-0.5 * w, h - 0.001, -0.5 * d), (0.5 * w, h + console_h, console_front), shell, APPLIANCE))
    _panel_knobs(spec, rng, (-0.4 * w, 0.4 * w, h + 0.02, h + console_h - 0.02), console_front,
                 int(rng.integers(1, 4)), palette.PLASTIC["grey"])
    # The hinge stands far enough in front of the console that the knobs (<= 24 mm proud) do not stop the lid
    # before it stands upright; past upright the console stops it (the clearance repair trims the limit).
    side, lid_t = rng.uniform(0.03, 0.07), rng.uniform(0.02, 0.035)
    back, front = console_front + rng.uniform(0.035, 0.05), 0.5 * d - rng.uniform(0.02, 0.06)
    y0 = h + 0.002
    lid_c = palette.jitter(rng, shell[:3], 0.02)
    lid = [box((-0.5 * w + side, y0, back), (0.5 * w - side, y0 + lid_t, front), lid_c, PLASTIC)]
    if rng.uniform() < 0.5:  # a window in the lid
        m = rng.uniform(0.04, 0.07)
        lid.append(box((-0.5 * w + side + m, y0 + lid_t - 0.001, back + m), (0.5 * w - side - m, y0 + lid_t + 0.003,
                                                                           front - m), palette.GLASS,
                       palette.DENSITY["glass"]))
    style = choice(rng, ["edge", "recessed"])
    if style == "edge":  # a lip along the lid's front edge, pulled up
        lid += place_on_face(handle_solids("edge", min(0.2, 0.5 * w), rng, handle, PLASTIC), (0, y0 + lid_t, front),
                             X, Z)
    pivot = np.array([0.0, y0 + lid_t, back])
    spec.add("door", "door", lid, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.5, 2.0), min_upper=1.3))
    spec.params = {"size": [w, h, d], "loading": "top", "handle_style": style, "console": [console_d, console_h]}
    return spec


def coffee_machine(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("CoffeeMachine", semantic="free")
    w, h, d = rng.uniform(0.2, 0.32), rng.uniform(0.3, 0.42), rng.uniform(0.3, 0.4)
    shell = palette.jitter(rng, choice(rng, [palette.APPLIANCE["black"], palette.APPLIANCE["steel"],
                                             palette.APPLIANCE["red"], palette.APPLIANCE["white"]]))
    accent = palette.contrasting(rng, shell, palette.METAL, 0.25)
    body = spec.part("body")
    base_h = rng.uniform(0.06, 0.08)
    tray = _style(rng, accent, shell, panel=0.006, back=0.006, front=0.008, handle_style="edge", handle_link=False)
    add_cabinet(spec, rng, (-0.5 * w, 0.0, -0.5 * d), (0.5 * w, base_h, 0.5 * d - 0.01),
                [Column(1.0, [Cell("drawer")])], tray)
    column_d = rng.uniform(0.4, 0.5) * d
    head_h = rng.uniform(0.08, 0.12)
    body.solids += [box((-0.5 * w, base_h, -0.5 * d), (0.5 * w, h, -0.5 * d + column_d), shell, APPLIANCE),
                    box((-0.5 * w, h - head_h, -0.5 * d + column_d - 0.001), (0.5 * w, h, 0.5 * d - 0.01), shell,
                        APPLIANCE),
                    cylinder((0, h - head_h - 0.015, 0.5 * (column_d - 0.01)), 0.02, 0.031, Y, accent,
                             METAL)]
    lid_t = rng.uniform(0.01, 0.016)
    lid = [box((-0.5 * w + 0.015, h + 0.002, -0.5 * d + 0.01), (0.5 * w - 0.015, h + 0.002 + lid_t,
                                                                -0.5 * d + column_d - 0.01), accent, PLASTIC)]
    pivot = np.array([0.0, h + 0.002 + lid_t, -0.5 * d + 0.01])
    spec.add("lid", "lid", lid, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.2, 1.9), min_upper=1.0))
    front = 0.5 * d - 0.01
    radius = min(0.022, 0.3 * head_h)
    _knob(spec, rng, np.array([0.25 * w, h - 0.5 * head_h, front]), radius, accent)
    spec.params = {"size": [w, h, d], "head": head_h}
    return spec


def toaster(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Toaster", semantic="free")
    w, h, d = rng.uniform(0.25, 0.34), rng.uniform(0.17, 0.22), rng.uniform(0.15, 0.2)
    shell = palette.jitter(rng, choice(rng, list(palette.APPLIANCE.values()) + [palette.METAL["chrome"]]))
    accent = palette.contrasting(rng, shell, palette.PLASTIC, 0.25)
    n = int(rng.integers(1, 3))
    slot_w, slot_d, end = rng.uniform(0.028, 0.038), rng.uniform(0.09, 0.12), rng.uniform(0.03, 0.045)
    wall = (d - n * slot_w) / (n + 1)
    base_top = h - slot_d
    body = spec.part("body")
    body.solids += [box((-0.5 * w, 0, -0.5 * d), (0.5 * w, base_top, 0.5 * d), shell, APPLIANCE),
                    box((-0.5 * w, base_top - 0.001, -0.5 * d), (-0.5 * w + end, h, 0.5 * d), shell, APPLIANCE),
                    box((0.5 * w - end, base_top - 0.001, -0.5 * d), (0.5 * w, h, 0.5 * d), shell, APPLIANCE)]
    for k in range(n + 1):
        z = -0.5 * d + k * (wall + slot_w)
        body.solids.append(box((-0.5 * w + end - 0.001, base_top - 0.001, z), (0.5 * w - end + 0.001, h, z + wall),
                               shell, APPLIANCE))
    xl = 0.5 * w - 0.5 * end - 0.01
    top = h - 0.025
    lever = [box((xl - 0.016, top - 0.014, 0.5 * d + 0.002), (xl + 0.016, top, 0.5 * d + 0.03), accent, PLASTIC)]
    travel = (top - 0.014) - 0.03
    spec.add("lever", "lever", lever, "body",
             JointSpec("prismatic", (xl, top - 0.007, 0.5 * d + 0.03), -Y, 0.0, rng.uniform(0.75, 0.9) * travel,
                       min_upper=0.6 * travel))
    if rng.uniform() < 0.7:
        _knob(spec, rng, np.array([-0.5 * w + 0.045, 0.045, 0.5 * d]), 0.016, accent)
    spec.params = {"size": [w, h, d], "slots": n}
    return spec


def printer(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Printer", semantic="free")
    w, h, d = rng.uniform(0.38, 0.5), rng.uniform(0.18, 0.3), rng.uniform(0.32, 0.45)
    shell = palette.jitter(rng, palette.PLASTIC[choice(rng, ["black", "white", "grey"])], 0.02)
    accent = palette.contrasting(rng, shell, palette.PLASTIC, 0.25)
    style = _style(rng, shell, accent, panel=0.01, back=0.01, front=0.012, handle_link=False, body_density=PLASTIC,
                   front_density=PLASTIC, handle_style="recessed", flap_label="door",
                   drawer_label="drawer")
    add_cabinet(spec, rng, (-0.5 * w, 0.0, -0.5 * d), (0.5 * w, h, 0.5 * d),
                [Column(1.0, [Cell("drawer", 0.35), Cell("flap_down", 0.3), Cell("panel", 0.35)])], style)
    lid_t = rng.uniform(0.02, 0.035)
    lid = [box((-0.5 * w + 0.005, h + 0.002, -0.5 * d + 0.005), (0.5 * w - 0.005, h + 0.002 + lid_t, 0.5 * d - 0.005),
               palette.jitter(rng, shell[:3], 0.02), PLASTIC)]
    pivot = np.array([0.0, h + 0.002 + lid_t, -0.5 * d + 0.005])
    spec.add("lid", "lid", lid, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.2, 1.6), min_upper=1.0))
    spec.params = {"size": [w, h, d], "handle_style": style.handle_style}
    return spec


BUILDERS = {"Refrigerator": refrigerator, "Microwave": microwave, "Oven": oven, "Dishwasher": dishwasher,
            "WashingMachine": washing_machine, "CoffeeMachine": coffee_machine, "Toaster": toaster,
            "Printer": printer}
#: Variants of a category that no named benchmark draws (:data:`~spark_bench.data.synth.generate.VARIANTS`).
VARIANTS = {"TopLoadingWasher": top_loading_washer}
