"""The joint sweep's drive: never weaker than the part's weight, and a stop explained by what holds the part."""

from __future__ import annotations

import pytest

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.sweep import (
    FORCE_MARGIN,
    MAX_SERVO_OMEGA_DT,
    SweptJoint,
    check_joint_sweep,
    servo_limits,
    stopped_by_contact,
)

mujoco = mujoco_module()
SLIDE = SweptJoint("slide", False, 0.0, 0.3, 0.0)


def drawer(wall: bool = False, stiffness: float = 0.0, pebble: float = 0.0):
    """A 50 g drawer (10 x 10 x 2 cm) sliding 0.3 m along x above a fixed plate; with ``wall`` a block stops it
    after 0.1 m; ``stiffness`` (N/m) is a spring pulling it back to 0; ``pebble`` (kg) is a loose block lying
    on the plate in its path, 2 cm ahead (friction 1: pushing it takes its weight)."""
    block = "<geom name='wall' type='box' size='.01 .2 .1' pos='.17 0 .1'/>" if wall else ""
    loose = (f"<body name='pebble' pos='.09 0 .03'><freejoint/><geom name='stone' type='box' size='.02 .02 .02'"
             f" mass='{pebble}' friction='1'/></body>" if pebble else "")
    xml = f"""<mujoco><option gravity='0 0 -9.81'/><worldbody>
      <geom name='plate' type='box' size='.5 .2 .01' pos='0 0 0' friction='1'/>{block}{loose}
      <body name='drawer' pos='0 0 .035'><joint name='slide' type='slide' axis='1 0 0' range='0 .3' limited='true'
        stiffness='{stiffness}'/><geom name='box' type='box' size='.05 .05 .01' mass='.05'/></body>
    </worldbody></mujoco>"""
    return mujoco.MjSpec.from_string(xml)


def test_the_servo_limit_is_never_below_the_weight_and_stays_integrable():
    # friction and damping need 1 mN; the part weighs 0.49 N: the limit is its weight
    force, kp = servo_limits(need=0.001, weight=0.49, inertia=0.05, span=0.3, dt=0.002)
    assert force == pytest.approx(0.49)
    assert kp <= 0.05 * (MAX_SERVO_OMEGA_DT / 0.002) ** 2 * 1.0001
    assert kp >= FORCE_MARGIN * 0.001 / (0.05 * 0.3)  # never softer than without the floor
    # a heavy need: the floor does not bind, the servo is as before
    force, kp = servo_limits(need=1.0, weight=0.49, inertia=0.05, span=0.3, dt=0.002)
    assert force == pytest.approx(FORCE_MARGIN) and kp == pytest.approx(FORCE_MARGIN / (0.05 * 0.3))


def test_a_resistance_below_the_parts_weight_does_not_stop_it():
    """Friction, damping and inertia ask 0.2 N of the servo (the limit without the floor); pushing the 35 g
    block lying in the drawer's path takes 0.34 N, less than the drawer's own weight (0.49 N): a hand that
    pulls a drawer out pushes a pebble aside, and so does the sweep's servo."""
    result = check_joint_sweep(drawer(pebble=0.035), [SLIDE], size=0.5)
    joint = result.details["joints"]["slide"]
    # at least 90 % out and back (measured: 98 % out, the servo 0.49 N against the block's 0.34 N)
    assert result.passed, result.details.get("reason")
    assert joint["returned"] >= 0.9


def test_without_the_weight_floor_the_same_resistance_stops_the_drawer(monkeypatch):
    """The case above with the servo limited to what friction and damping need: the block holds it, and the
    explanation says the contact did."""
    monkeypatch.setattr("spark_bench.sim.sweep.MIN_DRIVE_WEIGHTS", 0.0)
    result = check_joint_sweep(drawer(pebble=0.035), [SLIDE], size=0.5)
    joint = result.details["joints"]["slide"]
    assert not result.passed and joint["reached"] < 0.5
    assert joint["stopped_by"]["cause"] == "contact"


def test_a_drawer_run_into_a_wall_is_blocked_by_the_contact():
    result = check_joint_sweep(drawer(wall=True), [SLIDE], size=0.5)
    joint = result.details["joints"]["slide"]
    assert not result.passed
    assert joint["reached"] < 0.5
    assert joint["stopped_by"]["cause"] == "contact" and stopped_by_contact(joint)
    assert joint["stopped_by"]["opposing"]["contact"] >= 0.5 * joint["stopped_by"]["drive"]
    assert "(blocked: drawer runs into" in result.details["reason"]


def test_a_drawer_held_by_a_spring_is_not_said_to_be_blocked_by_a_contact():
    """A 20 N/m spring pulls back 2 N at 0.1 m, four times the drive: the drawer stops short, resting on its plate
    (a contact), and the reason names the spring."""
    result = check_joint_sweep(drawer(stiffness=20.0), [SLIDE], size=0.5)
    joint = result.details["joints"]["slide"]
    assert not result.passed
    assert joint["stopped_by"]["cause"] == "spring" and not stopped_by_contact(joint)
    assert "not blocked by a contact: held by spring" in result.details["reason"]
