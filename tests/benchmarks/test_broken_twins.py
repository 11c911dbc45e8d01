"""Broken twins (benchmarks/broken_twins.py) and the clean-break judge (benchmarks/clean_break.py), on assets built
in code: each twin rests where the intact object rests and moves its part the wrong way."""

import numpy as np
import pytest
from helpers_assets import open_cabinet, tiny_cabinet

from benchmarks.broken_twins import (
    applicable_kinds,
    axis_reversed,
    make_twin,
    pivot_far_edge,
    slide_turned,
    type_swapped,
)
from benchmarks.clean_break import judge_break, path_crossing


def part_points(asset, joint, value=None):
    """The moving part's vertices in the world with ``joint`` at ``value`` (rest when None)."""
    q = {} if value is None else {joint: value}
    link = asset.joints[joint].child
    while not asset.links[link].has_geometry:  # a moved pivot hangs the part on a helper link
        link = next(j.child for j in asset.joints.values() if j.parent == link)
    return asset.link_meshes(q, [link])[link].vertices


def test_a_reversed_hinge_rests_where_it_rested_and_turns_the_other_way():
    cabinet = tiny_cabinet()
    cabinet.joints["joint_door"].lower, cabinet.joints["joint_door"].upper = -0.3, 1.2  # rest at -0.3 rad
    twin = axis_reversed(cabinet, "joint_door")
    assert twin.asset.joints["joint_door"].lower == 0.0
    assert twin.asset.joints["joint_door"].upper == pytest.approx(1.5)
    np.testing.assert_allclose(part_points(twin.asset, "joint_door"), part_points(cabinet, "joint_door"), atol=1e-9)
    np.testing.assert_allclose(part_points(twin.asset, "joint_door", 0.4), part_points(cabinet, "joint_door", -0.7),
                               atol=1e-9)
    assert cabinet.joints["joint_door"].lower == -0.3  # the intact object is left as it was


def test_a_pivot_moved_to_the_far_edge_keeps_that_edge_still():
    cabinet = open_cabinet()  # door plate y in [-0.3, 0.3] in the world, hinged at y = -0.3
    twin = pivot_far_edge(cabinet, "door_joint")
    assert twin.part == "door" and "door_pivot_helper" in twin.asset.links
    rest = part_points(twin.asset, "door_joint")
    np.testing.assert_allclose(rest, part_points(cabinet, "door_joint"), atol=1e-9)
    turned = part_points(twin.asset, "door_joint", 0.5)
    far = rest[:, 1] > 0.29
    np.testing.assert_allclose(turned[far][:, :2], rest[far][:, :2], atol=0.011)  # turns about its far edge
    hinge = rest[:, 1] < -0.29
    assert np.all(turned[hinge][:, 0] > rest[hinge][:, 0] + 0.2)  # the old hinge edge swings back, into the body


def test_a_turned_slide_moves_sideways_and_a_vertical_slide_has_no_turn():
    cabinet = tiny_cabinet()  # the drawer pulls out along -x
    twin = slide_turned(cabinet, "joint_drawer")
    moved = part_points(twin.asset, "joint_drawer", 0.1) - part_points(twin.asset, "joint_drawer")
    np.testing.assert_allclose(np.abs(moved[0]), [0.0, 0.1, 0.0], atol=1e-9)
    cabinet.joints["joint_drawer"].axis = np.array([0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="slides vertically"):
        slide_turned(cabinet, "joint_drawer")


def test_swapped_types_a_door_slides_along_its_hinge_and_a_drawer_tips_about_its_front_edge():
    door = type_swapped(open_cabinet(), "door_joint").asset
    assert door.joints["door_joint"].type == "prismatic"
    assert door.joints["door_joint"].upper == pytest.approx(0.6, abs=0.01)  # the door's width
    moved = part_points(door, "door_joint", 0.1) - part_points(door, "door_joint")
    np.testing.assert_allclose(moved[0], [0.0, 0.0, 0.1], atol=1e-9)  # along the hinge line (+z)
    cabinet = tiny_cabinet()
    drawer = type_swapped(cabinet, "joint_drawer").asset
    rest, tipped = part_points(drawer, "joint_drawer"), part_points(drawer, "joint_drawer", 0.5)
    top_front = np.argmin(rest[:, 0] - rest[:, 2])  # the front (-x) top corner tips out (-x)
    assert tipped[top_front, 0] < rest[top_front, 0] - 0.05
    back_bottom = np.argmax(rest[:, 0] - rest[:, 2])  # the box behind rises
    assert tipped[back_bottom, 2] > rest[back_bottom, 2] + 0.01
    assert applicable_kinds(cabinet.joints["joint_drawer"]) == ("axis_reversed", "slide_turned", "type_swapped")
    with pytest.raises(ValueError, match="unknown kind"):
        make_twin(cabinet, "joint_drawer", "bent")


def test_the_judge_calls_a_door_into_its_body_clean_and_a_door_sliding_up_its_front_free():
    cabinet = open_cabinet()
    intact = path_crossing(cabinet, "door_joint")
    assert intact.entered < 0.02  # the right way, into free space
    reversed_door = judge_break(cabinet, axis_reversed(cabinet, "door_joint").asset, "door_joint")
    assert reversed_door.clean and reversed_door.twin.entered > 0.3
    assert reversed_door.twin.first < 0.1
    sliding = judge_break(cabinet, type_swapped(cabinet, "door_joint").asset, "door_joint")
    assert not sliding.clean and "free space" in sliding.reason  # it slides up in front of the body


def test_a_failure_says_what_it_caught_only_with_the_part_the_body_and_where():
    from benchmarks.measure_check_validity import says_what_it_caught

    # the reason of a caught twin of partnet_dev 100247 (a box whose lid's axis was reversed), as the check wrote it
    reason = ("joint joint_0 reached 0% and returned 63% of its range (blocked: link_0 runs into link_1 at 0 deg: "
              "link_0_collision_15 by link_1_collision_1); the surface of link_1 enters link_0 from 11 deg (6% of the "
              "range), 5.2 mm deep at most: the object itself blocks joint_0 there (its range or its geometry is wrong)")
    caught = {"passed": False, "failed": ["joint_sweep"], "reasons": {"joint_sweep": reason}, "sweep_failed": ["joint_0"]}
    assert says_what_it_caught(caught, "joint_0", "link_0")
    slide = {**caught, "reasons": {"joint_sweep": reason.replace("at 0 deg", "at 14 mm")}}
    assert says_what_it_caught(slide, "joint_0", "link_0")
    # another joint's failure says nothing of this one; a stop with no body, or no place, does not say enough
    assert not says_what_it_caught({**caught, "sweep_failed": ["joint_3"]}, "joint_9", "link_9")
    held = ("joint joint_0 reached 20% and returned 20% of its range (not blocked by a contact: held by its joint "
            "friction)")
    assert not says_what_it_caught({**caught, "reasons": {"joint_sweep": held}}, "joint_0", "link_0")
    resting = {"passed": False, "failed": ["rest_penetration"], "sweep_failed": [],
               "reasons": {"rest_penetration": "link_0_collision_1 and link_1_collision_3 interpenetrate by 0.94% of "
                                               "the object's size at rest"}}
    assert not says_what_it_caught(resting, "joint_0", "link_0")
    assert not says_what_it_caught({**caught, "passed": True}, "joint_0", "link_0")
