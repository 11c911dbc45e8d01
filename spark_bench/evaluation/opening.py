"""The opening test of a prediction: the scripted opener, planned from the *predicted* joints, acting on
the *ground-truth* object (:func:`spark_bench.rl.open_with_joint`).

Each ground-truth drawer (prismatic) and door (revolute) is opened once in its environment
(``SparkDrawer-v0`` / ``SparkDoor-v0``), with the parameters of the predicted joint it was matched with
by the metrics (Hungarian matching on parts). A joint the opener cannot open even with the
ground-truth parameters tests the opener, not the prediction: it is left out (``success`` None) with a
one-line ``reason``, the planner's own when it declines the part before any episode (no handle, knob,
notch or tab: a flush lid, a button), the scene's when the part driven directly by the gripper's largest
pull does not open (too heavy for the gripper, or jammed by its collision shapes), or the ground-truth
run's failure. The robot acts on the object at its real size: a case's ground truth is stored in the
benchmark frame ([-1, 1]^3), so it is scaled back to metres
(:meth:`~spark_bench.data.case.BenchmarkCase.to_metres`). The predicted axis line is carried from the
prediction's frame into the ground truth's: prediction world -> its benchmark frame (-> the ICP alignment,
when the metrics aligned) -> ground-truth world -> metres. A joint that is a test but was not matched
counts as not opened. Continuous joints (knobs, caps) have no opening task and are left out.

What it uses of other packages is their public face: :class:`~spark_bench.data.case.BenchmarkCase` and
:func:`~spark_bench.data.case.prediction_to_gt_world` for the case and its frames, :func:`spark_bench.envs.make_env`
and :mod:`spark_bench.rl` (``open_with_joint``, ``open_with_ground_truth``). The RL transfer score
(``eval --rl``) is :func:`spark_bench.rl.transfer.rl_transfer_score`;
:func:`spark_bench.evaluation.aggregate.summarize` averages it over a run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spark_bench.asset.transforms import unit
from spark_bench.data.case import ground_truth_in_metres, prediction_to_gt_world
from spark_bench.errors import InputError

ENV_OF_TYPE = {"prismatic": "SparkDrawer-v0", "revolute": "SparkDoor-v0"}


def predicted_axes_in_gt_frame(pred, gt, alignment=None, gt_to_world=None
                               ) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """``{pred joint: (axis, pivot, type)}`` in the ground truth's world frame.

    :param pred: predicted asset
    :param gt: ground-truth asset
    :param alignment: optional 4x4 similarity the metrics applied to the prediction's benchmark frame
    :param gt_to_world: optional 4x4 similarity applied after, e.g. a case's benchmark frame -> metres
    """
    frame = prediction_to_gt_world(pred, gt, alignment)
    if gt_to_world is not None:
        frame = np.asarray(gt_to_world, dtype=np.float64) @ frame
    out = {}
    for name, (point, direction) in pred.joint_frames().items():
        d = frame[:3, :3] @ direction
        p = frame[:3, :3] @ point + frame[:3, 3]
        out[name] = (unit(d), p, pred.joints[name].type)
    return out


def open_with_predicted_joints(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, seed: int = 0,
                               max_steps: int = 200, gt_stored=None) -> dict:
    """Open every ground-truth drawer and door with the matched predicted joint.

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder
    :param metrics: :meth:`MetricsResult.to_dict` of the prediction (its ``matching`` and ``alignment``)
    :param seed: environment reset seed
    :param max_steps: step limit per episode
    :param gt_stored: the object of ``gt_folder`` if the caller already loaded it (not modified)
    :returns: ``{"success_rate": fraction opened (None when nothing can be opened), "joints": {...}}``; a
        joint left out has ``success`` None and a one-line ``reason`` (the planner's: no handle, a flush lid;
        the scene's: a part too heavy for the gripper or jammed by its collision shapes, driven directly; or
        the opener failing with the ground-truth joint too)
    """
    from spark_bench.data import load_object
    from spark_bench.envs import make_env
    from spark_bench.envs.scene import plan_grasp
    from spark_bench.rl import open_with_ground_truth, open_with_joint

    gt_files, gt, to_source = ground_truth_in_metres(gt_folder, gt_stored)
    # the oracle's prediction is the ground-truth folder itself: loaded once (a real object takes seconds)
    same_folder = Path(pred_folder).resolve() == Path(gt_folder).resolve()
    pred = gt_files if same_folder else load_object(pred_folder)
    matched = {m["gt_joint"]: m["pred_joint"] for m in metrics.get("matching", [])}
    axes = predicted_axes_in_gt_frame(pred, gt_files, metrics.get("alignment"), to_source)
    joints = {}
    for joint in gt.movable_joints():
        env_id = ENV_OF_TYPE.get(joint.type)
        if env_id is None:
            continue
        try:  # the planner first: a part a parallel gripper cannot pull (no handle...) is no test
            reason = plan_grasp(gt, joint.name).reason
        except InputError as exc:
            reason = " ".join(str(exc).split())[:200]
        if reason is not None:
            joints[joint.name] = {"success": None, "reason": reason}
            continue
        try:
            env = make_env(env_id, asset=gt, joint=joint.name, max_episode_steps=max_steps)
        except InputError as exc:  # no task for this joint (the model does not compile...): not the method's fault
            joints[joint.name] = {"success": None, "reason": f"no opening task: {' '.join(str(exc).split())[:200]}"}
            continue
        # whether the joint is a test at all comes first, for every method alike: a part no pull of the
        # gripper opens (too heavy, jammed), or one the opener cannot open knowing the joint, is left out
        # whether or not the prediction matched it
        try:
            stuck = env.unwrapped.scene.grasp.reason
            if stuck is not None:
                joints[joint.name] = {"success": None, "reason": stuck}
                continue
            reference = open_with_ground_truth(env, seed=seed, max_steps=max_steps)
            if not reference.success:
                joints[joint.name] = {"success": None, "reason": "the scripted opener fails with the ground-truth "
                                      f"joint too (max fraction {reference.max_fraction:.2f})"}
                continue
            pred_name = matched.get(joint.name)
            if pred_name is None:
                joints[joint.name] = {"success": False, "why": "no matched predicted joint"}
                continue
            axis, pivot, pred_type = axes[pred_name]
            if pred_type not in ("prismatic", "revolute", "continuous"):
                joints[joint.name] = {"success": False, "why": f"predicted joint is {pred_type}"}
                continue
            result = open_with_joint(env, axis, pivot, pred_type, seed=seed, max_steps=max_steps)
        finally:
            env.close()
        joints[joint.name] = {"success": bool(result.success), "pred_joint": pred_name,
                              "max_fraction": float(result.max_fraction), "steps": int(result.steps)}
    judged = [j["success"] for j in joints.values() if j["success"] is not None]
    rate = float(np.mean(judged)) if judged else None
    return {"success_rate": rate, "joints": joints}
