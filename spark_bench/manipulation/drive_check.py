"""The drive check of an opening task: can the end-effector open the part at all?

The part is driven directly (no gripper in the way) by the largest force the end-effector can open it with,
at the grasp point: the hand's largest pull, one finger's servo for a pinch whose part starts to move along the
fingers' closing direction, the cup's hold for the suction cup. A part that does not open so is one no policy of
that end-effector opens (too heavy, or jammed by its collision shapes), and the scene's grasp says why
(:func:`stuck_reason`, run by :func:`~spark_bench.manipulation.task.build_scene`).
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.transforms import unit
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.manipulation.grasp import outward_direction, part_name
from spark_bench.manipulation.gripper import largest_pull, pinch_hold
from spark_bench.manipulation.scene import N_SUBSTEPS, Scene
from spark_bench.manipulation.suction import largest_hold
from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

#: The drive check (:func:`free_motion`, :func:`stuck_reason`): the most control steps a force is applied
#: for (20 s, longer than any episode: the opening score's run 200 steps), the fraction of the range the
#: part must reach so (the tasks' default success fraction), and how many times the gripper's largest pull
#: the second drive applies, to tell a part too heavy for the gripper from one its collision shapes hold.
#: The drive stops earlier once the part stands still: it moved less than :data:`STALL_TOLERANCE` of its
#: range over the last :data:`STALL_STEPS` control steps (a constant force on a part at rest that it does
#: not move never will), so the check does not depend on an episode's length.
FREE_STEPS = 500
JAM_FRACTION = 0.75
OVERLOAD = 4.0
STALL_STEPS = 10
STALL_TOLERANCE = 1e-3


def hand_pull(scene: Scene) -> float:
    """The largest steady force (N) the end-effector opens ``scene``'s part with: the cup's largest hold
    (:func:`~spark_bench.manipulation.suction.largest_hold`); the hand's largest pull
    (:func:`~spark_bench.manipulation.gripper.largest_pull`), and for a pinch whose part starts to move along the
    fingers' closing direction (a lid's lip pinched across its thickness and lifted) at most what the far
    finger's servo holds over that share of the pull (:func:`~spark_bench.manipulation.gripper.pinch_hold`): there
    the pads' friction holds nothing."""
    config = scene.gripper.config
    if scene.end_effector == EndEffector.SUCTION:
        return largest_hold(config)
    pull = largest_pull(config)
    if scene.grasp.inside_grip:  # the fingers open against a notch's sides: the pull runs across them
        return pull
    pivot, axis = scene.asset.joint_frames()[scene.joint.name]
    try:  # where the grasp point starts to move as the part opens
        moving = outward_direction(scene.joint.type, pivot, unit(axis), scene.grasp.point[None])
    except ValueError:  # a grasp on the hinge axis moves nowhere: nothing pulls along the closing
        return pull
    along = abs(float(moving @ scene.grasp.closing))
    return float(min(pull, pinch_hold(config) / along)) if along > 1e-6 else pull


def pinch_limited(scene: Scene) -> bool:
    """Whether one finger's servo, not the arm, limits the gripper's pull on ``scene``'s part (:func:`hand_pull`)."""
    return scene.end_effector == EndEffector.GRIPPER and hand_pull(scene) < largest_pull(scene.gripper.config)


