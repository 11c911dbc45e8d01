"""Household objects: Laptop, Suitcase, TrashCan, Toilet, Faucet, Bucket, KitchenPot."""

from __future__ import annotations

import numpy as np

from spark_bench.data.synth import palette
from spark_bench.data.synth.common import X, Y, Z, choice, new_object
from spark_bench.data.synth.handles import handle_solids, place_on_face
from spark_bench.data.synth.primitives import box, cylinder, frustum, oriented_box
from spark_bench.data.synth.spec import JointSpec, ObjectSpec

PLASTIC = palette.DENSITY["plastic"]
METAL = palette.DENSITY["metal"]


def laptop(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Laptop", semantic="free")
    w, d = rng.uniform(0.3, 0.4), rng.uniform(0.2, 0.27)
    base_t, screen_t = rng.uniform(0.014, 0.022), rng.uniform(0.005, 0.009)
    shell = palette.jitter(rng, choice(rng, [palette.METAL["steel"], palette.METAL["graphite"], palette.PLASTIC["black"],
                                             palette.METAL["chrome"], palette.PLASTIC["white"]]), 0.02)
    keys = palette.DARK if palette.luminance(shell) > 0.3 else palette.rgba((0.25, 0.25, 0.27))
    spec.part("body").solids += [
        box((-0.5 * w, 0, -0.5 * d), (0.5 * w, base_t, 0.5 * d), shell, 2000.0),
        box((-0.5 * w + 0.02, base_t - 0.001, -0.5 * d + 0.02), (0.5 * w - 0.02, base_t + 0.0005, 0.02), keys, 2000.0)]
    y0 = base_t + 0.003
    screen = [box((-0.5 * w, y0, -0.5 * d), (0.5 * w, y0 + screen_t, 0.5 * d), shell, 2000.0),
              box((-0.5 * w + 0.012, y0 - 0.0005, -0.5 * d + 0.01), (0.5 * w - 0.012, y0 + 0.001, 0.5 * d - 0.012),
                  palette.GLASS, 2500.0)]
    pivot = np.array([0.0, y0 + screen_t, -0.5 * d])
    spec.add("screen", "screen", screen, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.75, 2.3),
                                                           min_upper=1.6))
    spec.params = {"size": [w, base_t + screen_t, d]}
    return spec


