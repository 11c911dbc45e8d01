"""Phantom blockings (spark_bench.sim.phantom): a part stopped by its parent's hulls, not its surface."""

from __future__ import annotations

import os

import numpy as np
import pytest
import trimesh

os.environ.setdefault("MUJOCO_GL", "egl")

from helpers_boxes import box_visual  # noqa: E402

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual  # noqa: E402
from spark_bench.asset.transforms import make_transform  # noqa: E402
from spark_bench.sim import run_checks  # noqa: E402
from spark_bench.sim.phantom import (  # noqa: E402
    joint_steps,
    phantom_candidates,
    single_joint,
    surface_depth,
    surface_points,
)


def _panel_with_button(hole: bool) -> ArticulatedAsset:
    """A 30 x 30 x 4 cm panel whose collision is one solid box (as a convex hull over a hole would be),
    and a 3 x 3 x 2 cm button on top that slides 3 cm down, into the panel's 4 x 4 cm hole when
    ``hole`` (the panel's surface is then four bars around it), into solid wood otherwise."""
    if hole:
        bars = [((0.30, 0.13, 0.04), (0.0, 0.085, 0.02)), ((0.30, 0.13, 0.04), (0.0, -0.085, 0.02)),
                ((0.13, 0.04, 0.04), (0.085, 0.0, 0.02)), ((0.13, 0.04, 0.04), (-0.085, 0.0, 0.02))]
        mesh = trimesh.util.concatenate([trimesh.creation.box(extents=e, transform=make_transform(translation=c))
                                         for e, c in bars])
        visuals = [Visual(mesh=mesh, rgba=(0.6, 0.5, 0.4, 1.0))]
    else:
        visuals = [box_visual((0.30, 0.30, 0.04), (0.0, 0.0, 0.02))]
    panel = Link("panel", visuals=visuals, label="panel",
                 collisions=[Collision("box", make_transform(translation=(0, 0, 0.02)), np.array([0.30, 0.30, 0.04]))])
    button = Link("button", visuals=[box_visual((0.03, 0.03, 0.02), (0.0, 0.0, 0.05))], label="button")
    joints = {
        "root": Joint("root", "fixed", "base", "panel"),
        "joint_button": Joint("joint_button", "prismatic", "panel", "button", axis=np.array([0.0, 0.0, -1.0]),
                              lower=0.0, upper=0.03),
    }
    links = {link.name: link for link in (Link("base"), panel, button)}
    return ArticulatedAsset("panel_button", links, joints, category="Safe")


def test_single_joint_and_steps():
    asset = _panel_with_button(True)
    joint = single_joint(asset, "panel", "button")
    assert joint is not None and joint.name == "joint_button"
    assert single_joint(asset, "base", "panel") is None  # only a fixed joint between them
    steps = joint_steps(joint)
    assert steps[0] > joint.lower and steps[-1] == pytest.approx(joint.upper) and np.all(np.diff(steps) > 0)


def test_surface_points_only_near_the_box_and_spaced():
    mesh = trimesh.creation.box(extents=(1.0, 1.0, 0.1))
    lo, hi = np.array([0.2, 0.2, -1.0]), np.array([0.4, 0.4, 1.0])
    points = surface_points(np.asarray(mesh.vertices), np.asarray(mesh.faces), lo, hi, spacing=0.05)
    # the box's triangles are large, so points come from the triangles that reach the region: they lie
    # on the box's surface, and there are about area / spacing^2 of them
    assert 100 < len(points) <= 60_000
    on_surface = np.max(np.abs(points) / np.array([0.5, 0.5, 0.05]), axis=1)
    np.testing.assert_allclose(on_surface, 1.0, atol=1e-9)
    assert np.any(np.all((points >= lo) & (points <= hi), axis=1))
    none = surface_points(np.asarray(mesh.vertices), np.asarray(mesh.faces), lo + 5, hi + 5, spacing=0.05)
    assert len(none) == 0


def test_button_into_a_hole_is_not_blocked_by_the_panels_hull(isolated_home):
    report = run_checks(_panel_with_button(hole=True))
    assert report.passed, report.failures()
    blocks = report.checks["mjcf_compiles"].details["phantom_blocks"]
    assert [(b["parent"], b["child"], b["joint"]) for b in blocks] == [("panel", "button", "joint_button")]
    assert blocks[0]["depth"] > 0.001 and blocks[0]["surface_depth"] <= 0.001  # hulls 1+ mm deep; surface not
    assert report.checks["joint_sweep"].details["joints"]["joint_button"]["reached"] >= 0.9


