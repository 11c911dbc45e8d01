"""A floating parallel-jaw gripper added to an :class:`mujoco.MjSpec`.

The gripper is a physically simulated body, not a mocap: three world-aligned slide joints carry it, a
position actuator drives each towards a target, and gravity compensation makes it hover. Its hand
hangs below with a fixed orientation (fingers pointing along the approach direction, closing across the
handle) and, for doors, a passive spring-loaded wrist hinge parallel to the door's hinge, so that a
held handle can turn between the fingers without tearing out of the grasp. Two fingers slide on the
hand, each with its own force-limited position actuator, so a grasp squeezes with a bounded force.

Frames: the hand frame's origin is the *tool center point* (TCP), the point between the finger pads;
hand x is the approach direction (palm to fingertips), hand y the closing direction.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

PREFIX = "spark_gripper"
#: Largest TCP displacement per step (action 1.0), m: the environments move each translation servo's target
#: at most this far from the TCP (the carriage of either end-effector), the hand's largest pull follows from it
#: (:func:`largest_pull`) and the scripted opener scales its moves by it. The one definition.
MAX_STEP = 0.02


@dataclass
class GripperConfig:
    """Dimensions and gains of the gripper.

    :param finger_length: pad length along the approach direction, m
    :param tip_beyond_tcp: how far the fingertips reach past the TCP, m
    :param max_opening: finger travel per side, m (full opening is twice this)
    :param pad_height: pad extent across the approach and closing directions, m (lower to fit a notch)
    :param pad_thickness: pad extent along the closing direction, m (thinner to fit a pad into a narrow gap
        beside a handle, e.g. between the edge lips of a double door)
    :param kp: stiffness of the translation servos, N/m: an action moves the servo target at most 2 cm
        from the TCP, so this bounds the pull to ``kp * 0.02`` N per axis (60 N; a real safe's 60 kg door
        needed more than 1500 N/m gave to swing open within the 100 steps)
    :param dampratio: damping ratio of the translation servos (their damping resists the hand's absolute
        velocity, so it caps the speed at which a servo target 2 cm ahead can drag a load)
    :param force_limit: force limit of each translation servo, N
    :param finger_kp: stiffness of each finger servo, N/m
    :param squeeze: how far past fully closed (m) the closed command aims: the grip force on a handle of
        width w is about ``finger_kp * (squeeze + w / 2)``, up to ``grip_force``
    :param grip_force: force limit of each finger servo, N
    :param finger_damping: damping of each finger slide, N s/m: it caps the closing speed near
        ``grip_force / finger_damping`` (0.4 m/s, 1.6 mm per 4 ms physics step) without lowering the static
        grip force. At 2 N s/m (20 m/s) a pad crossed 18 mm in one step and landed inside a real drawer's
        round knob, whose hull then pushed it out along the pull
    :param pad_friction: sliding friction of the finger pads
    :param pad_solref: contact ``solref`` (time constant s, damping ratio) of the finger pads (they have
        contact priority, so theirs is used): MuJoCo scales a contact's softness with the light fingers'
        mass, and at its default (0.02 s) a 40 N grip sinks each pad 1-2 mm into what it holds: pads closing
        at 0.4 m/s on a 4 mm lip sank through it (synth StorageFurniture 4 and 7). Twice the physics step
        (MuJoCo's stiffest safe value) keeps it to about 0.5 mm
    :param wrist_stiffness: spring of the passive wrist hinge (doors), N m/rad
    :param wrist_damping: damping of the passive wrist hinge, N m s/rad
    :param wrist_range: the wrist hinge turns this far (rad) either way: a held handle turns with its door,
        and a door's task may ask for 75 % of a 180-degree range (135 degrees)
    :param rgba: display colour
    """

    finger_length: float = 0.05
    tip_beyond_tcp: float = 0.012
    max_opening: float = 0.045
    pad_height: float = 0.024
    pad_thickness: float = 0.012
    kp: float = 3000.0
    dampratio: float = 0.35
    force_limit: float = 150.0
    finger_kp: float = 1000.0
    squeeze: float = 0.025
    grip_force: float = 40.0
    finger_damping: float = 100.0
    pad_friction: float = 1.5
    pad_solref: tuple = (0.008, 1.0)  # 2 x the scene's 4 ms step
    wrist_stiffness: float = 0.3
    wrist_damping: float = 0.3
    wrist_range: float = 3.0
    rgba: tuple = (0.15, 0.35, 0.8, 1.0)


@dataclass
class GripperHandles:
    """Names of the gripper's elements in the compiled model (resolve ids with ``model.joint(name)``).

    :param slide_joints: x, y, z translation joints
    :param wrist_joint: the passive wrist hinge, or None
    :param finger_joints: left, right finger slides (0 = closed)
    :param slide_actuators: x, y, z position actuators
    :param finger_actuators: left, right finger actuators
    :param hand_body: the body whose frame is the TCP
    :param finger_bodies: left, right finger bodies
    :param touch_sensors: left, right pad touch sensors
    """

    slide_joints: tuple[str, str, str]
    wrist_joint: str | None
    finger_joints: tuple[str, str]
    slide_actuators: tuple[str, str, str]
    finger_actuators: tuple[str, str]
    hand_body: str
    finger_bodies: tuple[str, str]
    touch_sensors: tuple[str, str]
    config: GripperConfig = field(default_factory=GripperConfig)


def hand_rotation(approach: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """The hand's 3x3 rotation from its approach (x) and closing (y) directions, orthonormalized."""
    x = np.asarray(approach, float)
    x = x / np.linalg.norm(x)
    y = np.asarray(closing, float) - np.dot(closing, x) * x
    if np.linalg.norm(y) < 1e-6:  # closing parallel to approach: any perpendicular will do
        y = np.cross(x, [0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.cross(x, [0.0, 1.0, 0.0])
    y = y / np.linalg.norm(y)
    return np.stack([x, y, np.cross(x, y)], axis=1)


def rotation_quat(rotation: np.ndarray) -> np.ndarray:
    """MuJoCo's quaternion (w, x, y, z) of a 3x3 rotation."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).reshape(-1))
    return quat


def add_carriage(spec: mujoco.MjSpec, workspace: np.ndarray, cfg) -> tuple:
    """The gravity-compensated carriage every end-effector rides on: three world-aligned slides, each with a
    position servo (``cfg.kp``, ``cfg.dampratio``, ``cfg.force_limit``). Returns it, the slide joints' names
    and the servos' names.

    :param spec: the scene
    :param workspace: ``[[min], [max]]`` world box the TCP may reach (the slides' ranges)
    :param cfg: the end-effector's config (:class:`GripperConfig`, or the suction cup's)
    """
    carriage = spec.worldbody.add_body(name=f"{PREFIX}_carriage", gravcomp=1.0)
    carriage.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0, 0], mass=0.5,
                      contype=0, conaffinity=0, group=3)
    slides, servos = [], []
    for i, axis_name in enumerate("xyz"):
        name = f"{PREFIX}_slide_{axis_name}"
        carriage.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=np.eye(3)[i], limited=True,
                           range=[float(workspace[0, i]), float(workspace[1, i])], armature=0.01)
        act = spec.add_actuator(name=f"{name}_servo", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=cfg.kp, dampratio=cfg.dampratio)
        act.ctrlrange = [float(workspace[0, i]), float(workspace[1, i])]
        act.forcerange = [-cfg.force_limit, cfg.force_limit]
        act.forcelimited = True
        slides.append(name)
        servos.append(act.name)
    return carriage, slides, servos


def add_wrist(hand, rotation: np.ndarray, wrist_axis: np.ndarray | None, cfg) -> str | None:
    """A passive wrist hinge on ``hand`` about the world axis ``wrist_axis`` (None: a rigid wrist, no joint);
    returns its name.

    :param hand: the hand body (its frame turned by ``rotation``)
    :param rotation: the hand's rotation in the world
    :param wrist_axis: world axis of the hinge, or None
    :param cfg: the end-effector's config (``wrist_stiffness``, ``wrist_damping``, ``wrist_range``)
    """
    if wrist_axis is None:
        return None
    wrist = f"{PREFIX}_wrist"
    hand.add_joint(name=wrist, type=mujoco.mjtJoint.mjJNT_HINGE, axis=rotation.T @ np.asarray(wrist_axis, float),
                   stiffness=cfg.wrist_stiffness, damping=cfg.wrist_damping, limited=True,
                   range=[-cfg.wrist_range, cfg.wrist_range], armature=0.002)
    return wrist


def add_gripper(spec: mujoco.MjSpec, approach: np.ndarray, closing: np.ndarray,
                wrist_axis: np.ndarray | None = None, workspace: np.ndarray | None = None,
                config: GripperConfig | None = None) -> GripperHandles:
    """Add the floating gripper to ``spec`` (in place) and return the names of its parts.

    :param spec: the scene; the gripper's bodies are children of its world body
    :param approach: world direction from palm to fingertips (towards the object)
    :param closing: world direction along which the fingers close (across the handle)
    :param wrist_axis: world axis of a passive wrist hinge through the TCP, or None for a rigid wrist
    :param workspace: ``[[min], [max]]`` world box the TCP may reach (the slide joints' ranges)
    :param config: dimensions and gains
    """
    cfg = config or GripperConfig()
    rotation = hand_rotation(approach, closing)
    if workspace is None:
        workspace = np.array([[-2.0] * 3, [2.0] * 3])
    p = PREFIX
    carriage, slides, slide_acts = add_carriage(spec, workspace, cfg)
    hand = carriage.add_body(name=f"{p}_hand", quat=rotation_quat(rotation), gravcomp=1.0)
    wrist = add_wrist(hand, rotation, wrist_axis, cfg)
    color = list(cfg.rgba)
    length, tip = cfg.finger_length, cfg.tip_beyond_tcp
    palm_x = tip - length - 0.012
    hand.add_geom(name=f"{p}_palm", type=mujoco.mjtGeom.mjGEOM_BOX, pos=[palm_x, 0, 0],
                  size=[0.012, cfg.max_opening + 0.015, 0.02], mass=0.4, rgba=color, contype=2, conaffinity=1)
    hand.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=[palm_x - 0.06, 0, 0], size=[0.015, 0.05, 0],
                  quat=rotation_quat(hand_rotation([0, 0, 1], [0, 1, 0])), mass=0.2, rgba=color, contype=0,
                  conaffinity=0)
    fingers, finger_joints, finger_acts, sensors = [], [], [], []
    pad_half = cfg.pad_thickness / 2
    for side, sign in (("left", 1.0), ("right", -1.0)):
        body = hand.add_body(name=f"{p}_finger_{side}", gravcomp=1.0)
        joint = f"{p}_finger_{side}_slide"
        body.add_joint(name=joint, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, sign, 0], limited=True,
                       range=[0.0, cfg.max_opening], armature=0.001, damping=cfg.finger_damping)
        center = [tip - length / 2, sign * pad_half, 0]
        body.add_geom(name=f"{p}_pad_{side}", type=mujoco.mjtGeom.mjGEOM_BOX, pos=center,
                      size=[length / 2, pad_half, cfg.pad_height / 2], mass=0.05, rgba=color, contype=2, conaffinity=1,
                      friction=[cfg.pad_friction, 0.02, 0.001], condim=4, priority=1,
                      solref=list(cfg.pad_solref))
        body.add_site(name=f"{p}_pad_{side}_site", type=mujoco.mjtGeom.mjGEOM_BOX, pos=center,
                      size=[length / 2 + 0.002, pad_half + 0.002, cfg.pad_height / 2 + 0.002], rgba=[0, 0, 0, 0])
        sensor = spec.add_sensor(name=f"{p}_touch_{side}", type=mujoco.mjtSensor.mjSENS_TOUCH,
                                 objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"{p}_pad_{side}_site")
        act = spec.add_actuator(name=f"{joint}_servo", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=cfg.finger_kp, dampratio=1.0)
        act.ctrlrange = [-cfg.squeeze, cfg.max_opening]
        act.forcerange = [-cfg.grip_force, cfg.grip_force]
        act.forcelimited = True
        fingers.append(body.name)
        finger_joints.append(joint)
        finger_acts.append(act.name)
        sensors.append(sensor.name)
    return GripperHandles(slide_joints=tuple(slides), wrist_joint=wrist, finger_joints=tuple(finger_joints),
                          slide_actuators=tuple(slide_acts), finger_actuators=tuple(finger_acts),
                          hand_body=hand.name, finger_bodies=tuple(fingers), touch_sensors=tuple(sensors),
                          config=cfg)


def largest_pull(config: GripperConfig) -> float:
    """The largest steady force (N) the hand can exert on what it holds: each translation servo pulls at most
    ``kp * MAX_STEP`` (its target at most :data:`MAX_STEP` from the TCP), up to its force limit, and the
    three together at most sqrt(3) times that (along a diagonal)."""
    return float(np.sqrt(3.0) * min(config.kp * MAX_STEP, config.force_limit))


def pinch_hold(config: GripperConfig) -> float:
    """The force (N) a pinch holds along the fingers' closing direction: there one finger's servo alone
    holds the load (the pads' friction acts across that direction, not along it), pressing with
    ``finger_kp * squeeze`` on a thin handle (more on a thicker one), at most ``grip_force``."""
    return float(min(config.finger_kp * config.squeeze, config.grip_force))


def finger_target(config: GripperConfig, command: float) -> float:
    """Each finger's position target (m from closed) for a gripper command in [-1, 1]: -1 fully open,
    +1 :attr:`GripperConfig.squeeze` past closed (so a closed grip squeezes), linear between."""
    closed = -config.squeeze
    return closed + (config.max_opening - closed) * 0.5 * (1.0 - float(command))


def grip_command(config: GripperConfig, opening: float) -> float:
    """The gripper command that holds each finger ``opening`` (m) open: the inverse of
    :func:`finger_target`."""
    closed = -config.squeeze
    return float(1.0 - 2.0 * (opening - closed) / (config.max_opening - closed))