def suitcase(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Suitcase", semantic="free")
    w, h, d = rng.uniform(0.35, 0.5), rng.uniform(0.5, 0.75), rng.uniform(0.2, 0.3)
    shell = palette.jitter(rng, palette.PLASTIC[palette.pick(rng, palette.PLASTIC)], 0.03)
    trim = palette.contrasting(rng, shell, palette.METAL, 0.2)
    r, wheel_w = rng.uniform(0.025, 0.04), rng.uniform(0.018, 0.025)
    yb = 2 * r + 0.004
    body = spec.part("body")
    body.solids.append(box((-0.5 * w, yb, -0.5 * d), (0.5 * w, yb + h, 0.5 * d), shell, 250.0))
    body.solids += [box((sx * (0.5 * w - 0.04) - 0.015, 0, 0.5 * d - 0.045), (sx * (0.5 * w - 0.04) + 0.015, yb + 0.001,
                                                                               0.5 * d - 0.01), palette.DARK, PLASTIC)
                    for sx in (-1, 1)]
    body.solids += place_on_face(handle_solids("loop", min(0.14, 0.4 * w), rng, trim, PLASTIC), (0, yb + h, 0), X, Y)
    rod, xr = 0.016, rng.uniform(0.25, 0.35) * w
    z1 = -0.5 * d - 0.004
    top = yb + h + 0.02
    pull = [box((sx * xr - 0.5 * rod, yb + 0.08, z1 - rod), (sx * xr + 0.5 * rod, top, z1), trim, METAL) for sx in (-1, 1)]
    pull.append(box((-xr - 0.5 * rod - 0.008, top - 0.001, z1 - rod), (xr + 0.5 * rod + 0.008, top + 0.025, z1), palette.DARK,
                    PLASTIC))
    travel = top - (yb + 0.08)
    spec.add("pull_handle", "handle", pull, "body",
             JointSpec("prismatic", (0, top, z1), Y, 0.0, rng.uniform(0.6, 0.8) * travel, min_upper=0.5 * travel))
    for sx in (-1, 1):
        center = np.array([sx * (0.5 * w - 0.04), r, -0.5 * d + r + 0.005])
        spec.add("wheel", "wheel", [cylinder(center, r, wheel_w, X, palette.DARK, 1100.0)], "body",
                 JointSpec("continuous", center, X))
    spec.params = {"size": [w, h, d], "wheel_radius": r}
    return spec


def trash_can(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("TrashCan", semantic="free")
    round_ = rng.uniform() < 0.5
    h = rng.uniform(0.3, 0.7)
    color = palette.jitter(rng, choice(rng, list(palette.PLASTIC.values()) + [palette.METAL["steel"]]))
    dens = PLASTIC
    body = spec.part("body")
    if round_:
        r = rng.uniform(0.12, 0.2)
        half_w, half_d = r, r
        body.solids.append(cylinder((0, 0.5 * h, 0), r, h, Y, color, dens))
    else:
        half_w, half_d = rng.uniform(0.12, 0.22), rng.uniform(0.12, 0.2)
        body.solids.append(box((-half_w, 0, -half_d), (half_w, h, half_d), color, dens))
    lid_c = palette.jitter(rng, color[:3] if rng.uniform() < 0.5 else palette.METAL["steel"], 0.02)
    lt, over = rng.uniform(0.015, 0.03), 0.004
    y0 = h + 0.002
    if round_:
        lid = [cylinder((0, y0 + 0.5 * lt, 0), half_w + over, lt, Y, lid_c, dens)]
    else:
        lid = [box((-half_w - over, y0, -half_d - over), (half_w + over, y0 + lt, half_d + over), lid_c, dens)]
    kind = choice(rng, ["pedal", "hinged", "lift"])
    if kind == "lift":
        lid += place_on_face(handle_solids("knob", 0.05, rng, palette.contrasting(rng, lid_c), dens), (0, y0 + lt, 0), X, Y)
        spec.add("lid", "lid", lid, "body", JointSpec("prismatic", (0, y0 + lt, 0), Y, 0.0, rng.uniform(0.1, 0.2),
                                                      min_upper=0.08))
    else:
        if kind == "hinged":
            lid += place_on_face(handle_solids("edge", 0.08, rng, palette.contrasting(rng, lid_c), dens),
                                 (0, y0 + lt, half_d + over - (0.008 if round_ else 0.0)), X, Z)
        pivot = np.array([0.0, y0 + lt, -half_d - over])
        spec.add("lid", "lid", lid, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.3, 1.9), min_upper=1.1))
    if kind == "pedal":
        z0 = half_d + 0.008
        pedal = [box((-0.06, 0.02, z0), (0.06, 0.035, z0 + 0.06), palette.contrasting(rng, color, palette.METAL), METAL)]
        spec.add("pedal", "pedal", pedal, "body",
                 JointSpec("revolute", (0, 0.035, z0), X, 0.0, rng.uniform(0.2, 0.35), min_upper=0.15))
    spec.params = {"round": round_, "height": h, "size": [2 * half_w, 2 * half_d], "lid": kind}
    return spec