def test_button_into_solid_wood_stays_blocked(isolated_home):
    report = run_checks(_panel_with_button(hole=False))
    assert not report.checks["joint_sweep"].passed
    assert report.checks["mjcf_compiles"].details["phantom_blocks"] == []
    joint = report.checks["joint_sweep"].details["joints"]["joint_button"]
    assert joint["reached"] < 0.5
    assert any(b["blocked_by_body"] == "panel" for b in joint["blocked_by"])
    # the reason says what to fix: the panel's own surface is in the button's way from the start
    assert joint["explanation"].startswith("the surface of panel enters button from")
    assert "the object itself blocks joint_button" in report.checks["joint_sweep"].details["reason"]


def _u_part() -> trimesh.Trimesh:
    """A U of three 10 cm bars (x in [-0.05, 0.05], the slot between the arms x in [-0.03, 0.03], y > 0)."""
    bars = [((0.10, 0.02, 0.02), (0.0, -0.01, 0.0)), ((0.02, 0.08, 0.02), (-0.04, 0.04, 0.0)),
            ((0.02, 0.08, 0.02), (0.04, 0.04, 0.0))]
    return trimesh.util.concatenate([trimesh.creation.box(extents=e, transform=make_transform(translation=c))
                                     for e, c in bars])


def test_surface_depth_is_bounded_by_the_distance_to_the_part():
    from scipy.spatial import ConvexHull

    part = _u_part()  # its convex hull fills the slot between the arms and spans x, y in [-0.05, 0.05]
    hulls = [(ConvexHull(part.vertices).equations, part.vertices.min(0), part.vertices.max(0))]
    in_arm = np.array([[0.04, 0.05, 0.0]])  # the middle of an arm: 1 cm from its surface and the hull's
    assert surface_depth(in_arm, hulls, part) == pytest.approx(0.01, abs=1e-6)
    # just outside the arm, inside the hull only because the hull is wider than the part (a bulge)
    bulge = [(ConvexHull(part.vertices * [1.2, 1.0, 1.0]).equations, part.vertices.min(0) * [1.2, 1, 1],
              part.vertices.max(0) * [1.2, 1, 1])]
    beside = np.array([[0.0505, 0.05, 0.0]])
    assert surface_depth(beside, bulge) > 0.005  # the hull alone: 5+ mm deep
    assert surface_depth(beside, bulge, part) == pytest.approx(0.0005, abs=1e-6)  # its distance to the arm
    # in the slot, 3 cm from either arm: the hull depth (1 cm, half the thickness) bounds it
    assert surface_depth(np.array([[0.0, 0.05, 0.0]]), hulls, part) == pytest.approx(0.01, abs=1e-6)
    # below ``floor`` the answer is only bounded by it
    assert surface_depth(np.concatenate([beside, in_arm]), bulge, part, floor=0.015) <= 0.015


def test_a_closed_part_counts_only_the_points_inside_it():
    """conv-11: where the part's mesh is closed, a point in the slot its hull fills is not inside it, however far
    from its surface; a point inside an arm counts as deep as it is from the surface."""
    from scipy.spatial import ConvexHull

    from spark_bench.sim.solid import closed_pieces, closed_solid

    part = _u_part()
    hulls = [(ConvexHull(part.vertices).equations, part.vertices.min(0), part.vertices.max(0))]
    bars = [(bar.vertices, bar.faces) for bar in part.split(only_watertight=False)]
    assert len(closed_pieces(bars)) == 3  # three bars, three closed pieces
    solid = closed_solid(bars)
    in_slot = np.array([[0.0, 0.05, 0.0]])  # 1 cm deep in the hull, 3 cm from either arm, inside no bar
    assert surface_depth(in_slot, hulls, part) == pytest.approx(0.01, abs=1e-6)  # the bound of a soup
    assert surface_depth(in_slot, hulls, part, solid=solid) == 0.0
    assert surface_depth(in_slot, hulls, part, floor=0.002, solid=solid) <= 0.002
    in_arm = np.array([[0.04, 0.05, 0.0], [0.0, 0.05, 0.0]])
    assert surface_depth(in_arm, hulls, part, solid=solid) == pytest.approx(0.01, abs=1e-6)


