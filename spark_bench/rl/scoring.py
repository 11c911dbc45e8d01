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
  nothing (a flush lid, a handle-less drawer, a board: :mod:`spark_bench.envs.suction`); both plan from the
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

:func:`open_every_joint` is a diagnostic of the opener itself, on one object with its own joints.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import gymnasium as gym
import numpy as np

from spark_bench.asset.transforms import unit
from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, make_env
from spark_bench.envs.suction import cup_mm
from spark_bench.errors import InputError
from spark_bench.rl.scripted import OpenResult, open_with_ground_truth, open_with_joint

#: The ground-truth joint types that are opening tasks: drawers (prismatic) and doors (revolute).
OPENING_TYPES = ("prismatic", "revolute")
#: Step limit of a scripted episode in the scores (the ground-truth reference episode included).
OPENING_STEPS = 200
#: A result's ``acts_on`` when the policies act on the case's source object (:func:`object_acted_on`);
#: otherwise it names what they act on and why.
ACTS_ON_SOURCE = "source"
#: How closely a source's drawers and doors must agree with the prepared ground truth's in metres to stand
#: in for it: axis angle (radians), and pivot and prismatic range as a fraction of the object's diagonal
#: (the ground truth went through the normalization and its files: on partnet_dev and real_objects it
#: agrees to 1e-15, benchmarks/results/open_source.md).
SOURCE_ANGLE_TOL = 1e-3
SOURCE_LENGTH_TOL = 1e-3
#: Why a ground-truth joint counts as not opened when the metrics matched no predicted joint with it.
NOT_MATCHED = "no matched predicted joint"
#: The end-effector the scripted opening score opens each part with (:func:`judge_joint`): ``auto`` is the
#: gripper where the planner finds something to pinch and the suction cup where it finds nothing (and where
#: the gripper's pinch is too weak, or fails with the part's own joint, and the cup opens the part).
SCORED_END_EFFECTOR = "auto"
#: What left a joint out (a row's ``left_out_kind``): the grasp planner declined the part (nothing a parallel
#: gripper can pull), the scene found it stuck (the gripper's largest pull does not open it), the scripted
#: opener failed with the ground-truth joint, or no environment could be made of it.
LEFT_OUT_KINDS = ("planner", "stuck", "reference", "no_task")


def one_line(exc: Exception, limit: int = 200) -> str:
    """An exception's message on one line, at most ``limit`` characters (a ``reason`` or ``why``).

    :param exc: the exception
    :param limit: most characters kept
    """
    return " ".join(str(exc).split())[:limit]


def opening_joints(asset) -> list:
    """The joints of ``asset`` that are opening tasks (:data:`OPENING_TYPES`), in the asset's order.

    :param asset: an :class:`~spark_bench.asset.model.ArticulatedAsset`
    """
    return [joint for joint in asset.movable_joints() if joint.type in OPENING_TYPES]


# ----- the one rule for a joint nobody can open ----------------------------------------------------
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
        (:func:`spark_bench.envs.suction.cup_sizes`), else None
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
        (:func:`spark_bench.envs.suction.choose_end_effector`)
    """
    from spark_bench.envs.scene import plan_grasp
    from spark_bench.envs.suction import choose_end_effector

    try:
        grasp = plan_grasp(gt_metres, joint.name)
    except InputError as exc:  # no geometry, no outward direction: nothing to grasp
        return JudgedJoint(joint.name, joint.type, one_line(exc), kind="planner")
    effector = choose_end_effector(end_effector, grasp.declined)
    if grasp.reason is not None and effector == "gripper":
        return JudgedJoint(joint.name, joint.type, grasp.reason, kind="planner")
    try:
        # the rule as asked (``auto``: the scene may still take the cup, for a pinch too weak for the part)
        env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=gt_metres, joint=joint.name, max_episode_steps=max_steps,
                       end_effector=end_effector)
    except InputError as exc:  # the model does not compile, the cup finds no face...: not a method's fault
        return JudgedJoint(joint.name, joint.type, f"no opening task: {one_line(exc)}", kind="no_task",
                           end_effector=effector)
    scene = env.unwrapped.scene
    effector = scene.end_effector
    grasp = scene.grasp
    try:
        reference = None if grasp.reason else open_with_ground_truth(env, seed=seed, max_steps=max_steps)
    except BaseException:
        env.close()
        raise
    if end_effector == "auto" and effector == "gripper" and reference is not None and not reference.success:
        # the gripper fails with the part's own joint (a safe door's low ring beside its dial, where the pads
        # land on the dial): the cup scores the part where it opens it with that joint
        cup = _cup_reference(gt_metres, joint, seed, max_steps)
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


def _cup_reference(gt_metres, joint, seed: int, max_steps: int):
    """``(environment, reference episode)`` with the suction cup on ``joint``'s part when the cup finds a place,
    passes its drive check and opens the part with the joint's own parameters; else None (nothing left open)."""
    try:
        env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=gt_metres, joint=joint.name, max_episode_steps=max_steps,
                       end_effector="suction")
    except InputError:  # no face for the cup
        return None
    try:
        if env.unwrapped.scene.grasp.reason is None:
            reference = open_with_ground_truth(env, seed=seed, max_steps=max_steps)
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


