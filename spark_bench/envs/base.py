"""The shared opening environment: a floating parallel-jaw gripper must open one joint of an object.

:class:`SparkArticulationEnv` holds everything; :mod:`spark_bench.envs.drawer` and
:mod:`spark_bench.envs.door` fix the joint kind and document the task.
"""

from __future__ import annotations

import math
from functools import lru_cache

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from spark_bench.asset.joint_type import JointType
from spark_bench.envs import observation as OBS
from spark_bench.envs.assets import AssetLike, asset_key, load_asset
from spark_bench.envs.observation import FRAME_OBS_SIZE, OBS_SIZE
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.manipulation.grasp_target import GraspTarget
from spark_bench.manipulation.gripper import MAX_STEP, finger_target, grip_command
from spark_bench.manipulation.scene import N_SUBSTEPS, TIMESTEP, Scene
from spark_bench.manipulation.task import build_scene
from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

#: Start distance of the TCP in front of the grasp point, m, and the uniform noise on each axis.
START_OFFSET = 0.10
START_NOISE = 0.03
#: The TCP counts as at the grasp point within this distance, m (for the grasp reward).
GRASP_RADIUS = 0.03
#: A finger touches when its pad's contact normal force exceeds this, N.
TOUCH_THRESHOLD = 0.5
#: Dense reward weights: reach, grasp, open progress, success; the sum is divided by their total.
REWARD_WEIGHTS = (1.0, 1.0, 2.0, 1.0)
#: Observation layouts (:mod:`spark_bench.envs.observation`; the environments' docstrings): ``basic``, and
#: ``frame`` (``basic`` followed by the grasp frame and the joint, what a policy needs to act on any asset).
OBSERVATIONS = ("basic", "frame")
JOINT_TYPES = (JointType.PRISMATIC, JointType.REVOLUTE, JointType.CONTINUOUS)
#: Every observation entry is clipped to [-OBS_BOUND, OBS_BOUND] (positions in m, velocities in m/s).
OBS_BOUND = 10.0
#: The success rules an environment can report as ``is_success`` (both are in every ``info``): ``spark``,
#: the joint past ``target_fraction`` of its range; ``maniskill``, ManiSkill3's: past it **and** the joint's
#: link nearly still (:data:`MANISKILL_MAX_ANGULAR_SPEED`, :data:`MANISKILL_MAX_LINEAR_SPEED`).
SUCCESS_RULES = ("spark", "maniskill")
#: ManiSkill3's stillness limits, from ``OpenCabinetDrawerEnv.evaluate`` in
#: ``mani_skill/envs/tasks/mobile_manipulation/open_cabinet_drawer.py`` (haosulab/ManiSkill @ 01ac4c4e; its
#: ``OpenCabinetDoorEnv`` inherits the rule): ``link_is_static`` = ``norm(handle_link.angular_velocity) <= 1``
#: and ``norm(handle_link.linear_velocity) <= 0.1``, the handle link being the link the target joint moves
#: and its velocities SAPIEN's rigid-body ones (world frame, the link's centre of mass); ``open_enough`` =
#: ``qpos >= qmin + (qmax - qmin) * min_open_frac`` with ``min_open_frac = 0.75`` (its docstring says 90 %,
#: its code 0.75), this environment's default ``target_fraction``. rad/s and m/s.
MANISKILL_MAX_ANGULAR_SPEED = 1.0
MANISKILL_MAX_LINEAR_SPEED = 0.1


@lru_cache(maxsize=16)
def _cached_scene(key: str, kind: str, joint: str | None, visuals: bool = True,
                  end_effector: str = "gripper") -> Scene:
    asset, _ = load_asset(key)
    return build_scene(asset, kind, joint, visuals=visuals, end_effector=end_effector)