def stuck_reason(scene: Scene) -> str | None:
    """Why no policy of this end-effector can open ``scene``'s part, or None: driven directly (no gripper in
    the way) by the largest force it can open the part with (:func:`hand_pull`, at the grasp point, until it
    stands still) it does not reach :data:`JAM_FRACTION` of its range. Driven then by :data:`OVERLOAD` times
    that force, it either opens (the part is too heavy for the gripper: its simulated mass, damping or
    friction; or caught on a collision shape that the harder pull forces through) or not (its collision
    shapes hold it: jammed). With the suction cup the force is the cup's largest hold and there is no second
    drive: a harder pull tears the cup off. Sets ``scene.free_fraction``."""
    cup = scene.end_effector == EndEffector.SUCTION
    pull = hand_pull(scene)
    reached = scene.free_fraction = free_motion(scene, pull)
    if reached >= JAM_FRACTION:
        return None
    part = part_name(scene.asset, scene.joint.name)
    if cup:  # the cup's holding force, not the hand's pull: a harder pull would tear the cup off
        return (f"{scene.joint.name}: the simulated {part} is too heavy for the suction cup, or caught on its "
                f"collision shapes: driven directly with the cup's largest hold ({pull:.0f} N at the grasp, nothing "
                f"in the way) it stops at {reached:.2f} of its range, short of {JAM_FRACTION:.2f}")
    if pinch_limited(scene):
        return (f"{scene.joint.name}: the simulated {part} is too heavy for the pinch: it starts to move along the "
                f"fingers' closing direction, where one finger's servo holds at most {pinch_hold(scene.gripper.config):.0f} "
                f"N; driven directly with {pull:.0f} N at the grasp it stops at {reached:.2f} of its range, short of "
                f"{JAM_FRACTION:.2f}")
    harder = free_motion(scene, OVERLOAD * pull)
    # a part that gives way to a harder pull may be heavy or caught on a shape a harder pull forces: say both
    why = (f"too heavy for the gripper, or caught on its collision shapes (pulled with {OVERLOAD * pull:.0f} N "
           f"it reaches {harder:.2f})"
           if harder >= JAM_FRACTION else f"jammed by its collision shapes (with {OVERLOAD * pull:.0f} N: {harder:.2f})")
    return (f"{scene.joint.name}: the simulated {part} is {why}: driven directly with the gripper's largest pull "
            f"({pull:.0f} N at the grasp, nothing in the way) it stops at {reached:.2f} of its range, "
            f"short of {JAM_FRACTION:.2f}")


def free_motion(scene: Scene, force: float, steps: int = FREE_STEPS) -> float:
    """The largest fraction of its range ``scene``'s joint reaches when driven directly from rest: a
    generalized force on the joint (``force`` at the grasp point's lever arm for a rotational joint, at
    least 5 cm), the gripper parked at a corner of its workspace, at most ``steps`` control steps (it stops
    once the part passes :data:`JAM_FRACTION`, or stands still: :data:`STALL_STEPS`): tens of ms, no
    gripper contacts."""
    model = scene.model
    data = mujoco.MjData(model)
    data.qpos[:] = scene.rest_qpos
    park = scene.workspace[1] - 0.01
    slides = [model.jnt_qposadr[model.joint(name).id] for name in scene.gripper.slide_joints]
    data.qpos[slides] = park
    for name, target in zip(scene.gripper.slide_actuators, park):
        data.ctrl[model.actuator(name).id] = target
    lever = 1.0
    if scene.joint.is_rotational:
        pivot, axis = scene.asset.joint_frames()[scene.joint.name]
        r = scene.grasp.point - pivot
        lever = max(float(np.linalg.norm(r - (r @ axis) * axis)), 0.05)
    jid = model.joint(scene.joint.name).id
    dof, qadr = model.jnt_dofadr[jid], model.jnt_qposadr[jid]
    rest, span = scene.joint.rest_value, scene.joint.open_value - scene.joint.rest_value
    data.qfrc_applied[dof] = force * lever
    best, trail = 0.0, []
    for _ in range(steps):
        mujoco.mj_step(model, data, nstep=N_SUBSTEPS)
        fraction = float((data.qpos[qadr] - rest) / span)
        if not np.isfinite(fraction):
            break
        best = max(best, fraction)
        trail = (trail + [fraction])[-(STALL_STEPS + 1):]
        if best >= JAM_FRACTION or (len(trail) > STALL_STEPS and np.ptp(trail) < STALL_TOLERANCE):
            break
    return best