# ----- the prediction, paired with the ground truth -------------------------------------------------
def predicted_joints_in_gt_metres(pred, pred_to_gt_metres) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """``{predicted joint: (unit axis, pivot, type)}`` carried into the ground truth's frame in metres.

    :param pred: the predicted asset as stored
    :param pred_to_gt_metres: 4x4 similarity (:func:`spark_bench.data.case.prediction_to_gt_metres`)
    """
    frame = np.asarray(pred_to_gt_metres, dtype=np.float64)
    out = {}
    for name, (point, direction) in pred.joint_frames().items():
        out[name] = (unit(frame[:3, :3] @ direction), frame[:3, :3] @ point + frame[:3, 3], pred.joints[name].type)
    return out


# ----- the object the policies act on --------------------------------------------------------------
def source_mismatch(source, gt_metres) -> str | None:
    """How a source object's drawers and doors differ from the prepared ground truth's in metres (the first
    difference, one line), or None when they agree (:data:`SOURCE_ANGLE_TOL`, :data:`SOURCE_LENGTH_TOL`).

    :param source: the case's source object as loaded
    :param gt_metres: the case's ground truth at its real size
    """
    gt_joints = {joint.name: joint for joint in opening_joints(gt_metres)}
    source_joints = {joint.name: joint for joint in opening_joints(source)}
    if set(gt_joints) != set(source_joints):
        return f"drawers and doors {sorted(source_joints)} are not the ground truth's {sorted(gt_joints)}"
    length_tol = SOURCE_LENGTH_TOL * float(np.linalg.norm(np.ptp(gt_metres.bounds(), axis=0)))
    gt_frames, source_frames = gt_metres.joint_frames(), source.joint_frames()
    for name, joint in gt_joints.items():
        other = source_joints[name]
        (gt_point, gt_axis), (point, axis) = gt_frames[name], source_frames[name]
        angle = float(np.arccos(np.clip(np.dot(unit(gt_axis), unit(axis)), -1.0, 1.0)))
        range_tol = length_tol if joint.type == "prismatic" else SOURCE_ANGLE_TOL
        if other.type != joint.type:
            return f"joint {name} is {other.type}, the ground truth's {joint.type}"
        if angle > SOURCE_ANGLE_TOL or np.linalg.norm(np.asarray(point) - gt_point) > length_tol:
            return f"joint {name}'s axis line is not the ground truth's"
        if max(abs(other.lower - joint.lower), abs(other.upper - joint.upper)) > range_tol:
            return f"joint {name}'s range is not the ground truth's"
    return None


def object_acted_on(gt_folder: str | Path, gt_metres):
    """``(object, acts_on)``: what the policies open, and what it is (a result's ``acts_on``).

    A benchmark case's source object (``case.json``'s ``source``) as the dataset gives it, in metres:
    :data:`ACTS_ON_SOURCE`. Otherwise ``gt_metres``, never silently: ``acts_on`` is ``"prepared gt (...)"``
    with why (the source is not on this machine, unreadable, or its drawers and doors are not the ground
    truth's: :func:`source_mismatch`), or ``"object folder"`` for a ground truth that is no case (in metres
    already, acted on as it is).

    :param gt_folder: the ground-truth object folder
    :param gt_metres: its object at its real size (:func:`spark_bench.data.case.ground_truth_in_metres`)
    """
    from spark_bench.data.case import BenchmarkCase

    case = BenchmarkCase.of_gt_folder(gt_folder)
    if case is None:
        return gt_metres, "object folder"
    folder = case.source_folder
    if folder is None or not folder.exists():
        return gt_metres, f"prepared gt (source not found: {folder})"
    try:
        source = case.load_source()
    except (InputError, OSError, ValueError) as exc:  # a broken download: the prepared gt still stands
        return gt_metres, f"prepared gt (source unreadable: {one_line(exc)})"
    differs = source_mismatch(source, gt_metres)
    if differs is not None:
        return gt_metres, f"prepared gt (source differs: {differs})"
    return source, ACTS_ON_SOURCE


