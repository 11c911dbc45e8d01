"""A small procedural cabinet (box carcass, one drawer with a bar handle, one hinged door with a bar
handle), built in memory from box primitives.

It is the environments' fallback object when the ``synth`` generator is not installed, and the fixture
of the unit tests: it needs no file, no mesh decomposition, and compiles in milliseconds. Its frame
follows the benchmark conventions: Z up, the front facing -X, centered at the origin.
"""

from __future__ import annotations

import numpy as np
import trimesh

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual

WOOD = (0.62, 0.45, 0.3, 1.0)
METAL = (0.75, 0.75, 0.78, 1.0)


def box_part(center, size, rgba) -> tuple[Visual, Collision]:
    """A box as a visual mesh and a matching box collision, both in the link frame."""
    origin = np.eye(4)
    origin[:3, 3] = center
    mesh = trimesh.creation.box(extents=size, transform=origin)
    return Visual(mesh=mesh, rgba=rgba), Collision(kind="box", origin=origin, size=np.asarray(size, float))


def _link(name: str, boxes: list[tuple], label: str, semantic: str) -> Link:
    parts = [box_part(c, s, rgba) for c, s, rgba in boxes]
    return Link(name=name, visuals=[p[0] for p in parts], collisions=[p[1] for p in parts], label=label,
                semantic_joint=semantic)


def _translation(xyz) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = xyz
    return out


def procedural_cabinet(seed: int = 0) -> ArticulatedAsset:
    """A cabinet with a top drawer (``joint_0``, prismatic) and a bottom door (``joint_1``, revolute).

    The seed varies the outer size and the handle positions a little, deterministically.

    :param seed: random seed of the dimensions
    """
    rng = np.random.default_rng(seed)
    depth, width, height = rng.uniform([0.42, 0.55, 0.65], [0.5, 0.7, 0.8])
    t = 0.02  # panel thickness
    x0, x1 = -depth / 2, depth / 2
    y0, y1 = -width / 2, width / 2
    z0, z1 = -height / 2, height / 2
    z_split = z1 - 0.26  # drawer compartment above, door compartment below
    base = _link("base", [
        ((0, y0 + t / 2, 0), (depth, t, height), WOOD),            # left side
        ((0, y1 - t / 2, 0), (depth, t, height), WOOD),            # right side
        ((0, 0, z1 - t / 2), (depth, width, t), WOOD),             # top
        ((0, 0, z0 + t / 2), (depth, width, t), WOOD),             # bottom
        ((x1 - t / 2, 0, 0), (t, width, height), WOOD),            # back
        ((0, 0, z_split), (depth, width - 2 * t, t), WOOD),        # shelf between drawer and door
    ], "furniture_body", "heavy")

    # drawer: link frame at its front-face center, sliding along -X
    gap = 0.004
    dw = width - 2 * t - 2 * gap
    dh = z1 - t - z_split - t / 2 - 2 * gap
    dd = depth - 2 * t
    handle_z = rng.uniform(-0.02, 0.03)
    drawer = _link("link_0", [
        ((t / 2, 0, 0), (t, dw + 2 * t, dh + 0.01), WOOD),                     # front panel
        ((dd / 2, -dw / 2 + t / 2, -0.01), (dd - t, t, dh - 0.03), WOOD),       # sides
        ((dd / 2, dw / 2 - t / 2, -0.01), (dd - t, t, dh - 0.03), WOOD),
        ((dd - t / 2, 0, -0.01), (t, dw - 2 * t, dh - 0.03), WOOD),             # back
        ((dd / 2, 0, -dh / 2 + t / 2), (dd - t, dw - 2 * t, t), WOOD),          # bottom
        ((-0.035, 0, handle_z), (0.015, 0.22, 0.015), METAL),                   # bar
        ((-0.018, -0.09, handle_z), (0.022, 0.012, 0.012), METAL),              # standoffs
        ((-0.018, 0.09, handle_z), (0.022, 0.012, 0.012), METAL),
    ], "drawer", "slider")
    drawer_origin = _translation((x0 - t, 0, (z1 - t + z_split + t / 2) / 2))
    travel = 0.75 * dd

    # door: link frame on the hinge line (left front edge), the panel extending towards +Y
    door_h = z_split - t / 2 - z0 - t - 2 * gap
    door_w = width - 2 * gap
    handle_y = door_w - rng.uniform(0.06, 0.09)
    door = _link("link_1", [
        ((-t / 2, door_w / 2, 0), (t, door_w, door_h), WOOD),                   # panel
        ((-t - 0.035, handle_y, 0), (0.015, 0.015, 0.2), METAL),                # vertical bar
        ((-t - 0.018, handle_y, -0.08), (0.022, 0.012, 0.012), METAL),         # standoffs
        ((-t - 0.018, handle_y, 0.08), (0.022, 0.012, 0.012), METAL),
    ], "rotation_door", "hinge")
    door_origin = _translation((x0 - gap, y0 + gap, (z_split - t / 2 + z0 + t) / 2))

    joints = {
        "joint_0": Joint("joint_0", "prismatic", "base", "link_0", origin=drawer_origin,
                         axis=np.array([-1.0, 0.0, 0.0]), lower=0.0, upper=float(travel), damping=1.0,
                         friction=0.1),
        "joint_1": Joint("joint_1", "revolute", "base", "link_1", origin=door_origin,
                         axis=np.array([0.0, 0.0, 1.0]), lower=0.0, upper=float(np.pi / 2), damping=0.5,
                         friction=0.05),
    }
    links = {link.name: link for link in (base, drawer, door)}
    return ArticulatedAsset(name=f"procedural_cabinet_{seed}", links=links, joints=joints,
                            category="StorageFurniture", source=f"procedural_cabinet(seed={seed})")
