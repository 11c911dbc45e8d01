"""Opening helpers shared by several test modules: a part opens with its true hinge and not with a wrong one;
the observation the scripted opener reads; the matching of an object's joints to themselves."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from spark_bench.envs import observation as OBS


def opens_with_its_hinge_only(env, max_steps: int, seed: int = 0) -> tuple[bool, bool]:
    """``(opened with the true joint, opened with the hinge turned 90 degrees in the grasped face's plane)``:
    one scripted episode each, planned from the environment's own joint and from that wrong one."""
    from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint

    true = open_with_ground_truth(env, seed=seed, max_steps=max_steps).success
    axis, pivot, joint_type = ground_truth_joint(env)
    outward = env.unwrapped.scene.grasp.outward
    wrong = np.cross(outward, axis) + outward * float(outward @ axis)
    return bool(true), bool(open_with_joint(env, wrong, pivot, joint_type, seed=seed, max_steps=max_steps).success)


def opener_observation(tcp: Sequence[float], grasp: Sequence[float],
                       touch: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """An observation of the environments' layout holding only what the scripted opener reads (zeros
    elsewhere).

    :param tcp: the gripper's tool centre point
    :param grasp: the grasp point
    :param touch: the pads' touch readings
    """
    obs = np.zeros(OBS.OBS_SIZE, dtype=np.float32)
    obs[OBS.TCP], obs[OBS.GRASP], obs[OBS.TOUCH] = tcp, grasp, touch
    return obs


def identity_matching(asset) -> dict:
    """The metrics' ``matching`` of ``asset``'s movable joints to themselves (a prediction that is the
    ground truth).

    :param asset: the object
    """
    return {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in asset.movable_joints()]}
