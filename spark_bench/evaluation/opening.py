"""The opening test of a prediction: the scripted opener, planned from the *predicted* joints, acting on
the *ground-truth* object (:func:`spark_bench.rl.open_with_joint`).

Each ground-truth drawer (prismatic) and door (revolute) is opened once in its environment
(``SparkDrawer-v0`` / ``SparkDoor-v0``), with the parameters of the predicted joint it was matched with
by the metrics (Hungarian matching on parts). A joint the opener cannot open even with the
ground-truth parameters tests the opener, not the prediction: it is left out (``success`` None) with a
one-line ``reason``, the planner's own when it declines the part before any episode (no handle, knob,
notch or tab: a flush lid, a button) or the ground-truth run's failure. The
robot acts on the object at its real size: a case's ground truth is stored in the benchmark frame
([-1, 1]^3), so it is scaled back to metres (:meth:`~spark_bench.data.case.BenchmarkCase.to_metres`).
The predicted axis line is carried from the prediction's frame into the ground truth's: prediction world
-> its benchmark frame (-> the ICP alignment, when the metrics aligned) -> ground-truth world -> metres.
An unmatched joint counts as not opened. Continuous joints (knobs, caps) have no opening task and are
left out.

What it uses of other packages is their public face: :class:`~spark_bench.data.case.BenchmarkCase` and
:func:`~spark_bench.data.case.benchmark_frame` for the case and its frames, :func:`spark_bench.envs.make_env`
and :mod:`spark_bench.rl` (``open_with_joint``, ``open_with_ground_truth``, ``run_episodes``,
:func:`spark_bench.rl.train.train`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spark_bench.asset.transforms import unit
from spark_bench.data.case import BenchmarkCase, benchmark_frame
from spark_bench.errors import InputError

ENV_OF_TYPE = {"prismatic": "SparkDrawer-v0", "revolute": "SparkDoor-v0"}


def prediction_to_gt_world(pred, gt, alignment=None) -> np.ndarray:
    """The 4x4 similarity from the prediction's world frame into the ground truth's: prediction world
    -> its benchmark frame (-> the metrics' ICP alignment) -> ground-truth world.

    :param pred: predicted asset
    :param gt: ground-truth asset
    :param alignment: optional 4x4 similarity the metrics applied to the prediction's benchmark frame
    """
    align = np.asarray(alignment if alignment is not None else np.eye(4), dtype=np.float64)
    return np.linalg.inv(benchmark_frame(gt)) @ align @ benchmark_frame(pred)


def ground_truth_in_metres(gt_folder: str | Path):
    """``(ground truth as stored, ground truth in metres, 4x4 from the first to the second)``.

    A benchmark case's ground truth comes back from the benchmark frame to its source's size and place
    (:meth:`~spark_bench.data.case.BenchmarkCase.gt_at_source_size`); any other object folder is used as
    it is, with the identity.

    :param gt_folder: the ground-truth object folder (a case's ground truth, or any object folder)
    """
    from spark_bench.data import load_object

    stored = load_object(gt_folder)
    case = BenchmarkCase.of_gt_folder(gt_folder)
    if case is None:
        return stored, stored, np.eye(4)
    gt, to_metres = case.gt_at_source_size(stored)
    return stored, gt, to_metres


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
                               max_steps: int = 200) -> dict:
    """Open every ground-truth drawer and door with the matched predicted joint.

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder
    :param metrics: :meth:`MetricsResult.to_dict` of the prediction (its ``matching`` and ``alignment``)
    :param seed: environment reset seed
    :param max_steps: step limit per episode
    :returns: ``{"success_rate": fraction opened (None when nothing can be opened), "joints": {...}}``; a
        joint left out has ``success`` None and a one-line ``reason`` (the planner's: no handle, a flush lid;
        or the opener failing with the ground-truth joint too)
    """
    from spark_bench.data import load_object
    from spark_bench.envs import make_env
    from spark_bench.envs.scene import plan_grasp
    from spark_bench.rl import open_with_ground_truth, open_with_joint

    gt_files, gt, to_source = ground_truth_in_metres(gt_folder)
    pred = load_object(pred_folder)
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
        pred_name = matched.get(joint.name)
        if pred_name is None:
            joints[joint.name] = {"success": False, "why": "no matched predicted joint"}
            continue
        axis, pivot, pred_type = axes[pred_name]
        if pred_type not in ("prismatic", "revolute", "continuous"):
            joints[joint.name] = {"success": False, "why": f"predicted joint is {pred_type}"}
            continue
        try:
            env = make_env(env_id, asset=gt, joint=joint.name, max_episode_steps=max_steps)
        except InputError as exc:  # no task for this joint (the model does not compile...): not the method's fault
            joints[joint.name] = {"success": None, "reason": f"no opening task: {' '.join(str(exc).split())[:200]}"}
            continue
        try:
            reference = open_with_ground_truth(env, seed=seed, max_steps=max_steps)
            if not reference.success:  # the opener cannot open it even knowing the joint: no test
                joints[joint.name] = {"success": None, "reason": "the scripted opener fails with the ground-truth "
                                      f"joint too (max fraction {reference.max_fraction:.2f})"}
                continue
            result = open_with_joint(env, axis, pivot, pred_type, seed=seed, max_steps=max_steps)
        finally:
            env.close()
        joints[joint.name] = {"success": bool(result.success), "pred_joint": pred_name,
                              "max_fraction": float(result.max_fraction), "steps": int(result.steps)}
    judged = [j["success"] for j in joints.values() if j["success"] is not None]
    rate = float(np.mean(judged)) if judged else None
    return {"success_rate": rate, "joints": joints}


def rl_transfer(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, out_dir: str | Path,
                timesteps: int = 20_000, seed: int = 0, episodes: int = 10) -> dict:
    """Train a short opening policy on the prediction, evaluate it on the ground truth.

    The first ground-truth drawer or door with a matched predicted joint of an openable type is used:
    the policy is trained on the predicted object opening the predicted joint, then run on the ground
    truth opening the ground-truth joint.

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder
    :param metrics: the prediction's metrics (their ``matching``)
    :param out_dir: where the model and its learning curve go
    :param timesteps: training steps
    :param seed: training seed
    :param episodes: evaluation episodes on the ground truth
    :returns: ``{"success_rate": ..., "train_success_rate": ..., "gt_joint": ..., "pred_joint": ...}``
    """
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.data import load_object
    from spark_bench.envs import make_env
    from spark_bench.rl import ModelPolicy, load_model, run_episodes
    from spark_bench.rl.train import train

    gt_files, gt, to_source = ground_truth_in_metres(gt_folder)
    pred_files = load_object(pred_folder)
    # the prediction where (and as large as) the metrics matched it with the real object
    pred = similarity_asset(pred_files, to_source @ prediction_to_gt_world(pred_files, gt_files,
                                                                          metrics.get("alignment")))
    for match in metrics.get("matching", []):
        env_id = ENV_OF_TYPE.get(match["gt_type"])
        pred_type = pred.joints[match["pred_joint"]].type
        if env_id is None or ENV_OF_TYPE.get("revolute" if pred_type == "continuous" else pred_type) != env_id:
            continue
        result = train(env_id, steps=timesteps, out=Path(out_dir), asset=pred, joint=match["pred_joint"], n_envs=2,
                       seed=seed, eval_every=timesteps, eval_episodes=episodes, progress_bar=False)
        env = make_env(env_id, asset=gt, joint=match["gt_joint"])
        try:
            stats = run_episodes(env, ModelPolicy(load_model(Path(out_dir) / "model.zip")), episodes, seed=20_000)
        finally:
            env.close()
        return {"success_rate": float(stats.to_dict().get("success_rate", 0.0)),
                "train_success_rate": result.final.get("success_rate"), "gt_joint": match["gt_joint"],
                "pred_joint": match["pred_joint"], "env": env_id, "timesteps": timesteps}
    return {"success_rate": 0.0 if metrics.get("matching") else None,
            "why": "no matched drawer or door of the same kind to train on"}