def test_closed_pieces_of_a_soup_and_of_an_open_mesh():
    from spark_bench.sim.solid import closed_pieces, closed_solid, inside_pieces

    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    # as an OBJ writes it: every face with its own three vertices, one face twice (a two-sided panel)
    vertices = box.vertices[box.faces].reshape(-1, 3)
    faces = np.arange(len(vertices)).reshape(-1, 3)
    pieces = closed_pieces([(vertices, np.concatenate([faces, faces[:1]]))])
    assert pieces is not None and len(pieces) == 1
    # two boxes overlapping: a point in both is inside (one parity over both would say outside)
    other = trimesh.creation.box(extents=(0.1, 0.1, 0.1), transform=make_transform(translation=(0.05, 0, 0)))
    both = trimesh.util.concatenate([box, other])
    assert len(closed_pieces([(both.vertices, both.faces)])) == 2
    points = np.array([[0.03, 0.0, 0.0], [0.09, 0.0, 0.0], [0.2, 0.0, 0.0], [-0.049, 0.049, 0.0]])
    assert inside_pieces(points, closed_solid([(both.vertices, both.faces)])).tolist() == [True, True, False, True]
    # faces wound either way (a triangle soup's habit): the rays meet them from both sides all the same
    flipped = box.faces.copy()
    flipped[::2] = flipped[::2, ::-1]
    solid = closed_solid([(box.vertices, flipped)])
    assert inside_pieces(np.array([[0.01, 0.02, -0.03], [0.06, 0.0, 0.0]]), solid).tolist() == [True, False]
    # a box with a face missing is open: nothing can be told inside it
    assert closed_pieces([(box.vertices, box.faces[:-1])]) is None
    # a closed piece beside an open one: the part as a whole cannot be told
    open_panel = trimesh.creation.box(extents=(0.1, 0.1, 0.1), transform=make_transform(translation=(0.5, 0, 0)))
    assert closed_pieces([(box.vertices, box.faces), (open_panel.vertices, open_panel.faces[:-2])]) is None
    # two closed bars touching along an edge, in one mesh: welded, that edge has four faces and looks open;
    # as two meshes (two OBJ pieces) each is closed
    bar = trimesh.creation.box(extents=(0.1, 0.1, 0.1), transform=make_transform(translation=(0.1, 0.1, 0)))
    touching = trimesh.util.concatenate([box, bar])
    assert closed_pieces([(touching.vertices, touching.faces)]) is None
    assert len(closed_pieces([(box.vertices, box.faces), (bar.vertices, bar.faces)])) == 2


def test_candidates_include_a_handle_carried_by_a_door():
    body = Link("body", visuals=[box_visual((0.4, 0.4, 0.4), (0.0, 0.0, 0.2))], label="body")
    door = Link("door", visuals=[box_visual((0.02, 0.4, 0.4), (0.21, 0.0, 0.2))], label="door")
    handle = Link("handle", visuals=[box_visual((0.02, 0.02, 0.1), (0.24, 0.15, 0.2))], label="handle")
    joints = {
        "root": Joint("root", "fixed", "base", "body"),
        "hinge": Joint("hinge", "revolute", "body", "door", axis=np.array([0.0, 0.0, 1.0]), lower=0.0, upper=1.5,
                       origin=make_transform(translation=(0.22, -0.2, 0.0))),
        "turn": Joint("turn", "revolute", "door", "handle", axis=np.array([1.0, 0.0, 0.0]), lower=0.0, upper=1.0),
    }
    asset = ArticulatedAsset("cabinet", {k.name: k for k in (Link("base"), body, door, handle)}, joints)

    class Prepared:  # the two members phantom_candidates reads
        shapes = {"body": [1], "door": [1], "handle": [1]}

    Prepared.asset = asset
    found = {(p, c, j.name) for p, c, j in phantom_candidates(Prepared)}
    assert found == {("body", "door", "hinge"), ("door", "handle", "turn"), ("body", "handle", "hinge")}


