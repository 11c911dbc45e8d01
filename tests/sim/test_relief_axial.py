"""Hinge relief of contacts whose normal lies along the hinge axis (spark_bench.sim.relief)."""

from __future__ import annotations

import os

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from helpers_boxes import box_visual  # noqa: E402

from spark_bench.asset.model import ArticulatedAsset, Joint, Link  # noqa: E402
from spark_bench.sim import phantom, relief, run_checks  # noqa: E402
from spark_bench.sim.options import ConvertOptions  # noqa: E402

#: Rest overlaps up to 0.2 % of the object's size left in, as conv-8 left them: the rule under test is the one
#: that handles them (by default, since conv-9, such an overlap of a pair that collides is cut apart at rest:
#: spark_bench.sim.rest_trim).
SHALLOW_KEPT = ConvertOptions(trim_overlap=0.002)


def _lever_on_base(sink: float) -> ArticulatedAsset:
    """A 40 x 40 x 20 cm base and a 30 x 4 x 3 cm lever on top of it, turning 90 degrees about the
    vertical axis through the base's centre (a faucet lever); the lever's bottom is ``sink`` metres
    below the base's top (PartNet-Mobility meshes meet like this, a fraction of a millimetre off)."""
    return _turning_on_body("lever_on_base", "Faucet", [box_visual((0.40, 0.40, 0.20), (0.0, 0.0, 0.10))],
                            Link("lever", visuals=[box_visual((0.30, 0.04, 0.03), (0.10, 0.0, 0.215 - sink))],
                                 label="lever"))


def _turning_on_body(name: str, category: str, body_visuals: list, part: Link) -> ArticulatedAsset:
    """A fixed body of ``body_visuals`` and ``part`` on it, turning 90 degrees about the vertical axis
    through the origin (joint ``joint_<part name>``)."""
    joint = f"joint_{part.name}"
    joints = {"root": Joint("root", "fixed", "base", "body"),
              joint: Joint(joint, "revolute", "body", part.name, axis=np.array([0.0, 0.0, 1.0]),
                           lower=0.0, upper=np.pi / 2)}
    links = {link.name: link for link in (Link("base"), Link("body", visuals=body_visuals, label="base"), part)}
    return ArticulatedAsset(name, links, joints, category=category)


def test_lever_sunk_into_its_base_turns_after_relief(isolated_home, monkeypatch):
    # 0.8 mm sunk: the hulls (each eroded by half the 0.57 mm clearance) still overlap 0.2-0.3 mm at
    # rest, less than the overlap that excludes a parent-child pair (1.1 mm), so the pair collides
    asset = _lever_on_base(0.0008)
    # the lever's own path is free of the base's surface, so conv-9 would exclude the pair: keep it colliding
    monkeypatch.setattr(phantom, "CROSSING_BLOCK", 0.0)
    report = run_checks(asset, SHALLOW_KEPT)
    assert report.checks["mjcf_compiles"].details["excluded"] == []
    relieved = report.checks["mjcf_compiles"].details["relief"]
    assert "joint_lever" in relieved and relieved["joint_lever"]["cuts"] >= 1
    sweep = report.checks["joint_sweep"].details["joints"]["joint_lever"]
    assert sweep["reached"] >= 0.9 and sweep["returned"] >= 0.9, sweep
    assert report.passed, report.failures()
    # without the rule the lever's contact, pressing along the axis its hinge holds, jams it by friction
    monkeypatch.setattr(relief, "AXIAL_COS", 2.0)  # no contact qualifies
    monkeypatch.setenv("SPARK_BENCH_HOME", str(isolated_home / "without"))
    jammed = run_checks(asset, SHALLOW_KEPT).checks["joint_sweep"]
    assert not jammed.passed
    assert jammed.details["joints"]["joint_lever"]["reached"] < 0.5


def test_lever_sunk_into_its_base_on_a_free_path_is_excluded_whole_by_default(isolated_home):
    report = run_checks(_lever_on_base(0.0008))
    assert report.passed, report.failures()
    details = report.checks["mjcf_compiles"].details
    # the lever's own path is free of the base's surface: the pair is excluded, judged before any cut (conv-10),
    # so nothing is cut (under conv-9 the lever's hulls were cut apart from the base first)
    assert [(b["parent"], b["child"]) for b in details["phantom_blocks"]] == [("body", "lever")]
    assert details["rest_trim"] == {}


def test_lever_sunk_into_its_base_is_cut_apart_at_rest_where_it_collides(isolated_home, monkeypatch):
    monkeypatch.setattr(phantom, "CROSSING_BLOCK", 0.0)  # every path blocked: the pair collides
    report = run_checks(_lever_on_base(0.0008))
    assert report.passed, report.failures()
    details = report.checks["mjcf_compiles"].details
    assert details["excluded"] == []
    assert details["rest_trim"]  # the overlap is gone before the relief looks


def test_lever_clear_of_its_base_needs_no_relief(isolated_home):
    report = run_checks(_lever_on_base(-0.002))  # 2 mm above the base
    assert report.passed, report.failures()
    assert report.checks["mjcf_compiles"].details["relief"] == {}


def _door_over_sill(sill_top: float) -> ArticulatedAsset:
    """A 40 x 2 x 50 cm door 3 cm above a floor plate, hinged on a vertical axis at its edge, and a sill
    ``sill_top`` high in its path (the door's bottom meets it from 36 % of its 90 degree range)."""
    return _turning_on_body("door_over_sill", "StorageFurniture",
                            [box_visual((0.6, 0.6, 0.02), (0.2, 0.2, -0.01)),
                             box_visual((0.2, 0.1, sill_top), (0.2, 0.25, sill_top / 2))],
                            Link("door", visuals=[box_visual((0.40, 0.02, 0.50), (0.2, 0.0, 0.28))], label="door"))


def test_door_swinging_into_a_low_sill_stays_blocked(isolated_home):
    # the door overlaps the sill 1 cm along the axis and far more across it, so the contact normal lies
    # along the axis; the contact appears during the turn (not held since rest): a blocking, not relieved
    report = run_checks(_door_over_sill(0.04))
    assert report.checks["mjcf_compiles"].details["relief"] == {}
    sweep = report.checks["joint_sweep"]
    assert not sweep.passed and sweep.details["joints"]["joint_door"]["reached"] < 0.5