@dataclass
class Pairing:
    """A prediction and the ground truth it is scored on (:func:`load_pairing`).

    :param gt_bench: the ground truth as stored (a case's: benchmark frame)
    :param gt_metres: the object the policies act on, in metres: the case's source object when found
        (:func:`object_acted_on`), else the ground truth at its real size; the frame of both
    :param pred: the prediction as stored (its own world frame); ``gt_bench`` itself for the oracle
    :param pred_to_gt_metres: 4x4 similarity from ``pred``'s world frame into ``gt_metres``'
    :param matched: ``{ground-truth joint: predicted joint}`` from the metrics' matching
    :param acts_on: what ``gt_metres`` is (:func:`object_acted_on`)
    """

    gt_bench: object
    gt_metres: object
    pred: object
    pred_to_gt_metres: np.ndarray
    matched: dict[str, str]
    acts_on: str = "object folder"

    @cached_property
    def estimates(self) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
        """Every predicted joint as ``(unit axis, pivot, type)`` in ``gt_metres``' frame."""
        return predicted_joints_in_gt_metres(self.pred, self.pred_to_gt_metres)

    def predicted_joint(self, gt_joint: str) -> tuple[str | None, str | None]:
        """``(predicted joint, why it cannot be attempted)`` for a ground-truth joint: the name is None when
        none was matched; the reason is None when a policy can be told the predicted joint (an environment
        opens its type, :data:`~spark_bench.envs.registration.ENV_OF_JOINT_TYPE`).

        :param gt_joint: the ground-truth joint's name
        """
        name = self.matched.get(gt_joint)
        if name is None or name not in self.pred.joints:
            return name, NOT_MATCHED
        pred_type = self.pred.joints[name].type
        if pred_type not in ENV_OF_JOINT_TYPE:
            return name, f"the matched predicted joint is {pred_type}"
        return name, None


def matched_joints(metrics: dict) -> dict[str, str]:
    """``{ground-truth joint: predicted joint}`` of the metrics' matching (pairs without a prediction
    dropped).

    :param metrics: the prediction's metrics (their ``matching``)
    """
    return {m["gt_joint"]: m["pred_joint"] for m in metrics.get("matching", []) if m.get("pred_joint")}


def load_pairing(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, gt_bench=None) -> Pairing:
    """Load a prediction and its ground truth for a score.

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder (a benchmark case's ``gt/`` is brought to metres; its
        source object, when on this machine, is what the policies act on: :func:`object_acted_on`)
    :param metrics: the prediction's metrics (``matching``: gt_joint / pred_joint pairs; ``alignment``)
    :param gt_bench: the object of ``gt_folder`` if the caller already loaded it (not modified)
    """
    from spark_bench.data import load_object
    from spark_bench.data.case import ground_truth_in_metres, prediction_to_gt_metres

    gt_bench, gt_metres, bench_to_metres = ground_truth_in_metres(gt_folder, gt_bench)
    acted_on, acts_on = object_acted_on(gt_folder, gt_metres)
    # the oracle's prediction is the ground-truth folder itself: loaded once (a real object takes seconds)
    same_folder = Path(pred_folder).resolve() == Path(gt_folder).resolve()
    pred = gt_bench if same_folder else load_object(pred_folder)
    frame = prediction_to_gt_metres(pred, gt_bench, metrics.get("alignment"), bench_to_metres)
    return Pairing(gt_bench, acted_on, pred, frame, matched_joints(metrics), acts_on)


# ----- the scripted opening score -------------------------------------------------------------------
def open_with_predicted_joints(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, seed: int = 0,
                               max_steps: int = OPENING_STEPS, gt_bench=None, pairing: Pairing | None = None) -> dict:
    """The scripted opening score: every ground-truth drawer and door opened by one scripted episode
    planned from the matched predicted joint (:func:`spark_bench.rl.scripted.open_with_joint`).

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder (a benchmark case's ``gt/`` is brought to metres)
    :param metrics: :meth:`MetricsResult.to_dict` of the prediction (its ``matching`` and ``alignment``)
    :param seed: environment reset seed (the reference episode's too)
    :param max_steps: step limit per episode (the reference episode's too)
    :param gt_bench: the object of ``gt_folder`` if the caller already loaded it (not modified)
    :param pairing: the prediction and the object acted on, if the caller already loaded them
        (:func:`load_pairing` of the same folders and metrics); used as they are
    :returns: ``{"success_rate": fraction opened of the joints scored (None when none is), "joints": {...},
        "joints_total", "joints_scored", "left_out", "acts_on"}`` (``acts_on``: :func:`object_acted_on`'s
        word for what the episodes opened); a joint left out has ``success`` None and a one-line
        ``reason`` (module docstring); one not attempted has ``success`` False and ``why``; one attempted
        has ``success``, ``pred_joint``, ``max_fraction`` and ``steps``
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
    return {"success_rate": scored_mean(joints), "joints": joints, **coverage(joints), "acts_on": pairing.acts_on}


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
    return {"success": bool(result.success), "pred_joint": pred_name, "max_fraction": float(result.max_fraction),
            "steps": int(result.steps), **effector}


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
            results = [open_with_ground_truth(env, seed=seed + k) for k in range(episodes)]
        finally:
            env.close()
        reason = left_out_reason(grasp.reason, results[0] if results else None)
        rows.append({"joint": joint.name, "type": joint.type, "grasp": grasp.source,
                     "pad_thickness": grasp.pad_thickness,
                     "success_rate": float(np.mean([r.success for r in results])),
                     "max_fraction": float(np.mean([r.max_fraction for r in results])),
                     **({"reason": reason} if reason else {})})
    return rows
