"""Infinigen-Sim's rest-force check (:mod:`spark_bench.sim.rest_force`): a resting cabinet passes; a joint at
rest outside its limit, and a part starting inside a neighbour, push against themselves and fail, naming the
joint and what carries the force; the check is reported beside spark-bench's verdict, never in it."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from helpers_assets import tiny_cabinet  # noqa: E402
from helpers_boxes import box_visual  # noqa: E402

from spark_bench.sim import build_spec, run_checks  # noqa: E402
from spark_bench.sim.rest_force import REST_FORCE_CHECK, REST_FORCE_LIMIT, check_rest_force  # noqa: E402


@pytest.fixture
def cabinet_model(isolated_home):
    return build_spec(tiny_cabinet()).compile()


def test_a_resting_cabinet_passes(cabinet_model):
    result = check_rest_force(cabinet_model)
    assert result.passed and abs(result.value) < REST_FORCE_LIMIT
    assert result.details["threshold"] == REST_FORCE_LIMIT and "reason" not in result.details


def test_a_joint_at_rest_outside_its_limit_fails_and_is_named(cabinet_model):
    """The drawer's lower limit moved 2 cm past its rest (qpos0): the limit pushes it, Newtons on a slide."""
    joint = cabinet_model.joint("joint_drawer").id
    cabinet_model.jnt_range[joint] = [0.02, 0.3]
    result = check_rest_force(cabinet_model)
    assert not result.passed and abs(result.value) > 100 * REST_FORCE_LIMIT
    assert result.details["dofs"][0]["joint"] == "joint_drawer" and result.details["dofs"][0]["type"] == "slide"
    assert result.details["carriers"][0]["kind"] == "limit" and result.details["carriers"][0]["what"] == "joint_drawer"
    assert "joint_drawer" in result.details["reason"] and "\n" not in result.details["reason"]


def test_a_part_starting_inside_its_neighbour_fails_and_the_contact_is_named(isolated_home):
    """The door moved 2 cm in front of the carcass and made tall enough to reach into the drawer's front
    (siblings: no exclusion): the contact pushes them apart at rest."""
    asset = tiny_cabinet()
    asset.links["door"].visuals = [box_visual((0.02, 0.28, 0.7), (0.0, 0.14, 0.4))]  # door frame: x = -0.22
    result = check_rest_force(build_spec(asset).compile())
    assert not result.passed
    assert any(c["kind"] == "contact" and c["what"] == "door|drawer" for c in result.details["carriers"])


def test_the_check_is_reported_and_does_not_decide_the_verdict(isolated_home, monkeypatch):
    """run_checks puts the check in ``mjcf_compiles``'s details; failing it (a bound no model meets) leaves
    spark-bench's own verdict and checks as they are."""
    import spark_bench.sim.check_load as check_load

    report = run_checks(tiny_cabinet())
    reported = report.checks["mjcf_compiles"].details[REST_FORCE_CHECK]
    assert reported["passed"] is True and reported["threshold"] == REST_FORCE_LIMIT
    monkeypatch.setattr(check_load, "check_rest_force", lambda model: check_rest_force(model, limit=-1.0))
    strict = run_checks(tiny_cabinet())
    assert strict.checks["mjcf_compiles"].details[REST_FORCE_CHECK]["passed"] is False
    assert strict.passed and report.passed
    assert {k: v.passed for k, v in strict.checks.items()} == {k: v.passed for k, v in report.checks.items()}
    assert strict.to_dict()["checks"].keys() == report.to_dict()["checks"].keys()
