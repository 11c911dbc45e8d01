"""Open each ground-truth joint with a policy: what the scores of a prediction share.

A score of a prediction opens the *ground-truth* object's joints, at its real size, with a policy told the
*predicted* joints. Two scores do so: the scripted opening score (:func:`open_with_predicted_joints`, here:
one scripted episode planned from the predicted joint, ``eval``'s ``open`` stage) and the RL transfer score
(:func:`spark_bench.rl.transfer.rl_transfer_score`: the generalist policy zero-shot and fine-tuned, ``eval
--rl``). This module is everything they share; each supplies only how a matched joint is attempted.

- **Which ground-truth joints are opening tasks**: drawers and doors (:data:`OPENING_TYPES`, prismatic and
  revolute joints, :func:`opening_joints`); continuous joints (knobs, caps) have no opening task and are not
  reported. The environment of a joint type is :data:`spark_bench.envs.registration.ENV_OF_JOINT_TYPE`.
- **Which end-effector opens a part** (:data:`SCORED_END_EFFECTOR`, ``auto``): the parallel gripper where
  the grasp planner finds something to pinch, the suction cup on the part's front face where it finds
  nothing (a flush lid, a handle-less drawer, a board: :mod:`spark_bench.manipulation.suction`); both plan from the
  joint they are told, so a wrong axis fails with either. The cup also takes a part whose pinch is too weak
  for it (``weak_pinch``, the scene's drive check) and a part the gripper fails to open with its own joint
  where the cup opens it (:func:`judge_joint`). Every row says which (``end_effector``, and
  ``cup_mm`` for the cup: a smaller one where the 40 mm cup has no place). The RL transfer score uses the
  same rule and the same end-effector per joint (its generalist policies drive either).
- **A joint nobody can open is left out**, for every method alike, whether or not the prediction matched
  it (:func:`judge_joint`): ``success`` None and a one-line ``reason``, the first of: the grasp planner
  declines the part before any episode (the gripper finds nothing to pinch and the cup no flat patch, or
  the hand's way in is blocked, or it is a push button); the scene says it is stuck (driven directly by
  the end-effector's largest pull or hold it does not open: too heavy, or jammed by its collision shapes); the scripted opener fails with the ground-truth joint too (one episode, the
  score's seed and step limit; with the cup too, where the gripper's fails); or, rarer, no environment can be made of it (``no opening task``: the
  model does not compile). Such a joint tests the opener or the object, not the prediction. Every
  result carries its coverage (:func:`coverage`): ``joints_total``, ``joints_scored``, ``left_out``.
- **The pairing**: the predicted joint the metrics matched with each ground-truth joint
  (``metrics["matching"]``); a joint not matched, or matched with a predicted joint no environment opens,
  counts as not opened (:meth:`Pairing.predicted_joint`).
- **The frames**: the ground truth as stored is ``gt_bench`` (a benchmark case's ``gt/``: the benchmark
  frame, [-1, 1]^3) and the same object at its real size is ``gt_metres``
  (:func:`spark_bench.data.case.ground_truth_in_metres`; another object folder is in metres already). The
  prediction's joints are carried into ``gt_metres``: prediction world -> its benchmark frame (-> the
  metrics' ICP alignment) -> ground-truth world -> metres
  (:func:`spark_bench.data.case.prediction_to_gt_metres`).
- **The object acted on** (:func:`object_acted_on`, a result's ``acts_on``): a case's source object as the
  dataset gives it (``case.json``'s ``source``: its own meshes, in metres, in ``gt_metres``' frame), not
  the prepared ground truth, whose watertight remesh fattens thin parts and fills the gaps of handles
  (a drawer the gripper opens on the source finds nothing to hold on the remesh). The metrics keep the
  remesh. When the source is not on this machine, or its drawers and doors are not the ground truth's
  (names, types, axes, pivots, ranges), the policies act on ``gt_metres`` and ``acts_on`` says why.
- **The oracle shortcut**: a prediction folder that is the ground-truth folder is loaded once.
- **ManiSkill3's rule beside spark-bench's**: each attempted row's ``success_maniskill`` and the score's
  ``success_rate_maniskill`` (past the target **and** the part nearly still, ``OpenCabinetDrawer-v1``'s
  success; :func:`open_with_predicted_joints`), over the same joints; ``success`` is spark-bench's as before.

:func:`open_every_joint` is a diagnostic of the opener itself, on one object with its own joints.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np

from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, make_env
from spark_bench.errors import InputError
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.manipulation.suction import cup_mm
from spark_bench.opening.episodes import OpenResult, open_with_ground_truth, open_with_joint
from spark_bench.opening.pairing import (
    Pairing,
    load_pairing,
    one_line,
    opening_joints,
)

#: Step limit of a scripted episode in the scores (the ground-truth reference episode included).
OPENING_STEPS = 200
#: The end-effector the scripted opening score opens each part with (:func:`judge_joint`): ``auto`` is the
#: gripper where the planner finds something to pinch and the suction cup where it finds nothing (and where
#: the gripper's pinch is too weak, or fails with the part's own joint, and the cup opens the part).
SCORED_END_EFFECTOR = "auto"
#: What left a joint out (a row's ``left_out_kind``): the grasp planner declined the part (nothing a parallel
#: gripper can pull), the scene found it stuck (the gripper's largest pull does not open it), the scripted
#: opener failed with the ground-truth joint, or no environment could be made of it.
LEFT_OUT_KINDS = ("planner", "stuck", "reference", "no_task")


def left_out_reason(grasp_reason: str | None, reference: OpenResult | None) -> str | None:
    """Why a ground-truth joint is no test of a prediction, or None when it is one.

    :param grasp_reason: the planner's reason (no handle...) or the scene's (stuck), as the scene's
        ``grasp.reason`` reports either
    :param reference: the scripted opener's episode with the ground-truth joint (None: not run)
    """
    if grasp_reason:
        return grasp_reason
    if reference is not None and not reference.success:
        return (f"the scripted opener fails with the ground-truth joint too "
                f"(max fraction {reference.max_fraction:.2f})")
    return None


@dataclass
class JudgedJoint:
    """A ground-truth joint after the rule (:func:`judge_joint`).

    :param name: the joint's name
    :param type: the joint's type
    :param reason: why it is left out, or None when it is scored
    :param grasp: the planner's grasp source (``label``, ``notch``, ``face``...; empty when the planner
        declined the part)
    :param env: its scripted opener's environment, open, when it is scored (reset by every episode: the
        scripted score runs the prediction's episode in it); None when left out
    :param kind: what left it out (one of :data:`LEFT_OUT_KINDS`), None when it is scored
    :param end_effector: ``gripper`` or ``suction``: what opens (or would have opened) the part
    :param cup_radius: the suction cup's radius (m) where the planner placed one
        (:func:`spark_bench.manipulation.suction.cup_sizes`), else None
    """

    name: str
    type: str
    reason: str | None
    grasp: str = ""
    env: gym.Env | None = field(default=None, repr=False)
    kind: str | None = None
    end_effector: str = "gripper"
    cup_radius: float | None = None

    def close(self) -> None:
        """Close the environment, if open (idempotent)."""
        if self.env is not None:
            self.env.close()
            self.env = None


def judge_joint(gt_metres, joint, seed: int = 0, max_steps: int = OPENING_STEPS,
                end_effector: str = SCORED_END_EFFECTOR) -> JudgedJoint:
    """Apply the one rule to a ground-truth joint: the planner first (a part the gripper finds nothing to
    pinch on goes to the suction cup with ``auto``; a part declined for the end-effector that would open it
    needs no environment), then the scene's stuck check (with ``auto``, a pinch too weak for the part's pull
    along the fingers' closing gives way to the cup where the cup opens the part), then one episode of the
    scripted opener with the joint's own parameters; with ``auto``, where that episode fails with the gripper,
    one with the cup (its own place and drive check), which then opens the part for the prediction too. The
    caller closes the result.

    :param gt_metres: the object the policies act on, in metres (:func:`object_acted_on`)
    :param joint: one of its :func:`opening_joints`
    :param seed: the reference episode's reset seed
    :param max_steps: its step limit (and the environment's)
    :param end_effector: ``auto`` (:data:`SCORED_END_EFFECTOR`), ``gripper`` or ``suction``
        (:func:`spark_bench.manipulation.suction.choose_end_effector`)
    """
    from spark_bench.manipulation.scene import plan_grasp
    from spark_bench.manipulation.suction import choose_end_effector

    try:
        grasp = planned = plan_grasp(gt_metres, joint.name)
    except InputError as exc:  # no geometry, no outward direction: nothing to grasp
        return JudgedJoint(joint.name, joint.type, one_line(exc), kind="planner")
    effector = choose_end_effector(end_effector, grasp.declined)
    if grasp.reason is not None and effector == EndEffector.GRIPPER:
        return JudgedJoint(joint.name, joint.type, grasp.reason, kind="planner")
    try:
        # the rule as asked (``auto``: the scene may still take the cup, for a pinch too weak for the part), on
        # the grasp planned above: one plan per joint
        env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=gt_metres, joint=joint.name, max_episode_steps=max_steps,
                       end_effector=end_effector, grasp=grasp)
    except InputError as exc:  # the model does not compile, the cup finds no face...: not a method's fault
        return JudgedJoint(joint.name, joint.type, f"no opening task: {one_line(exc)}", kind="no_task",
                           end_effector=effector)
    scene = env.unwrapped.scene
    effector = scene.end_effector
    grasp = scene.grasp
    try:
        # the reference decides coverage by spark-bench's rule alone: no steps after its stop
        reference = None if grasp.reason else open_with_ground_truth(env, seed=seed, max_steps=max_steps,
                                                                     until_still=False)
    except BaseException:
        env.close()
        raise
    if end_effector == EndEffector.AUTO and effector == EndEffector.GRIPPER and reference is not None and not reference.success:
        # the gripper fails with the part's own joint (a safe door's low ring beside its dial, where the pads
        # land on the dial): the cup scores the part where it opens it with that joint
        cup = _cup_reference(gt_metres, joint, seed, max_steps, planned)
        if cup is not None:
            env.close()
            env, reference = cup
            scene, effector = env.unwrapped.scene, "suction"
            grasp = scene.grasp
    reason = left_out_reason(grasp.reason, reference)
    if reason is not None:
        env.close()
        # a reason with no drive check run is the cup's planner (no flat patch, blocked); with one, stuck
        kind = ("stuck" if scene.free_fraction is not None else "planner") if grasp.reason else "reference"
        return JudgedJoint(joint.name, joint.type, reason, grasp.source, kind=kind, end_effector=effector,
                           cup_radius=grasp.cup_radius)
    return JudgedJoint(joint.name, joint.type, None, grasp.source, env, end_effector=effector, cup_radius=grasp.cup_radius)


def _cup_reference(gt_metres, joint, seed: int, max_steps: int, grasp):
    """``(environment, reference episode)`` with the suction cup on ``joint``'s part when the cup finds a place,
    passes its drive check and opens the part with the joint's own parameters; else None (nothing left open).
    ``grasp`` is the gripper's plan on the part (the cup takes its face where it is a plate's broad one)."""
    try:
        env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=gt_metres, joint=joint.name, max_episode_steps=max_steps,
                       end_effector="suction", grasp=grasp)
    except InputError:  # no face for the cup
        return None
    try:
        if env.unwrapped.scene.grasp.reason is None:
            reference = open_with_ground_truth(env, seed=seed, max_steps=max_steps, until_still=False)
            if reference.success:
                return env, reference
    except BaseException:
        env.close()
        raise
    env.close()
    return None


def coverage(joints: dict[str, dict]) -> dict:
    """``{"joints_total", "joints_scored", "left_out": {joint: reason}, "left_out_kinds": {kind: count},
    "scored_by": {end-effector: count}}``: how many joints a score's rates cover, what left the others out
    (:data:`LEFT_OUT_KINDS`), and which end-effector the scored ones were opened with (``gripper`` in rows
    that do not say).

    :param joints: the score's per-joint rows (a row left out has ``success`` None, a ``reason`` and a
        ``left_out_kind``)
    """
    left_out = {name: row for name, row in joints.items() if row.get("success") is None}
    kinds: dict[str, int] = {}
    for row in left_out.values():
        kind = row.get("left_out_kind", "")
        kinds[kind] = kinds.get(kind, 0) + 1
    scored_by: dict[str, int] = {}
    for row in joints.values():
        if row.get("success") is not None:
            effector = row.get("end_effector", "gripper")
            scored_by[effector] = scored_by.get(effector, 0) + 1
    return {"joints_total": len(joints), "joints_scored": len(joints) - len(left_out),
            "left_out": {name: row["reason"] for name, row in left_out.items()}, "left_out_kinds": kinds,
            "scored_by": dict(sorted(scored_by.items()))}


def scored_mean(joints: dict[str, dict], key: str = "success") -> float | None:
    """The mean of ``key`` over the rows scored (``success`` not None); None when none is.

    :param joints: per-joint rows
    :param key: the row's value to average (``success``, the RL score's ``zero_shot``)
    """
    values = [row[key] for row in joints.values() if row.get("success") is not None]
    return float(np.mean(values)) if values else None


# ----- the scripted opening score -------------------------------------------------------------------
def open_with_predicted_joints(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, seed: int = 0,
                               max_steps: int = OPENING_STEPS, gt_bench=None, pairing: Pairing | None = None) -> dict:
    """The scripted opening score: every ground-truth drawer and door opened by one scripted episode
    planned from the matched predicted joint (:func:`spark_bench.opening.episodes.open_with_joint`).

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder (a benchmark case's ``gt/`` is brought to metres)
    :param metrics: :meth:`MetricsResult.to_dict` of the prediction (its ``matching`` and ``alignment``)
    :param seed: environment reset seed (the reference episode's too)
    :param max_steps: step limit per episode (the reference episode's too)
    :param gt_bench: the object of ``gt_folder`` if the caller already loaded it (not modified)
    :param pairing: the prediction and the object acted on, if the caller already loaded them
        (:func:`load_pairing` of the same folders and metrics); used as they are
    :returns: ``{"success_rate": fraction opened of the joints scored (None when none is),
        "success_rate_maniskill": the same under ManiSkill3's success rule, "joints": {...}, "joints_total",
        "joints_scored", "left_out", "acts_on"}`` (``acts_on``: :func:`object_acted_on`'s word for what the
        episodes opened); a joint left out has ``success`` None and a one-line ``reason`` (module
        docstring); one not attempted has ``success`` False and ``why`` (not opened under either rule); one
        attempted has ``success``, ``success_maniskill``, ``pred_joint``, ``max_fraction`` and ``steps``.
        ``success_maniskill`` is ManiSkill3's rule (``OpenCabinetDrawer-v1``: past the same target fraction
        **and** the part's link nearly still, :meth:`~spark_bench.envs.base.SparkArticulationEnv.evaluate`),
        reported beside spark-bench's ``success`` over the same joints and coverage, never replacing it: the
        episode stops on spark-bench's success as before (``success``, ``max_fraction`` and ``steps`` are
        those of that stop) and the opener runs on until the part is still
        (:func:`spark_bench.opening.episodes.open_with_joint`)
    """
    if pairing is None:
        pairing = load_pairing(pred_folder, gt_folder, metrics, gt_bench)
    return scripted_score(pairing, seed, max_steps)


def scripted_score(pairing: Pairing, seed: int = 0, max_steps: int = OPENING_STEPS,
                   only: Collection[str] | None = None) -> dict:
    """:func:`open_with_predicted_joints` of a loaded pairing (what it returns).

    :param pairing: the prediction and the object acted on (:func:`load_pairing`)
    :param seed: environment reset seed (the reference episode's too)
    :param max_steps: step limit per episode (the reference episode's too)
    :param only: score only these ground-truth joints (a measurement of some; default: every drawer and door)
    """
    joints: dict[str, dict] = {}
    for joint in opening_joints(pairing.gt_metres):
        if only is not None and joint.name not in only:
            continue
        judged = judge_joint(pairing.gt_metres, joint, seed, max_steps)
        try:
            joints[joint.name] = _scripted_row(judged, pairing, seed, max_steps)
        finally:
            judged.close()
    return {"success_rate": scored_mean(joints), "success_rate_maniskill": maniskill_rate(joints), "joints": joints,
            **coverage(joints), "acts_on": pairing.acts_on}


def maniskill_rate(joints: dict[str, dict]) -> float | None:
    """The fraction of the scored joints (``success`` not None, as :func:`scored_mean`) opened under ManiSkill3's
    rule (``success_maniskill``; a row not attempted, with ``why``, has none and counts as not opened); None
    when none is scored.

    :param joints: the scripted score's per-joint rows
    """
    values = [bool(row.get("success_maniskill")) for row in joints.values() if row.get("success") is not None]
    return float(np.mean(values)) if values else None


def _scripted_row(judged: JudgedJoint, pairing: Pairing, seed: int, max_steps: int) -> dict:
    """One ground-truth joint's row of the scripted opening score."""
    effector = {"end_effector": judged.end_effector}
    if judged.cup_radius is not None:  # which of the cups (their holding forces differ by their area)
        effector["cup_mm"] = cup_mm(judged.cup_radius)
    if judged.reason is not None:
        return {"success": None, "reason": judged.reason, "left_out_kind": judged.kind, **effector}
    pred_name, why = pairing.predicted_joint(judged.name)
    if why is not None:
        return {"success": False, "why": why, **effector}
    axis, pivot, pred_type = pairing.estimates[pred_name]
    result = open_with_joint(judged.env, axis, pivot, pred_type, seed=seed, max_steps=max_steps)
    return {"success": bool(result.success), "success_maniskill": bool(result.success_maniskill),
            "pred_joint": pred_name, "max_fraction": float(result.max_fraction), "steps": int(result.steps),
            **effector}


# ----- the opener's own diagnostic --------------------------------------------------------------------
def open_every_joint(asset, episodes: int = 1, seed: int = 0, max_episode_steps: int = 150) -> list[dict]:
    """The scripted opener with ground-truth joints on every movable joint of one object (drawers, doors,
    and the parts turning without limit that the door environment swings): one row per joint with its
    success rate and mean largest opening over ``episodes`` episodes.

    A diagnostic of the opener, not a score: every episode is run, also on a joint the scores leave out,
    and the row says what they did. Its ``reason`` is the scores' rule (:func:`left_out_reason`): the
    planner's or the scene's, else the first episode's failure (the episode the scores run as their
    reference, at this function's step limit). A joint with no environment has ``error`` instead.

    :param asset: anything the environments accept as ``asset``
    :param episodes: episodes per joint (seeds ``seed ..``)
    :param max_episode_steps: time limit per episode
    """
    from spark_bench.envs.assets import load_asset

    loaded, key = load_asset(asset)
    rows = []
    for joint in loaded.movable_joints():
        try:
            env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=key or loaded, joint=joint.name,
                           max_episode_steps=max_episode_steps)
        except InputError as exc:
            rows.append({"joint": joint.name, "type": joint.type, "success_rate": 0.0, "error": str(exc)})
            continue
        grasp = env.unwrapped.scene.grasp
        try:
            results = [open_with_ground_truth(env, seed=seed + k, until_still=False) for k in range(episodes)]
        finally:
            env.close()
        reason = left_out_reason(grasp.reason, results[0] if results else None)
        rows.append({"joint": joint.name, "type": joint.type, "grasp": grasp.source,
                     "pad_thickness": grasp.pad_thickness,
                     "success_rate": float(np.mean([r.success for r in results])),
                     "max_fraction": float(np.mean([r.max_fraction for r in results])),
                     **({"reason": reason} if reason else {})})
    return rows
