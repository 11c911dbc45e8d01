"""Discrete refinement of joint type and axis, and the whole native joint-optimization stage.

The paper re-asks the VLM for each joint's type and axis given the coarse URDF (section 3.3). The
offline counterpart here renders every candidate of the canonical dictionary and keeps the best after a
short continuous fit:

1. candidates per movable joint: ``revolute`` about each of the six canonical directions, with several
   pivot starts (the prior's pivot, the four edges of the part's rest bounding box parallel to the
   axis, where hinges almost always are, and the box's centre line, for parts that spin in place; small
   parts may get the prior's and the centre line only, ``small_part``), ``prismatic`` along each direction,
   and optionally ``fixed``;
2. screening: a blurred segmentation mismatch of every candidate at a coarse resolution
   (``screen_score_size``, ``screen_blur``) on a grid of open values, with the other joints as they are
   (all poses of a joint scored in a few batched rasterizations, :class:`~spark_bench.methods.ours.scoring.JointScorer`);
   the best few, and the best of the prior's family, then get a local search of their open value (the
   exact IoU of a thin door falls off within about 0.05 rad of its true angle);
3. the ``top_k`` best, and the best of the prior's family (its type about its axis line, either sign:
   ``(a, q)`` and ``(-a, -q)`` are the same motion), get the same short fit
   (:func:`~spark_bench.methods.ours.optimize.fit`, coarse then finer), and the finalists are compared on one
   footing: the exact segmentation mismatch at ``score_size`` px
   (:meth:`~spark_bench.methods.ours.optimize.OpenStateScene.seg_score`; per-part IoU when the open state
   has part masks). The prior's family is kept unless another candidate is better by a margin
   relative to the prior's score (``margin_rel``, at least ``margin_abs``): a candidate replaces what
   the prior says only on clear evidence, so a correct prior stays correct. Among candidates within
   that margin of the best, the one agreeing with the prior on most of type and axis line wins (a
   symmetric knob turns about any line alike; the prior's line then decides);
4. after the sweeps over the joints (see ``sweeps``), every joint is fitted together, coarse to fine.

Why not the soft loss at the screening resolution: at 32 px a candidate that is wrong but happens to
cover the same pixels (a drawer pulled out 0.38 vs a door tipped down 90 degrees seen from the front)
is within the loss's noise of the true one, and a fixed margin on the soft loss favoured whichever the
coarse image happened to prefer (measured: 2 correct joints of 8 replaced on the toy cabinets).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.methods.ours.assemble import apply_pivot_offset, set_joint
from spark_bench.methods.ours.hypothesis import (
    FitResult,
    Hypothesis,
    LossWeights,
    Stage,
    canonical_sign,
    child_box,
)
from spark_bench.methods.ours.optimize import OpenStateScene, fit
from spark_bench.methods.ours.sections import OptimizeConfig
from spark_bench.methods.ours.stages.refinements import REFINEMENTS
from spark_bench.methods.ours.structure import CANONICAL_AXES, OBJECT_TO_WORLD
from spark_bench.timing import StageTimer


@dataclass
class RefineSettings:
    """Knobs of the native joint optimization (see the module docstring), in the form the search uses.

    Their defaults live in one place, the ``optimize`` section of the configuration
    (:class:`~spark_bench.methods.ours.config.OptimizeConfig`, which documents each): build these with
    :meth:`from_config`.

    :param screen: the coarse level the short fits start at
    :param short_steps: Adam steps of each finalist's short fit at the screening level
    :param short_fine: a finer level the short fit continues at (None or 0 steps: none)
    :param top_k: candidates per joint that get a short fit
    :param final: the levels of the final joint fit, coarse to fine
    :param weights: loss weights
    :param refine_discrete: try other types and axes (False: continuous fit of the prior's only)
    :param include_fixed: also try ``fixed`` (a part that does not move)
    :param sweeps: most passes of the discrete search over the joints (another pass runs only for the
        joints searched before the last one whose type or axis changed in this pass: that change alters what
        they must explain, and the joints after it were searched with it in place)
    :param max_faces: per-link face budget for rendering
    :param lr_pivot: Adam step for pivot offsets
    :param lr_value: Adam step for open values
    :param score_size: resolution (px) of the exact segmentation score that picks among finalists
    :param screen_score_size: resolution (px) of the segmentation score that screens the candidates
    :param margin_rel: a candidate of another type or axis must beat the prior's score by this fraction
        of it (and by ``margin_abs`` at least) to replace it
    :param margin_abs: the smallest margin
    :param screen_values: open values tried for each candidate while screening, by type
    :param screen_blur: Gaussian blur (px) of the screening score (see ``OpenStateScene.seg_score``)
    :param screen_local: steps of the local search of the open value of the best screened candidates
        (radians; for prismatic joints, fractions of the value)
    :param small_part: a part whose rest box is smaller than this fraction of the object's gets only the
        prior's and the centre-line pivot starts (0: off; measured on synth-v1 at 0.15: a door's lever
        handle, hinged at its end, lost its true hinge and took another axis)
    :param skip_without_evidence: when no finalist, before its short fit, scores better than the part
        left at rest (exact score) by the decision's margin, keep the prior's hypothesis without short
        fits, later sweeps or the final fit (its hinge moved into its part's box)
    """

    screen: Stage
    short_steps: int
    short_fine: Stage | None
    top_k: int
    final: list[Stage]
    weights: LossWeights
    refine_discrete: bool
    include_fixed: bool
    sweeps: int
    max_faces: int
    lr_pivot: float
    lr_value: float
    score_size: int
    screen_score_size: int
    margin_rel: float
    margin_abs: float
    screen_values: dict[str, tuple[float, ...]]
    screen_blur: float
    screen_local: tuple[float, ...]
    small_part: float
    skip_without_evidence: bool = True

    @classmethod
    def from_config(cls, opt: OptimizeConfig | None = None) -> RefineSettings:
        """The settings of an ``optimize`` section (default: its defaults); the type/axis search runs
        when the refinement ``opt.refine`` names searches (``render``; ``vlm`` and ``none`` fit the given
        joints only)."""
        opt = opt or OptimizeConfig()
        return cls(
            screen=Stage(opt.screen_size, opt.screen_tau, 0), short_steps=opt.short_steps,
            short_fine=Stage(opt.short_fine_size, opt.short_fine_tau, opt.short_fine_steps), top_k=opt.top_k,
            final=[Stage(s, t, n) for s, t, n in zip(opt.final_sizes, opt.final_taus, opt.final_steps)],
            weights=LossWeights(opt.w_edge, opt.lambda_t, opt.lambda_theta, opt.w_part),
            refine_discrete=REFINEMENTS[opt.refine].searches, include_fixed=opt.include_fixed,
            sweeps=opt.sweeps, max_faces=opt.max_faces, lr_pivot=opt.lr_pivot, lr_value=opt.lr_value,
            score_size=opt.score_size, screen_score_size=opt.screen_score_size, margin_rel=opt.margin_rel,
            margin_abs=opt.margin_abs,
            screen_values={"revolute": tuple(opt.screen_values_revolute),
                           "prismatic": tuple(opt.screen_values_prismatic)},
            screen_blur=opt.screen_blur, screen_local=tuple(opt.screen_local), small_part=opt.small_part,
            skip_without_evidence=opt.skip_without_evidence)

    def short_stages(self) -> list[Stage]:
        """The stages of every finalist's short fit."""
        stages = [replace(self.screen, steps=self.short_steps)]
        return stages + ([self.short_fine] if self.short_fine is not None and self.short_fine.steps else [])


@dataclass
class RefineResult:
    """The refined asset and what it took.

    :param asset: a copy of the input asset with refined joints
    :param hypotheses: the final hypothesis per movable joint
    :param curve: loss per Adam step of the final fit
    :param candidates: per joint, every candidate's tag with its screening and short-fit losses
    :param timings: seconds per phase (:meth:`~spark_bench.timing.StageTimer.as_dict`):
        ``discrete_search`` (of which ``search_screen``, the screening scores, ``search_short_fits`` and
        ``search_exact_scores``) and ``final_fit``, wall and ``*_cpu``
    :param loss_prior: the prior's image loss at the finest level
    :param loss_final: the refined image loss at the finest level
    """

    asset: ArticulatedAsset
    hypotheses: dict[str, Hypothesis]
    curve: list[float]
    candidates: dict[str, list[dict]]
    timings: dict[str, float]
    loss_prior: float
    loss_final: float


def prior_hypotheses(asset: ArticulatedAsset, include_fixed: bool = False) -> dict[str, Hypothesis]:
    """The asset's own joints as hypotheses (open value = upper limit), excluding the root joint."""
    out = {}
    for joint in asset.joints.values():
        if joint.parent == asset.root:
            continue
        if joint.is_movable or include_fixed:
            jtype = "revolute" if joint.type == JointType.CONTINUOUS else joint.type
            out[joint.name] = Hypothesis(jtype, np.asarray(joint.axis, float), np.zeros(3),
                                         float(joint.open_value), tag=f"prior/{jtype}")
    return out


def canonical_axis(asset: ArticulatedAsset, joint_name: str, hyp: Hypothesis) -> Hypothesis:
    """``hyp`` with its axis replaced by the nearest of the object's canonical directions (sign kept).

    The search's dictionary is the object's canonical directions (its geometry is in the object's
    frame); a prior whose axes are named in another frame (the annotation prior's are the camera's: a
    vertical hinge seen from 30 degrees above is 30 degrees off) is read in that dictionary, as the
    paper's second VLM query re-reads its coarse URDF."""
    _, joint_rot, _ = _frames(asset, joint_name)
    world = joint_rot @ np.asarray(hyp.axis, float)
    world = world / np.linalg.norm(world)
    directions = [OBJECT_TO_WORLD @ np.asarray(d, float) for d in CANONICAL_AXES.values()]
    best = max(directions, key=lambda d: float(d @ world))
    if float(best @ world) > 1 - 1e-9:
        return hyp
    return replace(hyp, axis=joint_rot.T @ best, tag=f"{hyp.tag}/canonical")


def _frames(asset: ArticulatedAsset, joint_name: str):
    """World rotation of the parent frame and of the joint frame, and the world pivot, at rest."""
    joint = asset.joints[joint_name]
    parent = asset.link_poses()[joint.parent]
    frame = parent @ joint.origin
    return parent[:3, :3], frame[:3, :3], frame[:3, 3]


def candidate_hypotheses(asset: ArticulatedAsset, joint_name: str, prior: Hypothesis,
                         include_fixed: bool = False, default_values: dict | None = None,
                         small_part: bool = False) -> list[Hypothesis]:
    """Every type/axis/pivot-start candidate of one joint (see the module docstring).

    :param small_part: the part is small (a knob): its pivot starts are the prior's and the box's centre
        line only (its box edges are within a few pixels of the centre, so they add only cost)
    """
    values = default_values or {"revolute": np.pi / 2, "prismatic": 0.5}
    parent_rot, joint_rot, pivot_world = _frames(asset, joint_name)
    part_world = _part_vertices(asset, joint_name)
    box = None
    if len(part_world):
        obj = part_world @ OBJECT_TO_WORLD  # world -> object: R^T p, row-wise
        box = obj.min(axis=0), obj.max(axis=0)
    out = []
    directions = {name: OBJECT_TO_WORLD @ np.asarray(direction) for name, direction in CANONICAL_AXES.items()}
    prior_world = joint_rot @ np.asarray(prior.axis, float)
    prior_world = prior_world / np.linalg.norm(prior_world)
    if not any(abs(float(prior_world @ d)) > 1 - 1e-6 for d in directions.values()):
        # the prior's axis is none of the object's canonical directions (an annotation prior's axes are
        # the camera's): its own line is a candidate too
        directions["prior"] = prior_world
    for name, world_dir in directions.items():
        axis_joint = joint_rot.T @ world_dir
        for jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            value = prior.value if prior.type == jtype and prior.value > 0 else values[jtype]
            out.append(Hypothesis(jtype, axis_joint, np.zeros(3), value, tag=f"{jtype}/{name}/prior"))
        if box is not None:
            axis_object = OBJECT_TO_WORLD.T @ world_dir
            for k, point in enumerate(_box_edges(box, axis_object, pivot_world)):
                if small_part and k < 4:
                    continue
                offset = parent_rot.T @ (point - pivot_world)
                value = prior.value if prior.type == JointType.REVOLUTE and prior.value > 0 else values["revolute"]
                where = f"edge{k}" if k < 4 else "centre"
                out.append(Hypothesis("revolute", axis_joint, offset, value, tag=f"revolute/{name}/{where}"))
    if include_fixed:
        out.append(Hypothesis("fixed", prior.axis, np.zeros(3), 0.0, tag="fixed"))
    return out


def _part_vertices(asset: ArticulatedAsset, joint_name: str) -> np.ndarray:
    meshes = asset.link_meshes(links=asset.part_of_joint(joint_name))
    return np.concatenate([m.vertices for m in meshes.values()]) if meshes else np.zeros((0, 3))


def _box_edges(box: tuple[np.ndarray, np.ndarray], axis_object: np.ndarray, pivot_world: np.ndarray
               ) -> list[np.ndarray]:
    """World points on the four edges of the part's object-frame bounding box ``(lo, hi)`` parallel to
    the axis, then on its centre line (where knobs, wheels and lids that spin in place turn)."""
    lo, hi = box
    along = int(np.argmax(np.abs(axis_object)))
    others = [d for d in range(3) if d != along]
    pivot_obj = OBJECT_TO_WORLD.T @ pivot_world
    edges = []
    for a in (lo[others[0]], hi[others[0]]):
        for b in (lo[others[1]], hi[others[1]]):
            point = pivot_obj.copy()
            point[others[0]], point[others[1]] = a, b
            edges.append(OBJECT_TO_WORLD @ point)
    centre = pivot_obj.copy()
    centre[others] = (lo[others] + hi[others]) / 2
    edges.append(OBJECT_TO_WORLD @ centre)
    return edges


def _same_motion(a: Hypothesis, b: Hypothesis) -> bool:
    return a.type == b.type and np.allclose(a.axis, b.axis, atol=1e-6)


def _same_line(a: Hypothesis, b: Hypothesis) -> bool:
    """Parallel axes of either sign: ``(axis, value)`` and ``(-axis, -value)`` are one family."""
    return bool(abs(float(np.dot(a.axis, b.axis))) > 1 - 1e-6)


def _same_family(a: Hypothesis, b: Hypothesis) -> bool:
    """The same type about (or along) the same axis line, either sign."""
    return a.type == b.type and _same_line(a, b)


def refine(asset: ArticulatedAsset, scene: OpenStateScene, settings: RefineSettings) -> RefineResult:
    """The native joint-optimization stage on an assembled prior asset (see the module docstring)."""
    timer = StageTimer()
    prior = {n: canonical_axis(asset, n, h) for n, h in prior_hypotheses(asset, settings.include_fixed).items()}
    current = dict(prior)
    candidates_report: dict[str, list[dict]] = {}
    finest = settings.final[-1] if settings.final else settings.screen
    loss_prior = scene.loss(prior, finest, settings.weights)
    short = settings.short_stages()
    silent: set[str] = set()  # joints the image says nothing about (see ``skip_without_evidence``)
    with timer("discrete_search"):
        pending = list(current) if settings.refine_discrete else []
        for sweep in range(settings.sweeps):
            last_changed = -1
            for k, name in enumerate(pending):
                # the prior stays the reference in every sweep: a joint replaced while the others were
                # still wrong must beat the prior again once they are right
                found, rows, quiet = _search_joint(asset, scene, current, name, prior[name], short, settings, timer)
                candidates_report.setdefault(name, []).extend({"sweep": sweep, **row} for row in rows)
                if quiet:
                    silent.add(name)
                if not _same_motion(found, current[name]):
                    last_changed = k
                current[name] = found
            # another sweep helps only a joint that was searched before another's motion changed: the
            # joints searched after the last change already saw every change (and a joint without
            # evidence stays without)
            pending = [n for n in pending[:max(last_changed, 0)] if n not in silent]
            if not pending:
                break
    stages = list(settings.final)
    if not settings.refine_discrete:  # no short fits ran: start coarse
        stages = [replace(settings.screen, steps=2 * settings.short_steps)] + stages
    with timer("final_fit"):  # the joints without evidence keep the prior's hypothesis
        result: FitResult = fit(scene, current, [n for n in current if n not in silent], stages, settings.weights,
                                settings.lr_pivot, settings.lr_value)
    final = {n: canonical_sign(h) for n, h in result.hypotheses.items()}
    refined = asset.copy()
    for name, hyp in final.items():
        set_joint(refined, name, hyp.type, hyp.axis, hyp.value)
        if hyp.type == JointType.REVOLUTE:
            apply_pivot_offset(refined, name, hyp.pivot_offset)
    return RefineResult(refined, final, result.curve, candidates_report, timer.as_dict(), loss_prior,
                        result.loss)


def _search_joint(asset, scene, current, name, prior_hyp, short, settings, timer: StageTimer):
    """Screen and short-fit the candidates of one joint; returns the winner, a report, and whether the
    image had no evidence about the joint (the prior kept without short fits)."""
    with timer("search_screen"):
        screened, keep = _screen(asset, scene, current, name, prior_hyp, settings)
    report = [{"candidate": c.tag, "screen_loss": round(s, 6)} for s, c in screened]
    with timer("search_exact_scores"):
        exact = scene.seg_scorer(current, name, settings.score_size)
        # the part left at rest: a knob turned a full turn looks so, and then no motion is evidence of an axis
        rest_score = exact(replace(prior_hyp, value=0.0))
        if settings.skip_without_evidence:
            finalists = exact.scores(keep)
    if settings.skip_without_evidence and float(np.min(finalists)) > rest_score - _margin(rest_score, settings):
        # no finalist draws the open state better than the part left at rest, by the margin a decision
        # needs (a button pressed a millimetre, a knob turned in place, a part out of view): the image
        # says nothing about this joint, and the decision would keep the prior's family (``_decide``)
        report.append({"candidate": "(none: no finalist beats the part at rest)", "seg_score": round(rest_score, 6)})
        return _pivot_in_part(asset, name, prior_hyp), report, True
    fitted = []
    for cand in keep:
        with timer("search_short_fits"):
            res = fit(scene, {**current, name: cand}, [name], short, settings.weights, settings.lr_pivot,
                      settings.lr_value)
        # the short fit minimizes the soft loss, not the exact score: on a small part it can drift from
        # a start that was already right, so the better of the two (exactly scored) is the finalist
        options = [canonical_sign(res.hypotheses[name]), canonical_sign(cand)]
        with timer("search_exact_scores"):
            scores = exact.scores(options).tolist()
        score_exact, found = min(zip(scores, options), key=lambda item: item[0])
        entry = next(r for r in report if r["candidate"] == cand.tag)
        entry.update(fit_loss=round(res.loss, 6), seg_score=round(score_exact, 6))
        fitted.append((score_exact, res.loss, found, cand))
    return _decide(fitted, prior_hyp, rest_score, settings), report, False


def _pivot_in_part(asset: ArticulatedAsset, name: str, hyp: Hypothesis) -> Hypothesis:
    """``hyp`` with its axis line moved to pass through its part's rest bounding box (child frame), where
    a hinge is (SPARK's optimizer keeps its pivot in that box too): the line's point nearest the box's
    centre, clamped into the box (a line through the box is kept); prismatic joints have no pivot."""
    if hyp.type != JointType.REVOLUTE:
        return hyp
    box = child_box(asset, name)
    if box is None:
        return hyp
    rotation = np.asarray(asset.joints[name].origin, float)[:3, :3]
    point = rotation.T @ np.asarray(hyp.pivot_offset, float)  # on the line, child frame
    axis = np.asarray(hyp.axis, float) / np.linalg.norm(hyp.axis)  # the joint frame is the child's at rest
    centre = (box[0] + box[1]) / 2
    nearest = point + float((centre - point) @ axis) * axis
    inside = np.clip(nearest, box[0], box[1])
    if np.allclose(inside, nearest):
        return hyp
    return replace(hyp, pivot_offset=rotation @ inside, tag=f"{hyp.tag}/in-part")


def _margin(score: float, settings: RefineSettings) -> float:
    """How much better than ``score`` another candidate must be to count (``margin_rel``, at least
    ``margin_abs``)."""
    return max(settings.margin_abs, settings.margin_rel * score)


def _screen(asset, scene, current, name, prior_hyp, settings) -> tuple[list, list[Hypothesis]]:
    """Every candidate of one joint scored on the grid of open values (sorted ``(score, candidate)``
    pairs), and the finalists: the ``top_k`` best after a local search of the value, and the best of the
    prior's family."""
    cands = candidate_hypotheses(asset, name, prior_hyp, settings.include_fixed,
                                 small_part=_is_small_part(scene, name, settings.small_part))
    scorer = scene.seg_scorer(current, name, settings.screen_score_size, settings.screen_blur)
    grids = [[cand.value] + [v for v in settings.screen_values.get(cand.type, ()) if abs(v - cand.value) > 1e-6]
             for cand in cands]
    flat = scorer.scores([replace(cand, value=v) for cand, grid in zip(cands, grids) for v in grid])
    screened, at = [], 0
    for cand, grid in zip(cands, grids):
        loss, value = min(zip(flat[at:at + len(grid)].tolist(), grid))
        at += len(grid)
        screened.append((loss, replace(cand, value=value)))
    screened.sort(key=lambda item: item[0])
    # the open value's basin is narrower than the grid's step for thin parts: the best few, and the best of
    # the prior's family, get a local search of their value before the finalists are chosen
    pool = screened[: 2 * settings.top_k]
    family = next(item for item in screened if _same_family(item[1], prior_hyp))
    if not any(c is family[1] for _, c in pool):
        pool.append(family)
    best = [(loss, cand.value) for loss, cand in pool]
    for frac in settings.screen_local:
        trials = []
        for (_, cand), (_, value) in zip(pool, best):
            step = frac if cand.type == JointType.REVOLUTE else frac * max(cand.value, 0.1)
            trials += [(cand, value - step), (cand, value + step)]
        losses = scorer.scores([replace(cand, value=v) for cand, v in trials]).tolist()
        for k in range(len(pool)):
            best[k] = min([best[k]] + [(losses[2 * k + j], trials[2 * k + j][1]) for j in (0, 1)])
    refined = sorted(((loss, replace(cand, value=value)) for (_, cand), (loss, value) in zip(pool, best)),
                     key=lambda item: item[0])
    keep = [c for _, c in refined[: settings.top_k]]
    if not any(_same_family(c, prior_hyp) for c in keep):  # the prior's type and axis line always compete
        keep.append(next(c for _, c in refined if _same_family(c, prior_hyp)))
    return screened, keep


def _decide(fitted: list[tuple], prior_hyp: Hypothesis, rest_score: float, settings: RefineSettings
            ) -> Hypothesis:
    """The winner among the finalists ``(exact score, fit loss, fitted hypothesis, candidate)``.

    The prior's family wins unless another finalist beats its score by the margin. Otherwise, among the
    finalists within the margin of the best, the one that agrees with the prior on most of (type, axis
    line) wins, the type first (a knob that the prior calls prismatic turns about the prior's line; a
    lid lifted out of view is not told apart from one swung out of view, and the prior's type decides):
    what the image cannot tell apart, the prior decides. A winner that does not beat
    the part left at rest (``rest_score``) by the margin is no evidence about type or axis (a knob
    turned a full turn, fitted as 0.2 rad about whichever axis the pixels favour): the prior's family
    wins then too.
    """
    best_score, _, best, _ = min(fitted, key=lambda item: item[:2])
    prior_score, _, prior_best, _ = min((f for f in fitted if _same_family(f[3], prior_hyp)),
                                        key=lambda item: item[:2])
    margin = _margin(prior_score, settings)
    if best_score > min(prior_score, rest_score) - margin:
        return prior_best
    close = [f for f in fitted if f[0] <= best_score + margin]

    def disagreement(item):
        same_type, same_line = item[3].type == prior_hyp.type, _same_line(item[3], prior_hyp)
        return (-(same_type + same_line), -same_type, item[0], item[1])

    return min(close, key=disagreement)[2]


def _is_small_part(scene: OpenStateScene, name: str, fraction: float) -> bool:
    """Whether the joint's part is small next to the whole object (its rest bounding-box diagonal below
    ``fraction`` of the object's): knobs and buttons, whose pivot starts at the box edges all look alike."""
    if fraction <= 0:
        return False
    asset = scene.asset
    part = _part_vertices(asset, name)
    if not len(part):
        return False
    whole = np.concatenate([m.vertices for m in asset.link_meshes().values()])
    return bool(np.ptp(part, axis=0).max() < fraction * np.ptp(whole, axis=0).max())

