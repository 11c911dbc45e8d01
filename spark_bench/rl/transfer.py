"""The RL transfer score of a prediction: the shipped generalist policy, fine-tuned on the *predicted*
object, acting on the *ground-truth* object (``eval --rl``).

What it shares with the scripted opening score is in :mod:`spark_bench.opening.judge`: which ground-truth
joints are opening tasks (drawers and doors), the one rule that leaves out a joint nobody can open (the
planner declines it, the scene says it is stuck, or the scripted opener fails with the ground-truth joint
too: ``success`` None with the ``reason``, for every method alike), the pairing with the predicted joints
and their frame (prediction world -> its benchmark frame -> the metrics' alignment -> ground-truth world
-> metres), and the object acted on: a case's source object as the dataset gives it, not the remeshed
ground truth, when it is on this machine (the result's ``acts_on`` says which). For every ground-truth
drawer and door not left out:

1. the predicted joint matched with it by the metrics picks the policy (the drawer policy for a predicted
   prismatic joint, the door policy for a revolute or continuous one) and is what the policy is told about
   the joint, reported by the environment as ``joint_estimate``; the end-effector is the opening score's
   (``auto``, :data:`~spark_bench.opening.judge.SCORED_END_EFFECTOR`: the suction cup where the grasp planner
   finds nothing to pinch on the ground-truth part, the parallel gripper elsewhere; a row's
   ``end_effector``), and the policy drives either;
2. **zero-shot**: the shipped policy opens the ground-truth joint in its environment (``SparkDrawer-v0``
   / ``SparkDoor-v0``), told the predicted joint;
3. **fine-tuned**: a copy of the shipped policy trained with PPO for ``finetune_steps`` environment steps
   on the predicted object's matched joints of its kind (the prediction placed and scaled where the
   metrics matched it with the real object; the grasp frame turned at random each episode, as in
   training; every predicted joint matched with a ground-truth drawer or door, scored or left out: what
   the prediction offers to practise on, each with the end-effector ``auto`` picks on the predicted part),
   then run as in 2.

The policy takes the direction to pull from the joint it is told (it was trained so, see
:mod:`spark_bench.rl.generalist`): a predicted drawer axis 90 degrees off, or a door hinge moved next to
the handle, fails on the real object, as the scripted opener does.

A scored joint counts as not opened when no predicted joint was matched with it, when the matched one is
not a drawer or a door, and, for the fine-tuned score, when the prediction offers no task to fine-tune on.
The rates are over the scored joints (``joints_scored`` of ``joints_total``; ``scored_by`` counts them
per end-effector); the ``holdable_*`` rates beside them leave out too the joints a parallel gripper holds
only by a bare front (``face``).
"""

from __future__ import annotations

import time
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.opening.judge import OPENING_STEPS, SCORED_END_EFFECTOR, coverage, judge_joint, scored_mean
from spark_bench.opening.pairing import Pairing, load_pairing, one_line, opening_joints
from spark_bench.rl import FINETUNE_STEPS
from spark_bench.rl.generalist import (
    FRAME_NOISE,
    KIND_OF_TYPE,
    GeneralistPolicy,
    GraspFrameWrapper,
    TaskMixture,
    load_generalist,
    make_task_env,
    weights_record,
)
from spark_bench.rl.policies import fused_adam
from spark_bench.rl.tasks import TASK_KIND, holdable, run_episode, run_episodes

#: Episodes per ground-truth joint (the fine-tuning budget is :data:`spark_bench.rl.FINETUNE_STEPS`).
EPISODES = 1
#: Episode videos (``video``): frame size (width, height) and one control step kept in this many.
VIDEO_SIZE = (240, 180)
VIDEO_EVERY = 3
#: PPO settings of the fine-tuning (the shipped policy's own settings are those of its training run).
FINETUNE_PPO = {"n_steps": 256, "batch_size": 128, "n_epochs": 4, "learning_rate": 5e-5, "clip_range": 0.1,
                "target_kl": 0.03}


def finetune(kind: str, pred, joints: list[str], steps: int, seed: int = 0, weights=None):
    """A copy of the shipped ``kind`` policy trained with PPO for ``steps`` steps on ``joints`` of ``pred``.

    :returns: ``(model, info)``; the model is None when no joint gives a task (info says why)
    """
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    envs, skipped = [], {}
    for joint in joints:
        try:
            envs.append(GraspFrameWrapper(make_task_env(kind, pred, joint), FRAME_NOISE))
        except Exception as exc:  # noqa: BLE001  (a prediction's geometry may break the conversion anywhere)
            skipped[joint] = f"{type(exc).__name__}: {one_line(exc)}"
    info = {"joints": [j for j in joints if j not in skipped], "skipped": skipped, "steps": 0}
    if not envs:
        return None, info
    t0 = time.perf_counter()
    mixture = TaskMixture(envs)
    vec = DummyVecEnv([lambda: Monitor(mixture)])
    vec.seed(seed)
    n_steps = int(min(FINETUNE_PPO["n_steps"], max(steps, 16)))
    settings = {**FINETUNE_PPO, "n_steps": n_steps, "batch_size": int(min(FINETUNE_PPO["batch_size"], n_steps))}
    model = load_generalist(kind, weights, env=vec, custom_objects=settings)
    fused_adam(model)
    model.set_random_seed(seed)
    if steps > 0:
        model.learn(total_timesteps=int(steps), reset_num_timesteps=True)
    info.update(steps=int(model.num_timesteps), wall_s=round(time.perf_counter() - t0, 2))
    return model, info


