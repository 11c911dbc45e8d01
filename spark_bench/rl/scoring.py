"""Open each ground-truth joint with a policy (placeholder: being consolidated)."""

from __future__ import annotations

import numpy as np

from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, make_env
from spark_bench.errors import InputError
from spark_bench.rl.scripted import open_with_ground_truth


def open_every_joint(asset, episodes: int = 1, seed: int = 0, max_episode_steps: int = 150) -> list[dict]:
    """The scripted opener with ground-truth joints on every drawer (prismatic) and door (revolute)
    of one object: one row per joint with its success rate and mean largest opening (and the planner's or
    the scene's ``reason`` when it declines the part; the episodes are run all the same).

    :param asset: anything the environments accept as ``asset``
    :param episodes: episodes per joint (seeds ``seed ..``)
    :param max_episode_steps: time limit per episode
    """
    from spark_bench.envs.assets import load_asset

    loaded, key = load_asset(asset)
    rows = []
    for joint in loaded.movable_joints():
        env_id = ENV_OF_JOINT_TYPE[joint.type]
        try:
            env = make_env(env_id, asset=key or loaded, joint=joint.name, max_episode_steps=max_episode_steps)
        except InputError as exc:
            rows.append({"joint": joint.name, "type": joint.type, "success_rate": 0.0, "error": str(exc)})
            continue
        results = [open_with_ground_truth(env, seed=seed + k) for k in range(episodes)]
        grasp = env.unwrapped.scene.grasp
        rows.append({"joint": joint.name, "type": joint.type, "grasp": grasp.source,
                     "pad_thickness": grasp.pad_thickness,
                     "success_rate": float(np.mean([r.success for r in results])),
                     "max_fraction": float(np.mean([r.max_fraction for r in results])),
                     **({"reason": grasp.reason} if grasp.reason else {})})
        env.close()
    return rows