def toilet(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Toilet")
    ceramic = palette.jitter(rng, palette.CERAMIC[palette.pick(rng, palette.CERAMIC)], 0.01)
    dens = palette.DENSITY["ceramic"]
    hb, rt = rng.uniform(0.36, 0.41), rng.uniform(0.17, 0.21)
    rb = rt * rng.uniform(0.6, 0.75)
    body = spec.part("body")
    body.solids.append(frustum((0, 0.5 * hb, 0), rb, rt, hb, Y, ceramic, dens))
    seat_c = ceramic if rng.uniform() < 0.6 else palette.jitter(rng, choice(rng, [palette.WOOD["oak"],
                                                                                  palette.PLASTIC["black"]]))
    seat_t, ring = 0.02, 0.055
    for k in range(8):  # the seat ring: eight boxes around the rim
        a = k * np.pi / 4
        rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
        center = rot @ np.array([rt - 0.5 * ring, hb + 0.5 * seat_t, 0])
        body.solids.append(oriented_box(center, (ring, seat_t, 2 * rt * np.tan(np.pi / 8)), rot, seat_c, PLASTIC))
    lt, over = rng.uniform(0.018, 0.028), 0.01
    ly0 = hb + seat_t + 0.003
    lid_r = rt + over
    tank_front = -lid_r - 0.045
    tw, td, th = rng.uniform(0.36, 0.46), rng.uniform(0.14, 0.2), rng.uniform(0.3, 0.4)
    body.solids += [box((-0.5 * tw, hb - 0.08, tank_front - td), (0.5 * tw, hb + th, tank_front), ceramic, dens),
                    box((-0.12, 0, tank_front - 0.02), (0.12, hb - 0.079, -0.5 * rt), ceramic, dens)]
    lid = [cylinder((0, ly0 + 0.5 * lt, 0), lid_r, lt, Y, seat_c, PLASTIC)]
    pivot = np.array([0.0, ly0 + lt, -lid_r])
    spec.add("lid", "lid", lid, "body", JointSpec("revolute", pivot, -X, 0.0, rng.uniform(1.35, 1.55), min_upper=1.2))
    lx, ly = -0.5 * tw + 0.05, hb + th - 0.05
    metal = palette.jitter(rng, palette.METAL["chrome"], 0.02)
    lever = [cylinder((lx, ly, tank_front + 0.007), 0.014, 0.01, Z, metal, METAL),
             box((lx, ly - 0.007, tank_front + 0.01), (lx + 0.08, ly + 0.007, tank_front + 0.02), metal, METAL)]
    spec.add("lever", "lever", lever, "body",
             JointSpec("revolute", (lx, ly, tank_front + 0.002), -Z, 0.0, rng.uniform(0.4, 0.7), min_upper=0.3))
    spec.params = {"bowl": [rb, rt, hb], "tank": [tw, th, td]}
    return spec


def faucet(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Faucet", semantic="static")
    metal = palette.jitter(rng, palette.METAL[choice(rng, ["chrome", "steel", "black", "brass", "bronze"])], 0.02)
    body = spec.part("body")
    rc, hc = rng.uniform(0.018, 0.028), rng.uniform(0.12, 0.26)
    kind = choice(rng, ["two_handle", "single_lever"])
    arm_r, arm_l = rng.uniform(0.011, 0.016), rng.uniform(0.12, 0.2)
    nozzle = rng.uniform(0.025, 0.045)
    reach = rng.uniform(0.03, 0.05)
    xh = rc + reach + rng.uniform(0.02, 0.035)
    plate_w = xh + reach + 0.02 if kind == "two_handle" else rc + 0.03
    plate_c = palette.contrasting(rng, metal, {"black": palette.PLASTIC["black"], "white": palette.CERAMIC["white"],
                                                "grey": palette.PLASTIC["grey"]}, 0.15)
    body.solids.append(box((-plate_w, 0, -0.04), (plate_w, 0.012, 0.04), plate_c, METAL))
    handle_top = 0.014 + 0.045 + 0.012
    swivel = kind == "two_handle" and hc - 0.02 - arm_r - nozzle > handle_top + 0.02
    arm_y = hc - 0.02 if kind == "two_handle" else hc - 0.045
    spout = [cylinder((0, arm_y, 0.5 * arm_l), arm_r, arm_l, Z, metal, METAL),
             cylinder((0, arm_y - 0.5 * nozzle, arm_l - arm_r), arm_r * 0.9, nozzle, Y, metal, METAL)]
    if swivel:
        split = arm_y - arm_r - 0.012
        body.solids.append(cylinder((0, 0.5 * (0.011 + split), 0), rc, split - 0.011, Y, metal, METAL))
        spout.append(cylinder((0, 0.5 * (split + 0.002 + hc), 0), rc, hc - split - 0.002, Y, metal, METAL))
        spec.add("spout", "spout", spout, "body", JointSpec("revolute", (0, split, 0), Y, 0.0, rng.uniform(1.0, 1.6),
                                                            min_upper=0.8))
    else:
        body.solids.append(cylinder((0, 0.5 * (0.011 + hc), 0), rc, hc - 0.011, Y, metal, METAL))
        body.solids += spout
    if kind == "two_handle":
        for sx in (-1, 1):
            x = sx * xh
            parts = [cylinder((x, 0.014 + 0.0225, 0), 0.012, 0.045, Y, metal, METAL),
                     box((x - reach, 0.014 + 0.045 - 0.001, -0.007), (x + reach, handle_top, 0.007), metal, METAL),
                     box((x - 0.007, 0.014 + 0.045 - 0.001, -reach), (x + 0.007, handle_top, reach), metal, METAL),
                     cylinder((x, handle_top + 0.002, 0), 0.006, 0.005, Y,
                              palette.rgba((0.8, 0.1, 0.1) if sx < 0 else (0.1, 0.25, 0.8)), PLASTIC)]
            spec.add("handle", "switch", parts, "body", JointSpec("continuous", (x, 0.014, 0), Y))
    else:
        lever = [cylinder((0, hc + 0.002 + 0.009, 0), rc, 0.018, Y, metal, METAL),
                 box((-0.007, hc + 0.012, -0.06 - rc), (0.007, hc + 0.02, 0.0), metal, METAL)]
        spec.add("lever", "switch", lever, "body", JointSpec("continuous", (0, hc + 0.002, 0), Y))
    spec.params = {"kind": kind, "column": [rc, hc], "spout": [arm_l, nozzle], "swivel": swivel}
    return spec


def bucket(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("Bucket", semantic="free")
    h, rt = rng.uniform(0.2, 0.32), rng.uniform(0.12, 0.17)
    rb = rt * rng.uniform(0.7, 0.9)
    color = palette.jitter(rng, choice(rng, list(palette.PLASTIC.values()) + [palette.METAL["steel"]]))
    body = spec.part("body")
    rim = 0.012
    body.solids += [frustum((0, 0.5 * (h - rim), 0), rb, rt, h - rim, Y, color, PLASTIC),
                    cylinder((0, h - 0.5 * rim - 0.0005, 0), rt + 0.006, rim + 0.001, Y, color, PLASTIC)]
    py, rh = h + 0.012, rt + 0.006 + 0.012
    wire = palette.jitter(rng, palette.METAL["steel"], 0.02)
    arc, n = [], 10
    for k in range(n):
        a0, a1 = np.pi * k / n, np.pi * (k + 1) / n
        m = 0.5 * (a0 + a1)
        tangent, radial = np.array([-np.sin(m), np.cos(m), 0]), np.array([np.cos(m), np.sin(m), 0])
        length = 2 * rh * np.sin(0.5 * (a1 - a0)) + 0.006
        arc.append(oriented_box(np.array([0, py, 0]) + rh * np.cos(0.5 * (a1 - a0)) * radial, (0.005, length, 0.006),
                                np.column_stack([radial, tangent, Z]), wire, METAL))
    grip_c = palette.contrasting(rng, wire, palette.PLASTIC, 0.2)
    arc.append(cylinder((0, py + rh, 0), 0.011, min(0.1, rh), X, grip_c, PLASTIC))
    spec.add("handle", "handle", arc, "body", JointSpec("revolute", (0, py, 0), X, 0.0, rng.uniform(1.2, 1.5),
                                                        min_upper=1.0))
    spec.params = {"height": h, "radius": [rb, rt]}
    return spec


def kitchen_pot(rng: np.random.Generator) -> ObjectSpec:
    spec = new_object("KitchenPot", semantic="free")
    r, hp = rng.uniform(0.08, 0.15), rng.uniform(0.08, 0.18)
    color = palette.jitter(rng, choice(rng, [palette.METAL["steel"], palette.METAL["black"], palette.PLASTIC["red"],
                                             palette.METAL["chrome"], palette.PLASTIC["teal"]]))
    dark = palette.contrasting(rng, color, palette.PLASTIC, 0.2)
    body = spec.part("body")
    body.solids.append(cylinder((0, 0.5 * hp, 0), r, hp, Y, color, METAL * 0.3))
    for sx in (-1, 1):
        body.solids += place_on_face(handle_solids("loop", min(0.08, r), rng, dark, PLASTIC),
                                     (sx * (r - 0.02), 0.75 * hp, 0), Z, sx * X)
    lid_t = rng.uniform(0.006, 0.01)
    y0 = hp + 0.002
    lid = [cylinder((0, y0 + 0.5 * lid_t, 0), r + 0.004, lid_t, Y, palette.jitter(rng, color[:3], 0.02), METAL * 0.3)]
    lid += place_on_face(handle_solids("knob", 0.05, rng, dark, PLASTIC), (0, y0 + lid_t, 0), X, Y)
    spec.add("lid", "lid", lid, "body", JointSpec("prismatic", (0, y0 + lid_t, 0), Y, 0.0, rng.uniform(0.1, 0.2),
                                                  min_upper=0.08))
    spec.params = {"radius": r, "height": hp}
    return spec


BUILDERS = {"Laptop": laptop, "Suitcase": suitcase, "TrashCan": trash_can, "Toilet": toilet, "Faucet": faucet,
            "Bucket": bucket, "KitchenPot": kitchen_pot}
