"""Run a policy (the scripted opener or a trained model) for some episodes and score it.

A policy here is anything with ``reset(env)`` (called at each episode start) and ``__call__(obs) ->
action`` (:mod:`spark_bench.rl.policies`).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np

from spark_bench.envs.registration import make_env
from spark_bench.errors import InputError
from spark_bench.rl.policies import load_policy

VIDEO_SUFFIXES = (".gif", ".mp4")


@dataclass
class RolloutStats:
    """Scores of a policy over some episodes.

    :param success_rate: fraction of episodes in which the joint passed the target at some step
    :param episodes: number of episodes
    :param mean_return: mean summed reward
    :param mean_max_fraction: mean of each episode's largest joint fraction
    :param successes: per-episode success
    :param returns: per-episode return
    :param reason: why the scripted opener's planner declined the part (no handle, a flush lid...): then no
        episode ran, ``success_rate`` is 0 and the means are None
    :param end_effector: what opened (or tried to open) the part: ``gripper`` or ``suction``
    """

    success_rate: float
    episodes: int
    mean_return: float | None
    mean_max_fraction: float | None
    successes: list[bool] = field(default_factory=list)
    returns: list[float] = field(default_factory=list)
    reason: str | None = None
    end_effector: str = "gripper"

    def to_dict(self) -> dict:
        return asdict(self)


def run_episode(env: gym.Env, policy, seed: int, max_steps: int | None = None, stop_on_success: bool = False,
                frames: list | None = None, frame_every: int = 1) -> dict:
    """One episode of ``policy`` (``reset(env)``, ``__call__(obs)``) in ``env``.

    :param max_steps: at most this many steps (None: until the environment's time limit)
    :param stop_on_success: end as soon as the joint passes the target
    :param frames: if given, rendered frames are appended (before steps 0, ``frame_every``, ...)
    :param frame_every: render one step in this many
    :returns: ``{"success", "max_fraction", "steps", "return"}``
    """
    obs, _ = env.reset(seed=int(seed))
    policy.reset(env)
    best, success, total, steps, done = env.unwrapped.joint_fraction, False, 0.0, 0, False
    while not done and (max_steps is None or steps < max_steps):
        if frames is not None and steps % max(1, int(frame_every)) == 0:
            frames.append(env.render())
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        steps += 1
        total += float(reward)
        best = max(best, env.unwrapped.joint_fraction)
        success = success or bool(info.get("is_success", False))
        done = terminated or truncated or (success and stop_on_success)
    return {"success": bool(success), "max_fraction": float(best), "steps": int(steps), "return": total}


def run_episodes(env: gym.Env, policy, episodes: int, seed: int = 0, frames: list | None = None,
                 max_steps: int | None = None, stop_on_success: bool = False) -> RolloutStats:
    """Run ``policy`` for ``episodes`` episodes of :func:`run_episode` with seeds ``seed + i`` (by default
    each until the time limit).

    :param frames: if given, rendered frames are appended (the environment must render ``rgb_array``)
    """
    runs = [run_episode(env, policy, seed + episode, max_steps, stop_on_success, frames)
            for episode in range(episodes)]
    return RolloutStats(success_rate=float(np.mean([r["success"] for r in runs])), episodes=episodes,
                        mean_return=float(np.mean([r["return"] for r in runs])),
                        mean_max_fraction=float(np.mean([r["max_fraction"] for r in runs])),
                        successes=[r["success"] for r in runs], returns=[r["return"] for r in runs],
                        end_effector=getattr(env.unwrapped, "end_effector", "gripper"))


def write_video(frames: list[np.ndarray], path: str | Path, fps: int) -> Path:
    """Write frames as a GIF or MP4 (MP4 needs the ``imageio-ffmpeg`` package)."""
    import imageio.v3 as iio

    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise InputError(path, f"video must end in {' or '.join(VIDEO_SUFFIXES)}")
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, np.stack(frames), duration=1000.0 / fps, loop=0)
        return path
    stack = np.stack(frames)
    # H.264 wants sides divisible by 16: pad with the edge pixels rather than let the writer resample
    pad_h, pad_w = -stack.shape[1] % 16, -stack.shape[2] % 16
    if pad_h or pad_w:
        stack = np.pad(stack, ((0, 0), (0, pad_h), (0, pad_w), (0, 0)), mode="edge")
    try:
        iio.imwrite(path, stack, fps=fps, codec="libx264", plugin="FFMPEG")
    except (ImportError, ValueError, RuntimeError) as exc:
        raise InputError(path, f"cannot write MP4 ({exc}); install imageio-ffmpeg or use .gif") from None
    return path


def rollout(env_id: str, asset=None, policy: str = "scripted", episodes: int = 10, seed: int = 0,
            joint: str | None = None, video: str | Path | None = None,
            max_episode_steps: int | None = None, end_effector: str = "gripper") -> RolloutStats:
    """Score ``policy`` on an environment.

    :param env_id: ``SparkDrawer-v0`` or ``SparkDoor-v0``
    :param asset: the object (see :mod:`spark_bench.envs.assets`)
    :param policy: ``scripted`` or a saved model's path
    :param episodes: number of episodes (seeds ``seed .. seed + episodes - 1``)
    :param joint: the joint to open
    :param video: write the episodes to this ``.gif`` / ``.mp4``
    :param max_episode_steps: time limit (default: the registered one)
    :param end_effector: ``gripper``, ``suction`` or ``auto`` (the environments' option)
    :returns: the scores; with the scripted policy on a part its planner declines, no episode runs and
        ``reason`` says why (no video is written then)
    """
    env = make_env(env_id, asset=asset, joint=joint, render_mode="rgb_array" if video else None,
                   max_episode_steps=max_episode_steps, end_effector=end_effector)
    try:
        reason = env.unwrapped.scene.grasp.reason if policy == "scripted" else None
        if reason is not None:  # the planner says why a parallel gripper cannot open it: nothing to run
            return RolloutStats(success_rate=0.0, episodes=0, mean_return=None, mean_max_fraction=None,
                                reason=reason, end_effector=env.unwrapped.end_effector)
        frames = [] if video else None
        stats = run_episodes(env, load_policy(policy), episodes, seed=seed, frames=frames)
        if video:
            write_video(frames, video, fps=env.metadata.get("render_fps", 25))
    finally:
        env.close()
    return stats


def stats_json(stats: RolloutStats) -> str:
    """The CLI's JSON line: success rate, episodes, mean return, the mean largest fraction, the planner's
    ``reason`` when it declined the part, and the end-effector."""
    out = {"success_rate": stats.success_rate, "episodes": stats.episodes, "mean_return": stats.mean_return,
           "mean_max_fraction": stats.mean_max_fraction, "end_effector": stats.end_effector}
    if stats.reason is not None:
        out["reason"] = stats.reason
    return json.dumps(out)