def _button_meeting_the_panel(at: float) -> ArticulatedAsset:
    """The solid panel of :func:`_panel_with_button` and a 10 cm tall plunger that slides 5 cm down onto it, its
    bottom meeting the panel's top once it has travelled ``at`` of its range (it then goes on into the wood): a
    small share of its surface crosses the panel's."""
    asset = _panel_with_button(hole=False)
    travel = 0.05
    bottom = 0.04 + at * travel  # the panel's top is at 4 cm
    asset.links["button"].visuals[:] = [box_visual((0.03, 0.03, 0.10), (0.0, 0.0, bottom + 0.05))]
    asset.joints["joint_button"].upper = travel
    return asset


@pytest.mark.parametrize(("at", "free"), [(0.93, True), (0.7, False)])
def test_what_a_part_meets_beyond_the_sweeps_reach_is_its_stop(isolated_home, at, free):
    from spark_bench.sim.free_path import DEPTH_REACH
    from spark_bench.sim.mjcf import prepare

    assert DEPTH_REACH == pytest.approx(0.9)
    # the plunger ends 3.5 mm into the panel (more than its allowance, 0.5 % of the object's size; about a tenth of
    # its points cross the panel's top): met after 93 % of its range it lies on its stop, and the pair is excluded;
    # met at 70 % it is blocked and collides
    prepared = prepare(_button_meeting_the_panel(at))
    blocks = [(b.parent, b.child) for b in prepared.phantom]
    assert (("panel", "button") in blocks) == free
    assert (("panel", "button") in prepared.excluded) == free


def _bail_over_fin(open_bar: bool = False) -> ArticulatedAsset:
    """A bucket-handle-like bail (a U of three closed bars, its collision one box that fills the slot between the arms,
    as a convex hull of the U would), hinged at its arms' tips to lift 1.5 rad, and on the body a 4 mm fin standing in
    the plane between the arms: lifted, the bail's box sweeps through the fin, its bars pass either side of it.
    ``open_bar``: one bar with a face missing, so the bail is no longer a closed part."""
    bars = [box_visual((0.02, 0.1, 0.02), (x, -0.05, 0.0)) for x in (-0.04, 0.04)]
    bars.append(box_visual((0.1, 0.02, 0.02), (0.0, -0.11, 0.0)))
    if open_bar:
        mesh = bars[2].mesh
        bars[2] = Visual(mesh=trimesh.Trimesh(mesh.vertices, mesh.faces[:-1], process=False), rgba=bars[2].rgba)
    bail = Link("bail", visuals=bars, label="handle",
                collisions=[Collision("box", make_transform(translation=(0.0, -0.06, 0.0)), np.array([0.1, 0.12, 0.02]))])
    fin = box_visual((0.004, 0.03, 0.03), (0.0, -0.0329, 0.0307))
    body = Link("body", visuals=[fin], label="base",
                collisions=[Collision("box", make_transform(translation=(0.0, -0.0329, 0.0307)),
                                      np.array([0.004, 0.03, 0.03]))])
    joints = {"root": Joint("root", "fixed", "base", "body"),
              "bail_joint": Joint("bail_joint", "revolute", "body", "bail", axis=np.array([-1.0, 0.0, 0.0]),
                                  lower=0.0, upper=1.5)}
    links = {link.name: link for link in (Link("base"), body, bail)}
    return ArticulatedAsset("bail_over_fin", links, joints, category="Bucket")


def test_a_closed_part_is_not_held_by_what_lies_in_its_hull_only(isolated_home):
    """conv-11: the fin lies inside the bail's box (10 mm deep) but inside none of its closed bars: the bail's path is
    free, the pair excluded, the bail lifts; the same bail with a bar left open cannot be told from a soup, the fin
    counts as deep as it is far from the bars (bounded by the box's half thickness) and the bail stops on it."""
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.options import ConvertOptions

    options = ConvertOptions(use_cache=False)
    closed = prepare(_bail_over_fin(), options)
    assert ("body", "bail") in closed.excluded
    assert closed.solid("bail") is not None
    report = run_checks(_bail_over_fin(), options=options)
    assert report.passed, report.failures()
    opened = prepare(_bail_over_fin(open_bar=True), options)
    assert opened.solid("bail") is None
    assert ("body", "bail") not in opened.excluded
    stuck = run_checks(_bail_over_fin(open_bar=True), options=options).checks["joint_sweep"]
    assert not stuck.passed and stuck.details["joints"]["bail_joint"]["reached"] < 0.5