def _score_joint(row: dict, name: str, gt_metres, zero, tuned, skipped: dict, episodes: int,
                 seed: int) -> None:
    """Fill ``row`` with the zero-shot and fine-tuned episodes on ground-truth joint ``name``."""
    try:
        env = make_task_env(TASK_KIND[row["type"]], gt_metres, name, joint_estimate=row["estimate"],
                            end_effector=row["end_effector"])
    except InputError as exc:
        row["why"] = f"no opening task on the ground truth: {one_line(exc)}"
        return
    row["grasp"] = env.unwrapped.scene.grasp.source
    try:
        first = run_episodes(env, zero, episodes, seed)
        row.update(zero_shot=first.success_rate, zero_shot_max_fraction=first.mean_max_fraction)
        if tuned is None:
            row["why"] = "the prediction gives no opening task to fine-tune on"
            return
        if row["pred_joint"] in skipped:
            row["note"] = f"fine-tuned without this joint: {skipped[row['pred_joint']]}"
        second = first if tuned is zero else run_episodes(env, tuned, episodes, seed)
        row.update(success=second.success_rate, max_fraction=second.mean_max_fraction)
    finally:
        env.close()


def record_episode(kind: str, asset, joint: str, policy, path: str | Path, joint_estimate: tuple | None = None,
                   seed: int = 0, size: tuple[int, int] = VIDEO_SIZE, every: int = VIDEO_EVERY,
                   end_effector: str = SCORED_END_EFFECTOR) -> Path:
    """Write one episode of ``policy`` opening ``joint`` of ``asset`` as a video (``.gif`` / ``.mp4``).

    :param kind: the environment's kind (``drawer`` / ``door``, the joint's own type)
    :param joint_estimate: the joint the policy is told (default: the simulated one)
    :param size: ``(width, height)`` of the frames
    :param every: keep one control step in ``every`` (the video plays at the episode's speed)
    :param end_effector: ``auto``, ``gripper`` or ``suction`` (:func:`~spark_bench.rl.generalist.make_task_env`)
    """
    from spark_bench.rl.rollout import write_video

    env = make_task_env(kind, asset, joint, joint_estimate=joint_estimate, render_mode="rgb_array",
                        width=int(size[0]), height=int(size[1]), end_effector=end_effector)
    try:
        frames: list = []
        every = max(1, int(every))
        run_episode(env, policy, seed, frames=frames, frame_every=every)
        frames.append(env.render())  # the end
        return write_video(frames, path, fps=max(1, round(env.metadata.get("render_fps", 25) / every)))
    finally:
        env.close()


def rl_transfer_score(pred_folder: str | Path, gt_folder: str | Path, metrics: dict,
                      out_dir: str | Path | None = None, finetune_steps: int = FINETUNE_STEPS, seed: int = 0,
                      episodes: int = EPISODES, weights: str | Path | None = None,
                      video: str | Path | None = None, gt_bench=None, pairing: Pairing | None = None) -> dict:
    """Score a prediction by the generalist policy's success on the ground truth (see the module docstring).

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder (a benchmark case's ``gt/`` is brought to metres)
    :param metrics: the prediction's metrics (``matching``: gt_joint / pred_joint pairs; ``alignment``)
    :param out_dir: where the fine-tuned models are saved (None: not saved)
    :param finetune_steps: PPO steps per policy kind on the prediction (0: no fine-tuning, the fine-tuned
        column is the zero-shot one)
    :param seed: fine-tuning and episode seed (the scripted reference episode's too)
    :param episodes: episodes per ground-truth joint and column (reset seeds ``seed ..``)
    :param weights: a folder of generalist weights (default: the shipped ones)
    :param video: write the fine-tuned policy's episode on the first ground-truth joint it was run on there
        (``.gif`` / ``.mp4``)
    :param gt_bench: the object of ``gt_folder`` if the caller already loaded it (not modified)
    :param pairing: the prediction and the object acted on, if the caller already loaded them
        (:func:`~spark_bench.opening.pairing.load_pairing` of the same folders and metrics: ``eval`` loads them
        once for both scores); used as they are
    :returns: ``{"success_rate", "zero_shot_success_rate", "holdable_success_rate", "joints",
        "joints_total", "joints_scored", "left_out", "finetune", "policy", "assets", ...}``; the rates are
        over the joints scored, None when none is; a joint left out has ``success`` and ``zero_shot`` None
        and its ``reason``; the holdable rates are over the scored joints a parallel gripper can hold
        (:func:`spark_bench.rl.tasks.holdable`); ``assets`` names the prediction and the ground truth by
        path and content hash (the ground truth as stored: the metrics'), and ``acts_on`` what the episodes
        opened (:func:`spark_bench.opening.pairing.object_acted_on`)
    """
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # small MLPs: one thread is faster than several contending for the cores
    try:
        return _transfer_score(pred_folder, gt_folder, metrics, out_dir, finetune_steps, seed, episodes, weights,
                               video, gt_bench, pairing)
    finally:
        torch.set_num_threads(threads)


