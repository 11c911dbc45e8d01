"""Opening checks shared by several test modules: a part opens with its true hinge and not with a wrong one."""

from __future__ import annotations

import numpy as np


def opens_with_its_hinge_only(env, max_steps: int, seed: int = 0) -> tuple[bool, bool]:
    """``(opened with the true joint, opened with the hinge turned 90 degrees in the grasped face's plane)``:
    one scripted episode each, planned from the environment's own joint and from that wrong one."""
    from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint

    true = open_with_ground_truth(env, seed=seed, max_steps=max_steps).success
    axis, pivot, joint_type = ground_truth_joint(env)
    outward = env.unwrapped.scene.grasp.outward
    wrong = np.cross(outward, axis) + outward * float(outward @ axis)
    return bool(true), bool(open_with_joint(env, wrong, pivot, joint_type, seed=seed, max_steps=max_steps).success)
