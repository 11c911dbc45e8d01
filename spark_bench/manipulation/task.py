"""An opening task built: the joint chosen, its part's grasp planned, the end-effector picked, the scene
compiled with the object and the end-effector, and the drive check run on it
(:mod:`spark_bench.manipulation.drive_check`). The environments of :mod:`spark_bench.envs` simulate what
:func:`build_scene` returns.
"""

from __future__ import annotations

from dataclasses import replace

from spark_bench.asset.model import ArticulatedAsset, Joint
from spark_bench.errors import InputError
from spark_bench.manipulation.drive_check import pinch_limited, stuck_reason
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.manipulation.grasp_target import GraspTarget
from spark_bench.manipulation.gripper import GripperConfig, add_gripper
from spark_bench.manipulation.scene import (
    IMPRATIO,
    TIMESTEP,
    Scene,
    choose_joint,
    fitted_gripper,
    hold_hinged_parts,
    plan_cup,
    plan_grasp,
    prepared_object,
    workspace_box,
)
from spark_bench.manipulation.suction import SuctionConfig, add_suction, choose_end_effector, fitted_cup
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim import build_spec

mujoco = mujoco_module()


def build_scene(asset: ArticulatedAsset, kind: str, joint: str | None = None,
                gripper: GripperConfig | None = None, visuals: bool = True, end_effector: str = "gripper",
                suction: SuctionConfig | None = None, grasp: GraspTarget | None = None) -> Scene:
    """Compile the object with the gripper (or the suction cup), for opening ``joint`` (or the first joint of
    ``kind``).

    :param asset: the object (benchmark frame or metres; Z up, front facing -X)
    :param kind: ``prismatic`` (drawers) or ``revolute`` (doors)
    :param joint: the joint's name, or None for the first of ``kind``
    :param gripper: gripper dimensions and gains
    :param visuals: compile the object's visual meshes (for rendering); without them the scene simulates the
        same (visual geoms have no contacts and no mass) and a real object's compiles 10-30x faster
    :param end_effector: ``gripper``, ``suction`` or ``auto`` (the cup where the planner finds nothing to
        pinch: :func:`~spark_bench.manipulation.suction.choose_end_effector`; also where the cup opens a part whose
        pinch cannot hold its pull along the fingers' closing direction, ``weak_pinch``: :func:`~spark_bench.manipulation.drive_check.stuck_reason`)
    :param suction: the cup's dimensions and holding force
    :param grasp: the gripper's grasp on the chosen joint's part, planned already by the caller
        (:func:`~spark_bench.manipulation.scene.plan_grasp` of ``asset``, the joint and ``gripper``: the
        opening score's judge plans it once per joint and hands it on); None: planned here
    """
    chosen = choose_joint(asset, kind, joint)
    if grasp is None:
        grasp = plan_grasp(asset, chosen.name, gripper)
    effector = choose_end_effector(end_effector, grasp.declined)
    if effector == EndEffector.SUCTION:  # on the face the gripper's planner looked at (a plate's broad face)
        grasp = plan_cup(asset, chosen.name, suction, outward=grasp.outward if grasp.broad_face else None)
    scene = compile_scene(asset, chosen, grasp, effector, gripper, suction, visuals)
    if end_effector == EndEffector.AUTO and scene.grasp.declined == "weak_pinch":
        # a pinch too weak for the part (a heavy lid lifted by its lip: one finger's servo holds that pull): the
        # cup on the part's front, when it finds a place there and its drive check opens the part
        try:
            cup = compile_scene(asset, chosen, plan_cup(asset, chosen.name, suction), "suction", gripper, suction,
                                 visuals)
        except InputError:  # no face for the cup: the pinch stays, with its reason
            return scene
        if cup.grasp.reason is None:
            return cup
    return scene


def compile_scene(asset: ArticulatedAsset, chosen: Joint, grasp: GraspTarget, effector: str,
                   gripper: GripperConfig | None, suction: SuctionConfig | None, visuals: bool) -> Scene:
    """:func:`build_scene` for a planned ``grasp`` and a chosen end-effector (``gripper`` or ``suction``): the
    compiled scene, its drive check run when the planner found a grasp (:func:`~spark_bench.manipulation.drive_check.stuck_reason`)."""
    spec = build_spec(asset, prepared=prepared_object(asset), visuals=visuals)
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, 640)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, 480)
    workspace = workspace_box(asset, joint=chosen)
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.6, 0.6, 0.6]
    spec.worldbody.add_light(pos=[-2.0, -1.0, 3.0], dir=[0.5, 0.25, -0.8], diffuse=[0.5, 0.5, 0.5])
    held = hold_hinged_parts(spec, asset, chosen.name)
    wrist = asset.joint_frames()[chosen.name][1] if chosen.is_rotational else None
    if effector == EndEffector.SUCTION:
        handles = add_suction(spec, approach=-grasp.outward, closing=grasp.closing, wrist_axis=wrist,
                              workspace=workspace, config=fitted_cup(grasp, suction))
    else:
        handles = add_gripper(spec, approach=-grasp.outward, closing=grasp.closing, wrist_axis=wrist,
                              workspace=workspace, config=fitted_gripper(grasp, gripper))
    try:
        model = spec.compile()
    except ValueError as exc:
        raise InputError(asset.source or asset.name, f"MJCF does not compile: {exc}") from None

    data = mujoco.MjData(model)
    for j in asset.movable_joints():
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        if jid >= 0:
            data.qpos[model.jnt_qposadr[jid]] = j.rest_value
    mujoco.mj_kinematics(model, data)
    body = chosen.child
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
    if bid < 0:
        raise InputError(asset.source or asset.name, f"MJCF has no body for link {body!r}")
    local = data.xmat[bid].reshape(3, 3).T @ (grasp.point - data.xpos[bid])
    scene = Scene(model=model, asset=asset, joint=chosen, grasp=grasp, grasp_body=body, grasp_local=local,
                  gripper=handles, workspace=workspace, rest_qpos=data.qpos.copy(), held_joints=tuple(held),
                  end_effector=effector)
    if grasp.reason is None:  # a part no pull of this hand can open: say so, like a flush lid
        reason = stuck_reason(scene)
        if reason is not None:
            scene.grasp = replace(grasp, reason=reason, declined="weak_pinch" if pinch_limited(scene) else grasp.declined)
    return scene