def _plan_rows(pairing: Pairing, seed: int) -> tuple[dict[str, dict], dict[str, list[str]]]:
    """The ground-truth joints' rows before any policy runs, and ``{policy kind: ground-truth joints}``:
    every joint whose matched predicted joint a policy can be told (its predicted joint is fine-tuned on),
    left out or not."""
    joints: dict[str, dict] = {}
    plan: dict[str, list[str]] = {}
    for joint in opening_joints(pairing.gt_metres):
        # the opening score's end-effector (the cup where the planner finds nothing to pinch): the policies drive either
        judged = judge_joint(pairing.gt_metres, joint, seed, OPENING_STEPS, end_effector=SCORED_END_EFFECTOR)
        judged.close()  # the policies act in environments of their own (grasp-frame observations)
        pred_name, why = pairing.predicted_joint(joint.name)
        row = joints[joint.name] = {"type": joint.type, "pred_joint": pred_name, "zero_shot": 0.0, "success": 0.0,
                                    "end_effector": judged.end_effector}
        if judged.reason is not None:
            row.update(zero_shot=None, success=None, reason=judged.reason, left_out_kind=judged.kind)
        if why is not None:
            if judged.reason is None:
                row["why"] = why
            continue
        pred_type = row["pred_type"] = pairing.pred.joints[pred_name].type
        row["kind"] = KIND_OF_TYPE[pred_type]
        row["estimate"] = pairing.estimates[pred_name]
        plan.setdefault(row["kind"], []).append(joint.name)
    return joints, plan


def _transfer_score(pred_folder, gt_folder, metrics, out_dir, finetune_steps, seed, episodes, weights, video,
                    gt_bench=None, pairing: Pairing | None = None) -> dict:
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.rl.records import asset_content_hash

    t0, cpu0 = time.perf_counter(), time.process_time()
    record = weights_record(weights)
    if pairing is None:
        pairing = load_pairing(pred_folder, gt_folder, metrics, gt_bench)
    joints, plan = _plan_rows(pairing, seed)
    tuned: dict[str, dict] = {}
    recorded = video is None
    pred_metres = None  # the prediction where the metrics matched it, at the ground truth's size: fine-tuned on
    for kind, gt_joints in plan.items():
        scored = [name for name in gt_joints if joints[name]["success"] is not None]
        if not scored:
            continue
        zero = GeneralistPolicy(load_generalist(kind, weights))
        pred_joints = list(dict.fromkeys(joints[j]["pred_joint"] for j in gt_joints))
        if finetune_steps > 0:
            if pred_metres is None:
                pred_metres = similarity_asset(pairing.pred, pairing.pred_to_gt_metres)
            model, info = finetune(kind, pred_metres, pred_joints, finetune_steps, seed, weights)
        else:
            model, info = zero.model, {"joints": pred_joints, "skipped": {}, "steps": 0}
        tuned[kind] = info
        if model is not None and out_dir is not None and finetune_steps > 0:
            Path(out_dir).mkdir(parents=True, exist_ok=True)
            model.save(Path(out_dir) / f"{kind}_finetuned.zip")
        policy = zero if finetune_steps <= 0 else GeneralistPolicy(model) if model is not None else None
        for name in scored:
            row = joints[name]
            _score_joint(row, name, pairing.gt_metres, zero, policy, info["skipped"], episodes, seed)
            if not recorded and policy is not None and "max_fraction" in row:
                row["video"] = str(record_episode(TASK_KIND[row["type"]], pairing.gt_metres, name, policy, video,
                                                  row["estimate"], seed, end_effector=row["end_effector"]))
                recorded = True
    for row in joints.values():
        row.pop("estimate", None)
    scored_rows = {name: row for name, row in joints.items() if row["success"] is not None}
    held = {name: row for name, row in scored_rows.items() if holdable(row)}
    return {"success_rate": scored_mean(joints),
            "zero_shot_success_rate": scored_mean(joints, "zero_shot"),
            "holdable_joints": len(held),
            "holdable_success_rate": scored_mean(held),
            "holdable_zero_shot_success_rate": scored_mean(held, "zero_shot"),
            **coverage(joints), "acts_on": pairing.acts_on,
            "assets": {"prediction": {"path": str(Path(pred_folder)), "sha256": asset_content_hash(pairing.pred)},
                       "ground_truth": {"path": str(Path(gt_folder)),
                                        "sha256": asset_content_hash(pairing.gt_bench)}},
            "joints": joints, "finetune": tuned, "finetune_steps": int(finetune_steps), "episodes": int(episodes),
            "policy": {"version": record.get("version"), "feature_version": record.get("feature_version"),
                       "weights": str(weights) if weights is not None else "shipped"},
            "wall_s": round(time.perf_counter() - t0, 2), "cpu_s": round(time.process_time() - cpu0, 2)}
