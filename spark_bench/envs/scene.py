"""The compiled scene of an opening task: the object's MJCF (from :mod:`spark_bench.sim`), the floating
gripper, the chosen joint and where to grasp its part.

The object's :class:`mujoco.MjSpec` comes from :func:`spark_bench.sim.build_spec`, the sim-readiness
conversion (bodies named by link, joints by URDF joint name with ``qpos`` in URDF values, convex
collision geoms in class ``collision`` with ``contype = conaffinity = 1``, CoACD hulls cached under
``SPARK_BENCH_HOME``). The gripper's geoms have ``contype 2, conaffinity 1``: they touch the object and
not each other.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np

from spark_bench.asset.model import ArticulatedAsset, Joint
from spark_bench.envs.grasp import GraspTarget, find_grasp
from spark_bench.envs.gripper import GripperConfig, GripperHandles, add_gripper
from spark_bench.errors import InputError

#: Physics step, s. The control period is ``TIMESTEP * N_SUBSTEPS`` (25 Hz).
TIMESTEP = 0.004
N_SUBSTEPS = 10
#: Friction-to-normal impedance ratio, with elliptic friction cones: MuJoCo's default (1, pyramidal)
#: lets a pinched handle creep out of the pads under a steady pull (measured: 7 of 117 synth drawers
#: slipped off at 55-70 % open); 10 makes the grip hold.
IMPRATIO = 10.0
#: Room (m) left between the pads and a notch's edges, along its depth (the pads' height direction), and
#: the lowest pads a notch gets, m.
NOTCH_CLEARANCE = 0.014
NOTCH_MIN_PAD_HEIGHT = 0.008
#: Contact ``solref`` of pads thinned to fit beside a handle: the stiffest MuJoCo allows at this step
#: (2 steps), so that a 3 mm pad squeezing a 5 mm lip sinks about 0.5 mm into it, not 2 mm (at 0.02 s).
#: The default pads keep MuJoCo's default, which the opener's grasps were tuned on.
THIN_PAD_SOLREF = (2 * TIMESTEP, 1.0)
#: How far (m) around the object's box the gripper may move.
WORKSPACE_MARGIN = 0.35

KIND_TYPES = {"prismatic": ("prismatic",), "revolute": ("revolute", "continuous")}


@dataclass
class Scene:
    """A compiled opening task.

    :param model: the compiled model (object + gripper); share it read-only between environments
    :param asset: the object
    :param joint: the joint to open (its asset entry)
    :param grasp: where to grasp the part, world frame at rest
    :param grasp_body: the MuJoCo body the grasp point moves with (the joint's child link)
    :param grasp_local: the grasp point in that body's frame
    :param gripper: names of the gripper's elements
    :param workspace: ``[[min], [max]]`` box the TCP may reach
    :param rest_qpos: the full ``qpos`` with every object joint at rest, gripper at the origin
    """

    model: mujoco.MjModel
    asset: ArticulatedAsset
    joint: Joint
    grasp: GraspTarget
    grasp_body: str
    grasp_local: np.ndarray
    gripper: GripperHandles
    workspace: np.ndarray
    rest_qpos: np.ndarray

    @property
    def joint_range(self) -> tuple[float, float]:
        """The joint's opening range: ``(rest, open)``."""
        return self.joint.rest_value, self.joint.open_value


def choose_joint(asset: ArticulatedAsset, kind: str, joint: str | None) -> Joint:
    """The joint to open: ``joint`` checked against ``kind``, or the first joint of that kind.

    :param kind: ``prismatic`` or ``revolute``
    :raises InputError: no such joint, or not of the right kind
    """
    types = KIND_TYPES[kind]
    where = asset.source or asset.name
    movable = [j.name for j in asset.movable_joints()]
    if joint is not None:
        if joint not in asset.joints:
            raise InputError(where, f"no joint named {joint!r} (movable joints: {', '.join(movable) or 'none'})")
        found = asset.joints[joint]
        if found.type not in types:
            raise InputError(where, f"joint {joint!r} is {found.type}, this task needs a {kind} joint")
        candidate = found
    else:
        matches = [j for j in asset.movable_joints() if j.type in types]
        if not matches:
            raise InputError(where, f"asset has no {kind} joint (movable joints: {', '.join(movable) or 'none'})")
        candidate = matches[0]
    if candidate.open_value <= candidate.rest_value:
        raise InputError(where, f"joint {candidate.name!r} has an empty range [{candidate.lower}, {candidate.upper}]")
    return candidate


def workspace_box(asset: ArticulatedAsset, margin: float = WORKSPACE_MARGIN) -> np.ndarray:
    """The box holding the object both at rest and fully open, grown by ``margin`` on every side."""
    rest, opened = asset.bounds(), asset.bounds(asset.open_configuration())
    return np.stack([np.minimum(rest[0], opened[0]) - margin, np.maximum(rest[1], opened[1]) + margin])


def fitted_gripper(grasp: GraspTarget, gripper: GripperConfig | None = None) -> GripperConfig:
    """The gripper fitted to ``grasp``: pads lowered to enter a notch with room to spare, or thinned to fit
    into the gaps beside the handle (:func:`~spark_bench.envs.pads.plan_pads` planned them for ``gripper``).

    :param gripper: the gripper to fit (default: :class:`GripperConfig`'s defaults)
    """
    base = gripper or GripperConfig()
    if grasp.inside_grip and grasp.notch_size is not None:
        height = max(grasp.notch_size[0] - NOTCH_CLEARANCE, NOTCH_MIN_PAD_HEIGHT)
        return replace(base, pad_height=float(min(base.pad_height, height)))
    if grasp.pad_thickness is not None:
        return replace(base, pad_thickness=min(base.pad_thickness, grasp.pad_thickness), pad_solref=THIN_PAD_SOLREF)
    return base


def build_scene(asset: ArticulatedAsset, kind: str, joint: str | None = None,
                gripper: GripperConfig | None = None) -> Scene:
    """Compile the object with the gripper, for opening ``joint`` (or the first joint of ``kind``).

    :param asset: the object (benchmark frame or metres; Z up, front facing -X)
    :param kind: ``prismatic`` (drawers) or ``revolute`` (doors)
    :param joint: the joint's name, or None for the first of ``kind``
    :param gripper: gripper dimensions and gains
    """
    chosen = choose_joint(asset, kind, joint)
    try:
        grasp = find_grasp(asset, chosen.name, gripper=gripper)
    except ValueError as exc:
        raise InputError(asset.source or asset.name, str(exc)) from None
    from spark_bench.sim import build_spec

    spec = build_spec(asset)
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, 640)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, 480)
    workspace = workspace_box(asset)
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.6, 0.6, 0.6]
    spec.worldbody.add_light(pos=[-2.0, -1.0, 3.0], dir=[0.5, 0.25, -0.8], diffuse=[0.5, 0.5, 0.5])
    wrist = asset.joint_frames()[chosen.name][1] if chosen.is_rotational else None
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
    return Scene(model=model, asset=asset, joint=chosen, grasp=grasp, grasp_body=body, grasp_local=local,
                 gripper=handles, workspace=workspace, rest_qpos=data.qpos.copy())
