"""Phantom blockings (spark_bench.sim.phantom): a part stopped by its parent's hulls, not its surface."""

from __future__ import annotations

import os

import numpy as np
import pytest
import trimesh

os.environ.setdefault("MUJOCO_GL", "egl")

from helpers_assets import box_visual  # noqa: E402

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual  # noqa: E402
from spark_bench.asset.transforms import make_transform  # noqa: E402
from spark_bench.sim import run_checks  # noqa: E402
from spark_bench.sim.phantom import joint_steps, single_joint, surface_points  # noqa: E402


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
