"""The generalist opening policies: one per environment (drawer, door), trained on many synth objects
(``spark-bench train-generalist``, :mod:`spark_bench.rl.generalist_recipe`) and shipped with the package (``spark_bench/rl/weights/``).

**End-effectors.** Each policy drives either end-effector of the environments: the parallel gripper, or the
suction cup (:mod:`spark_bench.manipulation.suction`) on a part the grasp planner finds nothing to pinch on. Which
one is the environment's (made with ``end_effector="auto"`` by :func:`make_task_env`: the rule of the
scripted opening score, :func:`spark_bench.manipulation.suction.choose_end_effector`); the policy is told by
feature 39. The cup's state lies where the fingers' does (:mod:`spark_bench.envs.observation`): entry 7
is its suction command, 10-11 its contact force (both), 23 is -1 (approach released); its action's last
entry is the suction command (> 0 sucks) where the gripper's is the finger command.

**Observation.** A policy sees what any asset can supply: the environment's ``frame`` observation
(:mod:`spark_bench.envs.observation`: the gripper's state, the grasp point, the grasp frame and the joint),
expressed in the *joint frame* at the grasp point (:func:`policy_frames`: x the direction the grasp point
moves as the told joint opens, the joint's axis for a drawer or the tangent of its arc for a door; y the
fingers' closing direction made perpendicular to x; z the third), so one policy serves objects of any
size, place and orientation (:func:`features`, :data:`N_FEATURES` entries):

====== ============================================================================
index  meaning (joint frame)
====== ============================================================================
0-2    TCP minus grasp point, / 0.1 m
3-5    TCP velocity, / 0.5 m/s
6      wrist angle (rad)
7      finger opening (0 closed, 1 fully open); cup: the suction command (0 off, 1 full)
8      joint position as a fraction of its range
9      joint velocity / range
10-11  finger pad contact forces / 10 N, clipped to 1; cup: its contact force, in both
12-14  joint axis
15-17  outward: out of the part's front at the grasp (turns with the part)
18-20  from the grasp point to the joint axis (m; 0 for prismatic)
21     1 revolute, 0 prismatic
22     1 inside grip (a notch), else 0
23     the finger command to approach with
24-26  inside grip: the press direction towards the notch's inner wall
27     TCP to grasp point distance, / 0.1 m
28-30  TCP minus grasp point, / 0.02 m, clipped to +-3 (fine position near the handle)
31     steps in a row with the TCP within 0.015 m of the grasp point, / 10
32     steps in a row with both finger pads touching, / 10
33     steps in a row with the TCP slower than 0.02 m/s (stalled), / 10
34     steps since the episode began, / :data:`EPISODE_STEPS`
35-38  the previous action (joint frame; 0 at the start)
39     1 the suction cup, 0 the parallel gripper (:func:`end_effector_flag`)
====== ============================================================================

Entries 31-38 are the policy's memory (:class:`Memory`): when to close, press or pull depends on how long
the gripper has been at the handle and holding it (the cup: on the face, touching it), which one
observation cannot tell.

The joint entries (12-21) are the *reported* joint: the simulated asset's own, or a prediction's when the
environment was made with ``joint_estimate`` (acting on the real object with a predicted joint).

**Why the joint frame, and noise on the grasp frame.** On nearly every training object a part opens
straight out of its front, so a policy could pull along the handle's outward direction and ignore the
joint it is told: it would score a prediction's joint not at all. In the joint frame, opening is "+x"
whatever the object; and while training, each episode sees the observed grasp frame (outward, closing)
turned by a random rotation of up to :data:`FRAME_NOISE` rad (:func:`perturb_frame`), so the outward
direction is a worse cue than x. The policy pulls where the told joint says: a wrong predicted joint
misleads it as it misleads a robot acting on the prediction.

**Action.** ``a[0:3]`` moves the TCP by ``0.02 * a[0:3]`` m *in the joint frame* (turned into the world
frame, then clipped per axis as the environment does); ``a[3]`` commands the fingers, or the cup's
suction, as in the environments.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from spark_bench.envs import observation as OBS
from spark_bench.envs.observation import FRAME_OBS_SIZE
from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, make_env
from spark_bench.errors import InputError
from spark_bench.manipulation.end_effector import EndEffector

#: Bumped whenever :func:`features` or the action's meaning changes (shipped weights name the version
#: they were trained for).
FEATURE_VERSION = 3
N_FEATURES = 40
N_MEMORY = 8
#: Feature 39: which end-effector the policy drives (:func:`end_effector_flag`).
END_EFFECTOR_FEATURE = 39
FEATURE_BOUND = 10.0
#: Environment per policy kind, and the kind that opens a joint type.
KINDS = {"drawer": ENV_OF_JOINT_TYPE["prismatic"], "door": ENV_OF_JOINT_TYPE["revolute"]}
KIND_OF_TYPE = {"prismatic": "drawer", "revolute": "door", "continuous": "door"}
#: Time limit of an episode (control steps, 25 Hz): long enough for a 0.8 m door arc after the approach.
EPISODE_STEPS = 150
WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
#: The record of the run that produced the shipped weights (settings, wall time, success rates).
RECORD_NAME = "generalist.json"
POSITION_SCALE = 0.1
FINE_SCALE = 0.02
VELOCITY_SCALE = 0.5
#: The TCP counts as at the handle within this distance (m); a pad touches above this observed force (/10 N).
NEAR_RADIUS = 0.015
TOUCH_OBS = 0.05
STALL_SPEED = 0.02
#: Largest turn (rad) of the grasp frame during training (:func:`perturb_frame`).
FRAME_NOISE = 0.5


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def opening_directions(obs: np.ndarray) -> np.ndarray:
    """The direction(s) the grasp point moves as the told joint opens (world): the axis of a prismatic
    joint, ``axis x (grasp - hinge)`` of a revolute one (the outward direction if the grasp point lies on
    the hinge)."""
    obs = np.asarray(obs, dtype=np.float64)
    axis, to_axis = obs[..., OBS.AXIS], obs[..., OBS.TO_AXIS]
    radius = np.linalg.norm(to_axis, axis=-1, keepdims=True)
    swing = np.where(radius > 1e-6, np.cross(axis, -to_axis) / np.maximum(radius, 1e-9), obs[..., OBS.OUTWARD])
    return _unit(np.where(obs[..., OBS.REVOLUTE, None] > 0.5, swing, axis))


def policy_frames(obs: np.ndarray) -> np.ndarray:
    """The joint frame(s) of ``frame`` observation(s) (see the module docstring): ``(..., 3, 3)``
    rotations whose columns are x (the opening direction), y (the closing direction made perpendicular
    to x; the outward direction where closing runs along x) and z = x cross y, world frame."""
    obs = np.asarray(obs, dtype=np.float64)
    x = opening_directions(obs)
    closing, outward = _unit(obs[..., OBS.CLOSING]), _unit(obs[..., OBS.OUTWARD])
    along = np.abs(np.sum(closing * x, axis=-1, keepdims=True)) > 0.9
    y = np.where(along, outward, closing)
    y = y - np.sum(y * x, axis=-1, keepdims=True) * x
    spare = np.cross(x, [0.0, 0.0, 1.0])  # any perpendicular, where the observation gives none
    spare = np.where(np.linalg.norm(spare, axis=-1, keepdims=True) < 1e-3, np.cross(x, [1.0, 0.0, 0.0]), spare)
    y = _unit(np.where(np.linalg.norm(y, axis=-1, keepdims=True) < 1e-6, spare, y))
    return np.stack([x, y, np.cross(x, y)], axis=-1)


class Memory:
    """The policy's memory of its episode (features 31-38): steps at the handle, steps holding it, steps
    stalled, steps so far, the previous action. Call :meth:`reset` with the first observation, :meth:`step` with each
    action and the observation it led to."""

    def __init__(self):
        self.near = self.grip = self.stall = self.t = 0
        self.previous = np.zeros(4)

    def _observe(self, obs: np.ndarray) -> None:
        touch = obs[OBS.TOUCH]
        self.near = self.near + 1 if obs[OBS.GRASP_DISTANCE] < NEAR_RADIUS else 0
        self.grip = self.grip + 1 if touch[0] > TOUCH_OBS and touch[1] > TOUCH_OBS else 0
        self.stall = self.stall + 1 if float(np.linalg.norm(obs[OBS.TCP_VELOCITY])) < STALL_SPEED else 0

    def reset(self, obs: np.ndarray) -> None:
        self.near = self.grip = self.stall = self.t = 0
        self.previous = np.zeros(4)
        self._observe(obs)

    def step(self, action: np.ndarray, obs: np.ndarray) -> None:
        """Remember ``action`` (joint frame) and the observation it led to."""
        self.t += 1
        self.previous = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        self._observe(obs)

    def vector(self) -> np.ndarray:
        counts = [self.near / 10.0, self.grip / 10.0, self.stall / 10.0, self.t / EPISODE_STEPS]
        return np.concatenate([counts, self.previous])


def random_rotation(rng: np.random.Generator, max_angle: float) -> np.ndarray:
    """A rotation about a uniformly random axis by an angle uniform in ``[0, max_angle]``."""
    axis = rng.normal(size=3)
    axis /= max(float(np.linalg.norm(axis)), 1e-12)
    angle = float(rng.uniform(0.0, max_angle))
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def perturb_frame(obs: np.ndarray, rotation: np.ndarray | None) -> np.ndarray:
    """``obs`` with its grasp frame (outward, closing) turned by ``rotation`` (world frame); None: as is."""
    if rotation is None:
        return obs
    out = np.array(obs, dtype=np.float32, copy=True)
    out[OBS.OUTWARD] = rotation @ obs[OBS.OUTWARD]
    out[OBS.CLOSING] = rotation @ obs[OBS.CLOSING]
    return out


def end_effector_flag(env: gym.Env) -> float:
    """Feature 39 for the environment ``env`` (wrapped or not): 1.0 where it carries the suction cup, 0.0
    for the parallel gripper (an environment that does not say has the gripper).

    :param env: an opening environment
    """
    return 1.0 if getattr(env.unwrapped, "end_effector", "gripper") == EndEffector.SUCTION else 0.0


def features(obs: np.ndarray, memory: np.ndarray | None = None, suction: float = 0.0) -> np.ndarray:
    """The policy's input (see the module docstring) from ``frame`` observation(s) ``(..., 37)``.

    :param memory: :meth:`Memory.vector` (``(..., 8)``); None: zeros
    :param suction: 1.0 the observation is the suction cup's, 0.0 the gripper's (:func:`end_effector_flag`;
        the observation's layout is the same for both, it cannot tell)

    :raises ValueError: for an observation of another size (an environment made without
        ``observation="frame"``)
    """
    obs = np.asarray(obs, dtype=np.float64)
    if obs.shape[-1] != FRAME_OBS_SIZE:
        raise ValueError(f"the generalist needs the environment's 'frame' observation ({FRAME_OBS_SIZE} entries), "
                         f"got {obs.shape[-1]}: make the environment with observation='frame'")
    rot = policy_frames(obs)

    def local(v: np.ndarray) -> np.ndarray:  # world vectors into the joint frame: R^T v
        return np.einsum("...ji,...j->...i", rot, v)

    axis, to_axis = obs[..., OBS.AXIS], obs[..., OBS.TO_AXIS]
    out = np.concatenate([
        local(-obs[..., OBS.TO_GRASP]) / POSITION_SCALE,
        local(obs[..., OBS.TCP_VELOCITY]) / VELOCITY_SCALE,
        obs[..., [OBS.WRIST, OBS.FINGERS, OBS.JOINT_FRACTION, OBS.JOINT_VELOCITY]], obs[..., OBS.TOUCH],
        local(axis), local(obs[..., OBS.OUTWARD]), local(to_axis),
        obs[..., [OBS.REVOLUTE, OBS.INSIDE_GRIP, OBS.APPROACH_GRIP]], local(obs[..., OBS.PRESS]),
        obs[..., [OBS.GRASP_DISTANCE]] / POSITION_SCALE,
        np.clip(local(-obs[..., OBS.TO_GRASP]) / FINE_SCALE, -3.0, 3.0),
        np.broadcast_to(np.zeros(N_MEMORY) if memory is None else memory, obs.shape[:-1] + (N_MEMORY,)),
        np.full(obs.shape[:-1] + (1,), float(suction)),
    ], axis=-1)
    return np.clip(out, -FEATURE_BOUND, FEATURE_BOUND).astype(np.float32)


def to_world(obs: np.ndarray, action: np.ndarray) -> np.ndarray:
    """An action in the joint frame of ``obs`` as the environment's (world-frame) action, clipped to its
    box."""
    action = np.asarray(action, dtype=np.float64)
    out = np.empty(4, dtype=np.float32)
    out[:3] = np.clip(policy_frames(obs) @ np.clip(action[:3], -1.0, 1.0), -1.0, 1.0)
    out[3] = np.clip(action[3], -1.0, 1.0)
    return out


def to_frame(obs: np.ndarray, action: np.ndarray) -> np.ndarray:
    """A world-frame environment action as a joint-frame action (clipped to the box): the inverse of
    :func:`to_world` where neither clips."""
    action = np.asarray(action, dtype=np.float64)
    out = np.empty(4, dtype=np.float32)
    out[:3] = np.clip(policy_frames(obs).T @ action[:3], -1.0, 1.0)
    out[3] = np.clip(action[3], -1.0, 1.0)
    return out


class GraspFrameWrapper(gym.Wrapper):
    """An environment made with ``observation="frame"``, seen as the generalist sees it: observations are
    :func:`features` (with the environment's end-effector, :func:`end_effector_flag`), actions are in the
    joint frame. The raw observation (with the turned grasp frame, when training) is kept in ``raw_obs``.

    :param frame_noise: turn the grasp frame by a random rotation of up to this angle (rad) each episode
        (training only, :func:`perturb_frame`); 0: none
    """

    def __init__(self, env: gym.Env, frame_noise: float = 0.0):
        super().__init__(env)
        if env.observation_space.shape != (FRAME_OBS_SIZE,):
            raise ValueError("GraspFrameWrapper needs an environment made with observation='frame'")
        self.observation_space = spaces.Box(-FEATURE_BOUND, FEATURE_BOUND, shape=(N_FEATURES,), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)
        self.raw_obs: np.ndarray | None = None
        self.memory = Memory()
        self.frame_noise = float(frame_noise)
        self.rotation: np.ndarray | None = None
        self.suction = end_effector_flag(env)

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        if self.frame_noise > 0:
            self.rotation = random_rotation(self.env.unwrapped.np_random, self.frame_noise)
        self.raw_obs = perturb_frame(obs, self.rotation)
        self.memory.reset(self.raw_obs)
        return features(self.raw_obs, self.memory.vector(), self.suction), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(to_world(self.raw_obs, action))
        self.raw_obs = perturb_frame(obs, self.rotation)
        self.memory.step(action, self.raw_obs)
        return features(self.raw_obs, self.memory.vector(), self.suction), reward, terminated, truncated, info


def make_task_env(kind: str, asset, joint: str | None = None, joint_estimate: tuple | None = None,
                  max_episode_steps: int = EPISODE_STEPS, render_mode: str | None = None,
                  end_effector: str = "auto", **kwargs) -> gym.Env:
    """The environment of policy ``kind`` on ``asset``, with the ``frame`` observation (not wrapped).

    :param kind: ``drawer`` or ``door``
    :param asset: see :mod:`spark_bench.envs.assets`
    :param joint: the joint to open
    :param joint_estimate: ``(axis, pivot, type)`` the observation reports instead of the simulated joint
    :param max_episode_steps: time limit
    :param render_mode: None or ``rgb_array``
    :param end_effector: ``auto`` (the suction cup where the grasp planner finds nothing to pinch, the
        gripper elsewhere: the scripted opening score's rule), ``gripper`` or ``suction``
    :param kwargs: further environment options (``width``, ``height`` of rendered frames)
    """
    if kind not in KINDS:
        raise InputError(None, f"unknown policy kind {kind!r} (choose from {', '.join(KINDS)})")
    return make_env(KINDS[kind], asset=asset, joint=joint, max_episode_steps=max_episode_steps,
                    render_mode=render_mode, observation="frame", joint_estimate=joint_estimate,
                    end_effector=end_effector, **kwargs)


class TaskMixture(gym.Env):
    """Several opening tasks of one kind as one environment: each reset picks one task uniformly (with
    the environment's seeded generator) and the episode runs on it.

    :param envs: wrapped task environments (:class:`GraspFrameWrapper` over a time limit), same spaces
    """

    metadata = {"render_modes": []}

    def __init__(self, envs: list[gym.Env]):
        if not envs:
            raise ValueError("TaskMixture needs at least one task")
        self.envs = list(envs)
        self.observation_space = self.envs[0].observation_space
        self.action_space = self.envs[0].action_space
        self.current = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.current = int(self.np_random.integers(len(self.envs)))
        return self.envs[self.current].reset(seed=int(self.np_random.integers(2**31 - 1)))

    def step(self, action):
        return self.envs[self.current].step(action)

    def close(self):
        for env in self.envs:
            env.close()


class GeneralistPolicy:
    """A generalist model acting on ``frame`` observations (the rollout protocol of
    :mod:`spark_bench.rl.rollout`: ``reset(env)``, ``__call__(obs) -> action``); ``reset`` reads which
    end-effector the environment carries (:func:`end_effector_flag`).

    :param model: a stable-baselines3 model trained on :func:`features`, or a policy kind (``drawer`` /
        ``door``) for the shipped one
    :param deterministic: act with the policy's mean action
    """

    def __init__(self, model, deterministic: bool = True):
        self.model = load_generalist(model) if isinstance(model, str) else model
        self.deterministic = deterministic
        self.memory = Memory()
        self._last: np.ndarray | None = None
        self.suction = 0.0

    def reset(self, env: gym.Env) -> None:
        self._last = None
        self.suction = end_effector_flag(env)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self._last is None:
            self.memory.reset(obs)
        else:
            self.memory.step(self._last, obs)
        x = features(obs, self.memory.vector(), self.suction)
        action, _ = self.model.predict(x, deterministic=self.deterministic)
        self._last = np.clip(action, -1.0, 1.0)
        return to_world(obs, action)


def weights_path(kind: str, folder: str | Path | None = None) -> Path:
    """The weights file of policy ``kind`` in ``folder`` (default: the shipped ones)."""
    if kind not in KINDS:
        raise InputError(None, f"unknown policy kind {kind!r} (choose from {', '.join(KINDS)})")
    return Path(folder or WEIGHTS_DIR) / f"{kind}.zip"


def weights_record(folder: str | Path | None = None) -> dict:
    """The record of the run that produced the weights in ``folder`` (default: the shipped ones).

    :raises InputError: no record, or one for another :data:`FEATURE_VERSION`
    """
    from spark_bench.data.readers import read_json

    path = Path(folder or WEIGHTS_DIR) / RECORD_NAME
    if not path.is_file():
        raise InputError(path, "no generalist policy record (train one with spark-bench train-generalist)")
    record = read_json(path)
    if not isinstance(record, dict) or record.get("feature_version") != FEATURE_VERSION:
        found = record.get("feature_version") if isinstance(record, dict) else None
        raise InputError(path, f"weights for feature version {found}, this code reads version {FEATURE_VERSION}")
    return record


def load_generalist(kind: str, folder: str | Path | None = None, env=None, custom_objects: dict | None = None):
    """The generalist PPO model of ``kind`` (``drawer`` / ``door``) from ``folder`` (default: shipped).

    :param env: an environment (or vectorized one) to attach, for fine-tuning; None for acting only
    :param custom_objects: saved settings to replace (``n_steps``, ``learning_rate``...), as
        stable-baselines3's ``load`` takes them
    :raises InputError: missing weights, or weights of another feature version
    """
    weights_record(folder)
    path = weights_path(kind, folder)
    if not path.is_file():
        raise InputError(path, f"no {kind} policy weights")
    from stable_baselines3 import PPO

    return PPO.load(path, env=env, device="cpu", custom_objects=custom_objects)
