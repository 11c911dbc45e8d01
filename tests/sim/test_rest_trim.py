"""Which parts collide (conv-9, conv-10): a part and its parent are excluded from collision only where the part's own
path is free of the parent's surface (spark_bench.sim.phantom); the hulls of every other pair that overlap at rest
are cut apart (spark_bench.sim.rest_trim). Until conv-8 a pair whose hulls overlapped at rest was excluded whatever
its path; under conv-9 the hulls were cut before the pairs were judged, excluded pairs included."""

import numpy as np
from helpers_assets import open_cabinet
from helpers_boxes import box_between, box_visual

from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.asset.transforms import make_transform
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim import run_checks
from spark_bench.sim.mjcf import assemble_spec, build_spec, prepare
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.rest_trim import rest_overlaps

NO_CACHE = ConvertOptions(use_cache=False)
#: How far the door's hull bulges into the body (m): a CoACD hull's bulge on a real door is 2-20 mm.
BULGE = 0.008


def bulging_cabinet(door_axis=(0.0, 0.0, 1.0)) -> ArticulatedAsset:
    """:func:`open_cabinet` whose door carries a convex hull that bulges :data:`BULGE` into the body's front edges at
    rest, as CoACD's hulls of a real door do (its surface stays in front of the body)."""
    asset = open_cabinet(door_axis)
    hull = box_between((-0.01, 0.0, 0.0), (0.01 + BULGE, 0.6, 0.8))
    asset.links["door"].collisions = [Collision("mesh", mesh=hull)]
    return asset


def door_body_overlaps(prepared) -> list:
    mujoco = mujoco_module()
    spec = assemble_spec(prepared, visuals=False)
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    model = spec.compile()
    return [o for o in rest_overlaps(model, mujoco.MjData(model), {("body", "door")}) if o.depth > 1e-6]


def test_a_door_whose_hull_bulges_into_its_body_on_a_free_path_is_excluded_with_its_hulls_whole(isolated_home):
    prepared = prepare(bulging_cabinet(), NO_CACHE)
    # the door opens outwards, away from the body: its hulls, not the object, made the two meet
    assert list(prepared.excluded) == [("body", "door")]
    [free] = prepared.phantom
    assert free.first == 0.0 and free.depth > 0.5 * BULGE and free.crossing < 0.02
    # judged before any cut (conv-10): an excluded pair is not cut apart, its hulls stay as made for every other
    # contact (a neighbouring part, a gripper)
    assert prepared.trim == []
    assert max(o.depth for o in door_body_overlaps(prepared)) > 0.5 * BULGE
    model = build_spec(bulging_cabinet(), prepared=prepared).compile()
    assert model.nexclude == 1


def test_a_bulging_door_turned_into_its_body_is_cut_apart_at_rest_rests_still_and_is_blocked(isolated_home):
    right = run_checks(bulging_cabinet(), options=NO_CACHE)
    assert right.passed, right.failures()
    wrong_asset = bulging_cabinet(door_axis=(0.0, 0.0, -1.0))
    prepared = prepare(wrong_asset, NO_CACHE)
    assert prepared.excluded == {} and door_body_overlaps(prepared) == []  # it collides, cut apart at rest
    # the bulge is a third of the door hull's thickness, more than the quarter of its volume a part may lose to
    # rest trimming: the boards' hulls are cut back instead, each by a slab as deep as the bulge
    assert prepared.trim and {c.link for c in prepared.trim} == {"body"}
    assert all(c.removed < 0.05 and c.depth > 0.5 * BULGE for c in prepared.trim)
    assert prepare(open_cabinet(), NO_CACHE).trim == []  # exact boxes that do not overlap are left as they are
    wrong = run_checks(wrong_asset, options=NO_CACHE)
    assert wrong.checks["mjcf_compiles"].details["excluded"] == []  # its path crosses the body
    assert wrong.checks["mjcf_compiles"].details["rest_trim"]["body"]["cuts"] >= 1
    assert wrong.checks["rest_stability"].passed and wrong.checks["rest_penetration"].passed
    sweep = wrong.checks["joint_sweep"]
    door = sweep.details["joints"]["door_joint"]
    assert not sweep.passed and door["reached"] < 0.5  # it turns into the body
    assert door["stopped_by"]["cause"] == "contact"
    assert "door runs into body" in sweep.details["reason"]