def make_scene(asset: AssetLike, kind: str, joint: str | None, visuals: bool = True,
               end_effector: str = "gripper", grasp: GraspTarget | None = None) -> Scene:
    """The compiled scene, cached per (asset, kind, joint, visuals, end-effector) for assets given by name, so
    that the copies of a vectorized environment share one model; a scene for a grasp planned by the caller
    is compiled for it, uncached.

    :param visuals: compile the visual meshes; an environment that never renders leaves them out (the
        physics is the same: visual geoms have no contacts and no mass) and a real object's scene then
        compiles about 7 s faster per joint
    :param end_effector: ``gripper``, ``suction`` or ``auto`` (:func:`~spark_bench.manipulation.task.build_scene`)
    :param grasp: the gripper's grasp on the joint's part, planned already (None: planned with the scene)
    """
    key = asset_key(asset)
    if key is None:
        return build_scene(asset, kind, joint, visuals=visuals, end_effector=end_effector, grasp=grasp)
    if grasp is not None:  # compiled for the caller's plan: not shared
        return build_scene(load_asset(key)[0], kind, joint, visuals=visuals, end_effector=end_effector, grasp=grasp)
    return _cached_scene(key, kind, joint, visuals, end_effector)


class SparkArticulationEnv(gym.Env):
    """Open one joint of an articulated object with a floating parallel-jaw gripper.

    See :class:`~spark_bench.envs.drawer.SparkDrawerEnv` and :class:`~spark_bench.envs.door.SparkDoorEnv`
    for the task's documentation.

    :param asset: an object folder, URDF file, benchmark case folder, an ArticulatedAsset, or None for
        the default cabinet
    :param joint: the joint to open (default: the first of the task's kind)
    :param target_fraction: success when the joint passes this fraction of its range
    :param reward_type: ``dense`` or ``sparse``
    :param render_mode: None or ``rgb_array``
    :param width: rendered image width, pixels
    :param height: rendered image height, pixels
    :param seed: seeds the start-state noise (same as the first ``reset(seed=...)``)
    :param observation: ``basic`` (19 entries) or ``frame`` (37: the grasp frame and the joint follow)
    :param joint_estimate: ``(axis, pivot, type)``, world frame at rest: the joint the ``frame``
        observation reports instead of the simulated one's (a prediction's joint, acting on the real object)
    :param end_effector: ``gripper`` (the parallel gripper, the default), ``suction`` (a suction cup on the
        part's front face, :mod:`spark_bench.manipulation.suction`) or ``auto`` (the cup where the grasp planner finds
        nothing to pinch, the gripper everywhere else); the one chosen is ``self.end_effector`` and every
        step's ``info["end_effector"]``
    :param success_rule: what ``info["is_success"]``, the ``success`` reward term and the sparse reward follow
        (:data:`SUCCESS_RULES`): ``spark`` (the default: the joint past ``target_fraction``) or ``maniskill``
        (ManiSkill3's: past it and the joint's link nearly still, :meth:`evaluate`); every ``info`` carries
        both as ``is_success_spark`` and ``is_success_maniskill``
    :param grasp: the gripper's grasp on ``joint``'s part as the caller planned it
        (:func:`~spark_bench.manipulation.scene.plan_grasp` of the loaded asset and the joint: the opening
        score's judge plans it once and hands it on), or None (the default: planned with the scene)
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": int(round(1.0 / (N_SUBSTEPS * TIMESTEP)))}
    joint_kind = "prismatic"

    def __init__(self, asset: AssetLike = None, joint: str | None = None, target_fraction: float = 0.75,
                 reward_type: str = "dense", render_mode: str | None = None, width: int = 480,
                 height: int = 360, seed: int | None = None, observation: str = "basic",
                 joint_estimate: tuple | None = None, end_effector: str = "gripper", success_rule: str = "spark",
                 grasp: GraspTarget | None = None):
        if not 0.0 < target_fraction <= 1.0:
            raise ValueError(f"target_fraction must be in (0, 1], got {target_fraction}")
        if reward_type not in ("dense", "sparse"):
            raise ValueError(f"reward_type must be 'dense' or 'sparse', got {reward_type!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation must be one of {OBSERVATIONS}, got {observation!r}")
        if success_rule not in SUCCESS_RULES:
            raise ValueError(f"success_rule must be one of {SUCCESS_RULES}, got {success_rule!r}")
        self.success_rule = success_rule
        self.scene = make_scene(asset, self.joint_kind, joint, visuals=render_mode is not None,
                                end_effector=end_effector, grasp=grasp)
        self.end_effector = self.scene.end_effector
        self._suction = self.end_effector == EndEffector.SUCTION
        self.observation = observation
        self.target_fraction = float(target_fraction)
        self.reward_type = reward_type
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)
        self.model = self.scene.model
        self.data = mujoco.MjData(self.model)
        self._renderer = None
        self._index()
        self._index_frame(joint_estimate)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)
        size = FRAME_OBS_SIZE if observation == "frame" else OBS_SIZE
        self.observation_space = spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(size,), dtype=np.float32)
        self._seed = seed

    # ----- indices ---------------------------------------------------------------------------
    def _index(self) -> None:
        m, g = self.model, self.scene.gripper
        qadr = [m.jnt_qposadr[m.joint(n).id] for n in g.slide_joints]
        vadr = [m.jnt_dofadr[m.joint(n).id] for n in g.slide_joints]
        self._tcp_q = slice(qadr[0], qadr[0] + 3)
        self._tcp_v = slice(vadr[0], vadr[0] + 3)
        assert qadr == list(range(qadr[0], qadr[0] + 3)) and vadr == list(range(vadr[0], vadr[0] + 3))
        self._wrist_q = m.jnt_qposadr[m.joint(g.wrist_joint).id] if g.wrist_joint else None
        act = [m.actuator(n).id for n in g.slide_actuators]
        self._act_tcp = slice(act[0], act[0] + 3)
        assert act == list(range(act[0], act[0] + 3))
        if self._suction:  # one cup: its touch reading fills both pads' entries
            self._finger_q = np.zeros(0, dtype=int)
            self._act_fingers = np.zeros(0, dtype=int)
            self._act_suction = m.actuator(g.suction_actuator).id
            self._touch = np.repeat(m.sensor_adr[m.sensor(g.touch_sensor).id], 2)
        else:
            self._finger_q = np.array([m.jnt_qposadr[m.joint(n).id] for n in g.finger_joints])
            self._act_fingers = np.array([m.actuator(n).id for n in g.finger_actuators])
            self._touch = np.array([m.sensor_adr[m.sensor(n).id] for n in g.touch_sensors])
        jid = m.joint(self.scene.joint.name).id
        self._joint_q, self._joint_v = m.jnt_qposadr[jid], m.jnt_dofadr[jid]
        self._link = int(m.jnt_bodyid[jid])  # ManiSkill's "handle link": the body the joint moves
        self._rest, self._open = self.scene.joint_range
        self._span = self._open - self._rest
        self._body = m.body(self.scene.grasp_body).id
        self._local = self.scene.grasp_local.copy()
        self._gripper_config = g.config
        self._max_opening = None if self._suction else g.config.max_opening
        self._low, self._high = self.scene.workspace[0], self.scene.workspace[1]

    def _index_frame(self, joint_estimate: tuple | None) -> None:
        """The grasp frame in the part's body frame, and the joint the ``frame`` observation reports."""
        scene, d = self.scene, self.data
        d.qpos[:] = scene.rest_qpos
        mujoco.mj_kinematics(self.model, d)
        to_body = d.xmat[self._body].reshape(3, 3).T  # world -> the part's frame, at rest
        grasp = scene.grasp
        self._outward_local = to_body @ grasp.outward
        self._closing_local = to_body @ grasp.closing
        self._press_local = to_body @ grasp.press if grasp.inside_grip else np.zeros(3)
        if self._suction:
            self._approach_grip = -1.0  # the cup comes in released and sucks once on the face
        elif grasp.inside_grip:
            self._approach_grip = 1.0  # closed: the fingers enter the notch, then open against its sides
        elif grasp.opening is not None:
            self._approach_grip = grip_command(self._gripper_config, grasp.opening)
        else:
            self._approach_grip = -1.0
        if joint_estimate is None:
            pivot, axis = scene.asset.joint_frames()[scene.joint.name]
            joint_type = scene.joint.type
        else:
            axis, pivot, joint_type = joint_estimate
        axis, pivot = np.asarray(axis, dtype=np.float64), np.asarray(pivot, dtype=np.float64)
        norm = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
        if not (norm > 1e-9 and np.isfinite(norm) and pivot.shape == (3,) and np.all(np.isfinite(pivot))):
            raise ValueError(f"joint_estimate needs a non-zero finite 3-vector axis and a finite 3-vector pivot, "
                             f"got {axis!r}, {pivot!r}")
        if joint_type not in JOINT_TYPES:
            raise ValueError(f"joint_estimate type must be one of {JOINT_TYPES}, got {joint_type!r}")
        self.joint_estimate = (axis / norm, pivot, str(joint_type))
        self._frame = self.observation == "frame"

    # ----- state -----------------------------------------------------------------------------
    @property
    def tcp(self) -> np.ndarray:
        """The TCP's world position."""
        return self.data.qpos[self._tcp_q].copy()

    @property
    def grasp_point(self) -> np.ndarray:
        """The grasp point's world position (it moves with the part)."""
        return self.data.xpos[self._body] + self.data.xmat[self._body].reshape(3, 3) @ self._local

    @property
    def joint_fraction(self) -> float:
        """The joint's position as a fraction of its range (0 rest, 1 fully open)."""
        return float((self.data.qpos[self._joint_q] - self._rest) / self._span)

    def _touching(self) -> np.ndarray:
        return self.data.sensordata[self._touch] > TOUCH_THRESHOLD

    def _obs(self) -> np.ndarray:
        d = self.data
        tcp = d.qpos[self._tcp_q]
        grasp = self.grasp_point
        out = np.empty(FRAME_OBS_SIZE if self._frame else OBS_SIZE, dtype=np.float32)
        out[OBS.TCP] = tcp
        out[OBS.WRIST] = d.qpos[self._wrist_q] if self._wrist_q is not None else 0.0
        if self._suction:
            out[OBS.SUCTION] = d.ctrl[self._act_suction]
        else:
            out[OBS.FINGERS] = (d.qpos[self._finger_q[0]] + d.qpos[self._finger_q[1]]) / (2 * self._max_opening)
        out[OBS.TCP_VELOCITY] = d.qvel[self._tcp_v]
        out[OBS.GRASP] = grasp
        out[OBS.TO_GRASP] = grasp - tcp
        out[OBS.JOINT_FRACTION] = (d.qpos[self._joint_q] - self._rest) / self._span
        out[OBS.JOINT_VELOCITY] = d.qvel[self._joint_v] / self._span
        out[OBS.TOUCH] = np.minimum(d.sensordata[self._touch] / 10.0, 1.0)
        out[OBS.GRASP_DISTANCE] = np.linalg.norm(out[OBS.TO_GRASP])
        if self._frame:
            self._frame_obs(out, grasp)
        np.clip(out, -OBS_BOUND, OBS_BOUND, out=out)
        return out

    def _frame_obs(self, out: np.ndarray, grasp: np.ndarray) -> None:
        """The ``frame`` entries: the grasp frame (turned with the part) and the reported joint."""
        rot = self.data.xmat[self._body].reshape(3, 3)
        axis, pivot, joint_type = self.joint_estimate
        out[OBS.OUTWARD] = rot @ self._outward_local
        out[OBS.CLOSING] = rot @ self._closing_local
        out[OBS.AXIS] = axis
        if joint_type == JointType.PRISMATIC:
            out[OBS.TO_AXIS] = 0.0
            out[OBS.REVOLUTE] = 0.0
        else:
            v = pivot - grasp
            out[OBS.TO_AXIS] = v - (v @ axis) * axis
            out[OBS.REVOLUTE] = 1.0
        out[OBS.INSIDE_GRIP] = 1.0 if self.scene.grasp.inside_grip else 0.0
        out[OBS.APPROACH_GRIP] = self._approach_grip
        out[OBS.PRESS] = rot @ self._press_local

    def link_speeds(self) -> tuple[float, float]:
        """``(angular, linear)``: the speeds (rad/s, m/s) of the body the joint moves, at its centre of mass in
        the world frame (what ManiSkill3's stillness test reads from SAPIEN), from the last computed
        kinematics (after a step, those of its last physics substep's start, 4 ms earlier)."""
        velocity = np.empty(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_BODY, self._link, velocity, 0)
        return math.hypot(*velocity[:3]), math.hypot(*velocity[3:])  # hypot: np.linalg.norm costs 3 us

    def evaluate(self) -> dict[str, bool | float]:
        """Both success rules at the current state: ``is_success_spark`` (the joint past ``target_fraction``
        of its range), ``is_success_maniskill`` (ManiSkill3's ``OpenCabinetDrawerEnv.evaluate``: past it and
        the joint's link at most :data:`MANISKILL_MAX_ANGULAR_SPEED` rad/s and :data:`MANISKILL_MAX_LINEAR_SPEED`
        m/s, :meth:`link_speeds`), and the speeds themselves (``link_angular_speed``, ``link_linear_speed``).
        """
        fraction = np.float32((self.data.qpos[self._joint_q] - self._rest) / self._span)  # as the observation
        return self._rules(bool(fraction >= self.target_fraction))

    def _rules(self, spark: bool) -> dict[str, bool | float]:
        """:meth:`evaluate`'s entries, given whether the joint is past ``target_fraction``."""
        angular, linear = self.link_speeds()
        still = angular <= MANISKILL_MAX_ANGULAR_SPEED and linear <= MANISKILL_MAX_LINEAR_SPEED
        return {"is_success_spark": spark, "is_success_maniskill": spark and still,
                "link_angular_speed": angular, "link_linear_speed": linear}

    def _reward_terms(self, obs: np.ndarray) -> dict[str, float]:
        dist = float(obs[OBS.GRASP_DISTANCE])
        reach = 1.0 - np.tanh(10.0 * dist)
        grasped = float(dist < GRASP_RADIUS and bool(np.all(self._touching())))
        fraction = obs[OBS.JOINT_FRACTION]
        progress = float(min(max(fraction / self.target_fraction, 0.0), 1.0))  # np.clip costs 3 us on a scalar
        success = float(fraction >= self.target_fraction)
        terms = {"reach": float(reach), "grasp": grasped, "progress": progress, "success": success}
        rules = self._rules(bool(success))
        if self.success_rule == "maniskill":
            terms["success"] = float(rules["is_success_maniskill"])
        terms.update(rules)
        return terms

    def _reward(self, terms: dict[str, float]) -> float:
        if self.reward_type == "sparse":
            return terms["success"]
        w = REWARD_WEIGHTS
        total = w[0] * terms["reach"] + w[1] * terms["grasp"] + w[2] * terms["progress"] + w[3] * terms["success"]
        return float(total / sum(w))

    # ----- gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is None and self._seed is not None:
            seed, self._seed = self._seed, None
        super().reset(seed=seed)
        d = self.data
        mujoco.mj_resetData(self.model, d)
        d.qpos[:] = self.scene.rest_qpos
        start = self.scene.grasp.point + START_OFFSET * self.scene.grasp.outward
        start = start + self.np_random.uniform(-START_NOISE, START_NOISE, size=3)
        start = np.clip(start, self._low, self._high)
        d.qpos[self._tcp_q] = start
        d.ctrl[self._act_tcp] = start
        if not self._suction:  # the cup starts released: mj_resetData zeroed its control
            d.qpos[self._finger_q] = self._max_opening
            d.ctrl[self._act_fingers] = self._max_opening
        mujoco.mj_forward(self.model, d)
        obs = self._obs()
        info = self._reward_terms(obs)
        info["is_success"] = bool(info["success"])
        info["end_effector"] = self.end_effector
        return obs, info

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        d = self.data
        d.ctrl[self._act_tcp] = np.clip(d.qpos[self._tcp_q] + MAX_STEP * a[:3], self._low, self._high)
        if self._suction:  # a[3] > 0 sucks with that fraction of the cup's holding force, <= 0 releases
            d.ctrl[self._act_suction] = min(max(a[3], 0.0), 1.0)
        else:
            d.ctrl[self._act_fingers] = finger_target(self._gripper_config, a[3])
        mujoco.mj_step(self.model, d, nstep=N_SUBSTEPS)
        obs = self._obs()
        terms = self._reward_terms(obs)
        reward = self._reward(terms)
        terms["is_success"] = bool(terms["success"])
        terms["end_effector"] = self.end_effector
        if not np.all(np.isfinite(obs)):  # diverged physics: end the episode rather than feed NaNs
            obs = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
            return obs, 0.0, True, False, terms
        return obs, reward, False, False, terms

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, self.height, self.width)
            self._camera = mujoco.MjvCamera()
            box = self.scene.workspace
            self._camera.lookat[:] = 0.5 * (box[0] + box[1])
            self._camera.distance = 1.25 * float(np.max(box[1] - box[0]))
            self._camera.azimuth, self._camera.elevation = 30.0, -22.0  # from the front (-X), left, above
        self._renderer.update_scene(self.data, camera=self._camera)
        return self._renderer.render()

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
