"""Scripted episodes: the scripted opener (:mod:`spark_bench.opening.opener`, or the cup's
:mod:`spark_bench.opening.suction_opener`) made for an environment's grasp and run for one episode, planned
from given joint parameters (:func:`open_with_joint`) or the environment's own (:func:`open_with_ground_truth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.manipulation.gripper import grip_command
from spark_bench.manipulation.scene import part_points
from spark_bench.opening.door_geometry import door_edge, turns_in_place
from spark_bench.opening.opener import PULL_STEP, ScriptedOpener
from spark_bench.opening.suction_opener import SuctionOpener


@dataclass
class OpenResult:
    """One scripted episode.

    :param success: the joint passed the environment's target fraction
    :param steps: environment steps taken
    :param fraction: the joint's final position as a fraction of its range
    :param max_fraction: the largest fraction reached
    :param episode_return: the summed reward
    :param end_effector: what opened (or tried to open) the part: ``gripper`` or ``suction``
    :param success_maniskill: the joint met ManiSkill3's success rule at some step (past the target fraction
        and its link nearly still: :meth:`~spark_bench.envs.base.SparkArticulationEnv.evaluate`); where the
        episode stops on success, the opener runs on after that stop, until the rule is met or the step limit,
        and the other fields stay those of the stop
    """

    success: bool
    steps: int
    fraction: float
    max_fraction: float
    episode_return: float
    end_effector: str = "gripper"
    success_maniskill: bool = False


def ground_truth_joint(env: gym.Env) -> tuple[np.ndarray, np.ndarray, str]:
    """The environment's own joint as ``(axis, pivot, type)``, world frame at rest."""
    scene = env.unwrapped.scene
    pivot, axis = scene.asset.joint_frames()[scene.joint.name]
    return axis, pivot, scene.joint.type


def opener_for(env: gym.Env, axis, pivot, joint_type: str, pull_step: float = PULL_STEP) -> ScriptedOpener:
    """A :class:`ScriptedOpener` for ``env``'s grasp (its outward direction, its inside grip if the part
    has a notch, its pre-closed aligned approach if the pads go into gaps beside the handle), planned from
    the given joint parameters; a :class:`~spark_bench.opening.suction_opener.SuctionOpener` for an environment
    with the suction cup."""
    scene = env.unwrapped.scene
    grasp = scene.grasp
    if scene.end_effector == EndEffector.SUCTION:
        return SuctionOpener(axis, pivot, joint_type, grasp.outward, pull_step)
    approach_grip = lateral_tolerance = None
    if grasp.opening is not None and not grasp.inside_grip:
        approach_grip = grip_command(scene.gripper.config, grasp.opening)
        lateral_tolerance = 0.5 * grasp.clearance
    edge, in_place = None, False
    if joint_type != JointType.PRISMATIC:
        points = part_points(scene.asset, scene.joint.name)
        in_place = turns_in_place(points, grasp.point, axis, pivot)
        edge = None if in_place else door_edge(points, grasp.point, grasp.outward, axis, pivot)
    return ScriptedOpener(axis, pivot, joint_type, grasp.outward, pull_step, inside_grip=grasp.inside_grip,
                          press=grasp.press, approach_grip=approach_grip, lateral_tolerance=lateral_tolerance,
                          edge=edge, in_place=in_place)


def open_with_joint(env: gym.Env, axis, pivot, joint_type: str, seed: int | None = None,
                    max_steps: int = 200, stop_on_success: bool = True,
                    pull_step: float = PULL_STEP, until_still: bool = True) -> OpenResult:
    """Run one scripted episode in ``env`` planned from the given joint parameters.

    :param env: a ``SparkDrawer-v0`` / ``SparkDoor-v0`` environment (wrapped or not)
    :param axis: joint axis direction, world frame (opening = increasing joint value)
    :param pivot: a point on the axis, world frame (unused for prismatic joints)
    :param joint_type: ``prismatic``, ``revolute`` or ``continuous``
    :param seed: reset seed
    :param max_steps: step limit (the environment's own time limit also applies)
    :param stop_on_success: end the episode as soon as the joint passes the target (the result's
        ``success_maniskill`` is then decided by the steps after that stop, which change none of its other
        fields: :func:`_run_until_still`)
    :param pull_step: path length per step while opening, m
    :param until_still: run on after a stop on success to decide ``success_maniskill`` (False: it says only
        whether ManiSkill's rule held up to the stop)
    """
    opener = opener_for(env, axis, pivot, joint_type, pull_step)
    obs, info = env.reset(seed=seed)
    total, best, success, steps = 0.0, env.unwrapped.joint_fraction, False, 0
    maniskill, ended = False, False
    for steps in range(1, max_steps + 1):  # noqa: B007  (steps is reported)
        obs, reward, terminated, truncated, info = env.step(opener(obs))
        total += float(reward)
        best = max(best, env.unwrapped.joint_fraction)
        success = success or bool(info["is_success"])
        maniskill = maniskill or bool(info["is_success_maniskill"])
        ended = terminated or truncated
        if ended or (success and stop_on_success):
            break
    result = OpenResult(success=success, steps=steps, fraction=env.unwrapped.joint_fraction,
                        max_fraction=best, episode_return=total, end_effector=env.unwrapped.scene.end_effector,
                        success_maniskill=maniskill)
    if until_still and not maniskill and success and not ended:
        result.success_maniskill = _run_until_still(env, opener, obs, max_steps - steps)
    return result


def _run_until_still(env: gym.Env, opener: ScriptedOpener, obs: np.ndarray, steps_left: int) -> bool:
    """Run the opener on from where an episode stopped on success until the joint meets ManiSkill3's rule
    (past the target and its link nearly still: a drawer still being pulled meets it once it stops at its
    limit, or where the opener lets go), the episode ends or ``steps_left`` steps are spent; whether it met it.

    :param env: the environment, in the state the episode stopped in
    :param opener: the episode's opener, in the phase it stopped in
    :param obs: the last observation
    :param steps_left: the episode's step limit minus the steps taken
    """
    for _ in range(steps_left):
        obs, _, terminated, truncated, info = env.step(opener(obs))
        if info["is_success_maniskill"]:
            return True
        if terminated or truncated:
            break
    return False


def open_with_ground_truth(env: gym.Env, seed: int | None = None, **kwargs) -> OpenResult:
    """:func:`open_with_joint` with the environment's own (ground-truth) joint."""
    axis, pivot, joint_type = ground_truth_joint(env)
    return open_with_joint(env, axis, pivot, joint_type, seed=seed, **kwargs)