def shaft_through_panel() -> ArticulatedAsset:
    """A 1 cm panel with a knob whose 6 cm shaft passes through it: an overlap no cut of either hull can part
    within half its volume (the shaft is the whole knob, and the panel is thinner than the shaft is long)."""
    panel = Link("panel", [Visual(box_between((-0.1, -0.1, -0.005), (0.1, 0.1, 0.005)))], label="panel")
    knob = Link("knob", [Visual(box_between((-0.01, -0.01, -0.03), (0.01, 0.01, 0.03)))], label="knob")
    joints = {"root": Joint("root", "fixed", "base", "panel"),
              "knob_joint": Joint("knob_joint", "continuous", "panel", "knob", make_transform(), np.array([0.0, 0.0, 1.0]),
                                  0.0, 2 * np.pi)}
    return ArticulatedAsset("knob_panel", {"base": Link("base"), "panel": panel, "knob": knob}, joints)


def test_an_overlap_by_construction_stays_excluded_and_the_knob_turns(isolated_home):
    prepared = prepare(shaft_through_panel(), NO_CACHE)
    assert list(prepared.excluded) == [("panel", "knob")]
    assert prepared.excluded[("panel", "knob")] > 0.005
    report = run_checks(shaft_through_panel(), options=NO_CACHE)
    assert report.checks["joint_sweep"].passed, report.checks["joint_sweep"].details


def plate_with_lid_and_plunger() -> ArticulatedAsset:
    """A 1 cm plate whose collision box bulges 2 cm above it (as a hull bulges past its surface), a lid lying in that
    bulge and hinged to lift away, and a plunger 5 mm above the bulge that slides 2 cm down, to 5 mm above the
    plate: both paths are free of the plate's surface."""
    body = Link("body", visuals=[box_visual((0.4, 0.4, 0.01), (0.0, 0.0, 0.005))], label="base",
                collisions=[Collision("box", make_transform(translation=(0, 0, -0.035)), np.array([0.4, 0.4, 0.13]))])
    lid = Link("lid", visuals=[box_visual((0.2, 0.2, 0.02), (0.1, 0.0, -0.01))], label="lid")
    plunger = Link("plunger", visuals=[box_visual((0.05, 0.05, 0.05), (0.125, 0.0, 0.06))], label="button")
    joints = {"root": Joint("root", "fixed", "base", "body"),
              "lid_joint": Joint("lid_joint", "revolute", "body", "lid", make_transform(translation=(-0.2, 0, 0.03)),
                                 np.array([0.0, -1.0, 0.0]), 0.0, 1.5),
              "plunger_joint": Joint("plunger_joint", "prismatic", "body", "plunger", axis=np.array([0.0, 0.0, -1.0]),
                                     lower=0.0, upper=0.02)}
    links = {link.name: link for link in (Link("base"), body, lid, plunger)}
    return ArticulatedAsset("plate_lid_plunger", links, joints, category="Box")


def test_hulls_left_whole_for_an_excluded_pair_are_judged_against_the_other_parts(isolated_home, monkeypatch):
    from spark_bench.sim import phantom

    prepared = prepare(plate_with_lid_and_plunger(), NO_CACHE)
    # the lid's path is free: excluded, and the plate's box is not cut for it (judged as if cut, the box stopped
    # below the plunger's path); on the box left whole the plunger's hulls meet it, its path is free: excluded too
    assert prepared.trim == []
    assert set(prepared.excluded) == {("body", "lid"), ("body", "plunger")}
    report = run_checks(plate_with_lid_and_plunger(), options=NO_CACHE)
    assert report.passed, report.failures()
    # judged on the cut box only, the plunger would stay colliding with the whole one and stop at once
    judge = phantom.find_phantom_blocks
    monkeypatch.setattr(phantom, "find_phantom_blocks", lambda *a, **k: [] if k.get("skip") else judge(*a, **k))
    monkeypatch.setenv("SPARK_BENCH_HOME", str(isolated_home / "first_pass_only"))
    stuck = run_checks(plate_with_lid_and_plunger(), options=NO_CACHE).checks["joint_sweep"]
    assert not stuck.passed and stuck.details["joints"]["plunger_joint"]["reached"] < 0.5
