"""No check passes on a number that is not one, and a part with nothing to weigh fails ``mass_inertia`` (issue 43,
item 3).

Today (``spark_bench/sim/checks.py`` ``check_mass_inertia``): an object none of whose bodies moves passes
``mass_inertia`` with the value NaN (the smallest mass over no moving body), and a moving part without any geometry
(no visual, no collision shape) passes with the converter's placeholder mass (``spark_bench.sim.physical.HELPER_MASS``,
1 g, meant for PartNet-Mobility's ``*_helper`` links between two joints). Both fail now, with a reason.
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


def test_no_check_passes_with_a_value_that_is_not_a_number():
    report = run_checks(static_box(), _options())
    passed_on_nan = [name for name, check in report.checks.items() if check.passed and not math.isfinite(check.value)]
    assert passed_on_nan == []


def test_a_moving_part_without_collision_geometry_fails_mass_inertia_with_a_reason():
    check = run_checks(empty_door(), _options()).checks["mass_inertia"]
    assert not check.passed
    assert "door" in check.details["reason"] and "collision" in check.details["reason"]


def test_a_helper_link_between_two_joints_still_passes_mass_inertia():
    """The rule above must look at the part a body carries (itself and the bodies below it), not the body alone."""
    check = run_checks(helper_chain(), _options()).checks["mass_inertia"]
    assert check.passed and math.isfinite(check.value), check.to_dict()
