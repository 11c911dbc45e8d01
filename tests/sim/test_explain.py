"""Why a swept part stopped: the forces on its joint where it stopped, not the contacts that happen to be there."""

from __future__ import annotations

import pytest

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.explain import stop_cause

mujoco = mujoco_module()


def lid(friction: float = 0.0, wall: bool = False, force: float = 2.0, touch: bool = False) -> str:
    """A 0.3 m, 1 kg lid on a hinge about y, driven by a position servo limited to ``force`` N m towards
    90 deg; with ``wall`` a block stops it at about 23 deg; with ``touch`` a 1 g pebble rests on it (a contact
    of millinewtons that holds nothing back)."""
    block = "<geom name='wall' type='box' size='.05 .2 .05' pos='.2 0 .2'/>" if wall else ""
    pebble = ("<body pos='.25 0 .061'><freejoint/><geom name='pebble' type='box' size='.02 .02 .02' mass='.001'/>"
            "</body>" if touch else "")
    return f"""<mujoco><compiler angle='radian'/><option gravity='0 0 -9.81'/><worldbody>{block}
      <body name='lid'><joint name='hinge' type='hinge' axis='0 -1 0' range='0 1.5708' frictionloss='{friction}'
        limited='true'/><geom name='plate' type='box' size='.15 .1 .01' pos='.15 0 .03' mass='1'/></body>{pebble}
    </worldbody><actuator><position name='servo' joint='hinge' kp='50' forcelimited='true'
      forcerange='-{force} {force}'/></actuator></mujoco>"""


def stopped(xml: str, target: float = 1.5708, steps: int = 1500, feed_forward: bool = True):
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    dof = int(model.jnt_dofadr[model.joint("hinge").id])
    for _ in range(steps):
        data.ctrl[0] = target
        data.qfrc_applied[:] = 0.0
        if feed_forward:  # as the sweep does: the part's weight carried by the drive's feed-forward
            data.qfrc_applied[dof] = data.qfrc_bias[dof]
        mujoco.mj_step(model, data)
    return model, data


def test_a_part_stopped_by_another_is_explained_by_the_contact():
    model, data = stopped(lid(wall=True))
    assert data.qpos[0] < 1.0  # stopped well short of 90 deg
    cause = stop_cause(model, data, "hinge", "servo")
    assert cause["cause"] == "contact" and cause["saturated"]
    assert cause["opposing"]["contact"] == pytest.approx(cause["drive"], rel=0.1)


def test_a_part_held_by_its_joint_friction_is_not_explained_by_a_light_contact():
    """The servo gives 2 N m, the hinge's friction takes 2.5: the lid creeps a little (MuJoCo's friction is
    soft) and stops far short, and the pebble lying on it (a contact of millinewton-metres) is not what holds it."""
    model, data = stopped(lid(friction=2.5, touch=True))
    assert data.qpos[0] < 0.5
    assert data.ncon >= 1  # the pebble touches the lid
    cause = stop_cause(model, data, "hinge", "servo")
    assert cause["cause"] == "joint friction" and cause["saturated"]
    assert cause["opposing"].get("contact", 0.0) < 0.1 * cause["drive"]
    assert "joint friction" in cause["text"]


def test_a_part_too_heavy_for_its_drive_is_said_so():
    """Without the feed-forward the lid's weight (about 1.5 N m at rest) is more than the 1 N m servo: nothing
    but its own weight holds it."""
    model, data = stopped(lid(force=1.0), feed_forward=False)
    assert data.qpos[0] < 0.05
    cause = stop_cause(model, data, "hinge", "servo")
    assert cause["cause"] == "drive too weak" and cause["saturated"]
    assert cause["text"].startswith("the drive is too weak for the part")
