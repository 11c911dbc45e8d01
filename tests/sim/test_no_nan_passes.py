"""No check passes on a number that is not one, and a part with nothing to weigh fails ``mass_inertia`` (issue 43,
item 3).

Before issue 43, ``check_mass_inertia`` passed an object none of whose bodies moves with the value NaN (the smallest
mass over no moving body), and a moving part without any geometry (no visual, no collision shape) with the converter's
placeholder mass (``spark_bench.sim.physical.HELPER_MASS``, 1 g, meant for PartNet-Mobility's ``*_helper`` links
between two joints). Now the first weighs its bodies (a finite value, a pass), the second fails with a reason, and a
result that is not a number is never a pass (:class:`~spark_bench.sim.results.CheckResult`).
"""

from __future__ import annotations

import math

import numpy as np
from helpers_boxes import box_visual

from spark_bench.asset.model import ArticulatedAsset, Joint, Link
from spark_bench.sim.checks import run_checks
from spark_bench.sim.options import ConvertOptions


def _offset(x: float, y: float, z: float) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = [x, y, z]
    return out


def _options() -> ConvertOptions:
    return ConvertOptions(workers=1, use_cache=False)


def static_box() -> ArticulatedAsset:
    """A box with a lid welded on: nothing moves."""
    links = {"base": Link("base", [box_visual([0.4, 0.4, 0.4], [0, 0, 0.2])]),
             "lid": Link("lid", [box_visual([0.4, 0.4, 0.02], [0, 0, 0.01])])}
    joints = {"weld": Joint("weld", "fixed", "base", "lid", _offset(0, 0, 0.4))}
    return ArticulatedAsset("static_box", links, joints)


def empty_door() -> ArticulatedAsset:
    """A carcass and a door on a hinge, the door with no geometry at all (what a file whose door meshes are all
    left out becomes): nothing to collide with, nothing to weigh."""
    links = {"base": Link("base", [box_visual([0.4, 0.6, 0.8], [0.2, 0, 0.4])]), "door": Link("door")}
    joints = {"hinge": Joint("hinge", "revolute", "base", "door", _offset(0, -0.3, 0), np.array([0, 0, 1.0]),
                             0.0, 1.5)}
    return ArticulatedAsset("empty_door", links, joints)


def helper_chain() -> ArticulatedAsset:
    """A part on two joints through a helper link without geometry (PartNet-Mobility's ``*_helper``): the helper
    weighs the placeholder, the part below it has its box; this must keep passing."""
    links = {"base": Link("base", [box_visual([0.4, 0.4, 0.4], [0, 0, 0.2])]), "cap_helper": Link("cap_helper"),
             "cap": Link("cap", [box_visual([0.1, 0.1, 0.05], [0, 0, 0.025])])}
    joints = {"turn": Joint("turn", "continuous", "base", "cap_helper", _offset(0, 0, 0.4), np.array([0, 0, 1.0]),
                            0.0, 2 * math.pi, has_limits=False),
              "lift": Joint("lift", "prismatic", "cap_helper", "cap", np.eye(4), np.array([0, 0, 1.0]), 0.0, 0.02)}
    return ArticulatedAsset("helper_chain", links, joints)


def test_a_result_that_is_not_a_number_is_a_failure_with_its_reason():
    from spark_bench.sim.results import CheckResult

    for value in (float("nan"), float("inf")):
        result = CheckResult(True, value, {})
        assert not result.passed and "not a number" in result.details["reason"]
    assert CheckResult(True, 0.5, {}).passed


def test_an_object_where_nothing_moves_is_weighed_by_its_bodies():
    check = run_checks(static_box(), _options()).checks["mass_inertia"]
    assert check.passed and math.isfinite(check.value) and check.value > 0.1, check.to_dict()  # kg, not NaN


def test_a_moving_part_without_collision_geometry_fails_mass_inertia_with_a_reason():
    check = run_checks(empty_door(), _options()).checks["mass_inertia"]
    assert not check.passed
    assert "door" in check.details["reason"] and "collision" in check.details["reason"]


def test_a_helper_link_between_two_joints_still_passes_mass_inertia():
    """The rule above must look at the part a body carries (itself and the bodies below it), not the body alone."""
    check = run_checks(helper_chain(), _options()).checks["mass_inertia"]
    assert check.passed and math.isfinite(check.value), check.to_dict()
