"""SPARK's own joint optimizer (``optimize.method = "spark"``, label ``opt=spark``), reproduced from its code.

Source: ``URDFoptimizer/optimize_urdf_joint_v4.py`` of YumengHe/PartCrafter (SPARK's code), run with
``--learn-angle --init-random``. For the one revolute joint of a URDF, the script:

- learns ``delta_t`` (3,), a shift of the joint's pivot in the parent frame that leaves the child where
  it is at rest (the child's visual origin takes ``-R_j^T delta_t``), and ``delta_angle``, added to the
  start angle;
- takes as target the open image resized to 1024 px (bilinear), object where the mean of R, G, B (0-1)
  is below 0.9 (``--threshold``), and the closed image likewise;
- minimizes ``L(open) + 0.2 L(closed) + 1e-3 |delta_t|^2 + 1e-4 delta_angle^2`` with
  ``L = BCE + 0.5 Dice + 0.2 Edge`` of the soft silhouette ``S`` against the target ``T``
  (:func:`spark_terms`): BCE the mean binary cross-entropy, ``Dice = 1 - (2 sum ST + 1e-6) / (sum S +
  sum T + 1e-6)``, Edge the mean absolute difference of Sobel gradient magnitudes (kernels / 8, zero
  padding, ``sqrt(gx^2 + gy^2 + 1e-6)``); the closed image is rendered at angle 0;
- runs Adam (torch's defaults) with step 5e-3 on ``delta_t`` and 1e-2 on the angle for 200 iterations;
  after each step the pivot is clamped into the child's bounding box (``--init-random`` turns on
  ``--constrain-to-child``) and the angle into [35, 180] degrees;
- starts the pivot at a uniform random point of the child's box (seed 42), the angle at
  ``--target-angle-deg``, and writes the final pivot (not the angle) back to the URDF.

Here it runs for each revolute joint of the prior in turn (the others at their open values: the prior's,
or as fitted), and keeps the prior's types, axes and prismatic joints. What differs, and why:

- **renderer**: the halo soft-silhouette renderer of :mod:`.render` (PyTorch3D is not installable here)
  in a square window around the object (:class:`~.optimize.OpenStateScene`) at ``size`` px, instead of
  the whole frame at 1024 px. The target gets the renderer's edge profile (:func:`~.loss.halo_target`),
  so that the true joint attains the loss's minimum, as two sharp 1024 px silhouettes do. The sums of
  the BCE and edge terms are rescaled to their values as means over the script's 1024 x 1024 frame
  (:func:`frame_scales`: BCE measures an area, the edge term a length), so that the terms and the
  regularizers keep the script's balance. The default size was chosen by measurement
  (``benchmarks/measure_joint_opt.py --spark-sizes``; see ``benchmarks/results/table4_synth-v1.md``);
- **target mask**: the benchmark renders on a grey backdrop, darker than 0.9. Where an image's border is
  darker than the threshold the rule would call the whole image object; the object is then the pixels
  unlike the border colour (:func:`~spark_bench.data.images.mask_from_image`). ``target_rule`` in the report says
  which rule each image got;
- **start angle**: the prior's open value (its upper limit) clipped into the bounds, since the
  benchmark's open image shows every joint at its upper limit (the script starts at
  ``--target-angle-deg``, 35 by default);
- **closed term**: at angle 0 a pivot shift leaves the part in place, so that term does not depend on
  the parameters: it is computed once per object (the same loss values and gradients);
- **random start**: the script draws the point in the child mesh's coordinates and sets
  ``delta_t = R_j (p - child visual xyz)``, which is in the child's box only when the child's visual
  origin is 0; here the pivot is drawn uniformly in the child's rest box (in its link frame, the flag's
  stated intent) and clamped to that box after each step; the seed is combined with the case and joint;
- **output**: the learned angle becomes the joint's upper limit (the script only prints it).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.data.images import GENERATED_TOLERANCE, mask_from_image
from spark_bench.methods.ours import exact
from spark_bench.methods.ours.adam import Adam
from spark_bench.methods.ours.assemble import apply_pivot_offset, set_joint
from spark_bench.methods.ours.hypothesis import Hypothesis, Stage, child_box
from spark_bench.methods.ours.loss import halo_target
from spark_bench.methods.ours.optimize import OpenStateScene
from spark_bench.methods.ours.refine import prior_hypotheses
from spark_bench.timing import StageTimer

#: The script's render size (``--image-size``): the frame its loss terms are means over.
SPARK_FRAME = 1024
#: The script's epsilon in the Dice and edge terms.
EPS = 1e-6
#: Weights of the script's ``compute_silhouette_loss``: BCE, Dice, edge.
W_BCE, W_DICE, W_EDGE = 1.0, 0.5, 0.2
_SOBEL_X = torch.tensor([[-1.0, 0.0, 1.0], [-2.0, 0.0, 2.0], [-1.0, 0.0, 1.0]]) / 8.0


def spark_mask(rgb: np.ndarray, threshold: float = 0.9, tolerance: float = GENERATED_TOLERANCE
               ) -> tuple[np.ndarray, str]:
    """SPARK's object mask of an image and the rule used (see the module docstring).

    :param rgb: (H, W, 3) in [0, 1]
    :param threshold: object where the mean of R, G, B is below it
    :param tolerance: the backdrop's colour tolerance when the border is darker than ``threshold``
        (:data:`~spark_bench.methods.ours.open_state.RENDER_TOLERANCE` for the benchmark's renders)
    :returns: ``(mask (H, W) of 0/1, rule)``, rule ``darker-than-threshold`` (the script's) or
        ``unlike-border`` (the border itself is darker than the threshold)
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    bright = rgb.mean(axis=2)
    border = np.concatenate([bright[0], bright[-1], bright[:, 0], bright[:, -1]])
    if float(np.median(border)) < threshold:
        image = Image.fromarray(np.clip(np.round(rgb * 255), 0, 255).astype(np.uint8))
        return mask_from_image(image, tolerance), "unlike-border"
    return (bright < threshold).astype(np.float64), "darker-than-threshold"


def edge_map(image: torch.Tensor) -> torch.Tensor:
    """The script's edge map: ``sqrt(gx^2 + gy^2 + 1e-6)`` of Sobel kernels / 8 with zero padding."""
    kx = _SOBEL_X.to(image.dtype).view(1, 1, 3, 3)
    ky = _SOBEL_X.T.contiguous().to(image.dtype).view(1, 1, 3, 3)
    x = image[None, None]
    gx, gy = F.conv2d(x, kx, padding=1), F.conv2d(x, ky, padding=1)
    return exact.sqrt(gx * gx + gy * gy + EPS)[0, 0]


def spark_terms(sil: torch.Tensor, target: torch.Tensor, area_scale: float | None = None,
                length_scale: float | None = None, target_edges: torch.Tensor | None = None
                ) -> dict[str, torch.Tensor]:
    """The script's ``compute_silhouette_loss``, term by term.

    With the default scales the BCE and edge terms are means over the image, as in the script; with
    :func:`frame_scales` they are the means over the script's 1024 px frame of a window rendered at
    another size.

    :param sil: (H, W) soft silhouette (clamped into [0, 1], as the script does)
    :param target: (H, W) target in [0, 1]
    :param area_scale: factor of the BCE sum (default ``1 / pixels``)
    :param length_scale: factor of the edge term's sum (default ``1 / pixels``)
    :param target_edges: ``edge_map(target)``, when the caller keeps it for many calls
    :returns: ``{"bce", "dice", "edge", "total"}``, ``total = bce + 0.5 dice + 0.2 edge``
    """
    sil = sil.clamp(0.0, 1.0)
    target = target.to(sil.dtype)
    pixels = sil.numel()
    area_scale = 1.0 / pixels if area_scale is None else area_scale
    length_scale = 1.0 / pixels if length_scale is None else length_scale
    bce = F.binary_cross_entropy(sil, target, reduction="sum") * area_scale
    dice = 1.0 - (2.0 * (sil * target).sum() + EPS) / (sil.sum() + target.sum() + EPS)
    target_edges = edge_map(target) if target_edges is None else target_edges.to(sil.dtype)
    edge = (edge_map(sil) - target_edges).abs().sum() * length_scale
    return {"bce": bce, "dice": dice, "edge": edge, "total": W_BCE * bce + W_DICE * dice + W_EDGE * edge}


def frame_scales(window_px: float, image_px: float, size: int, frame: int = SPARK_FRAME) -> tuple[float, float]:
    """``(area_scale, length_scale)`` of :func:`spark_terms` for a window of ``window_px`` image pixels
    rendered at ``size`` px, so that the terms are their means over the whole image at ``frame`` px.

    One render pixel spans ``k = window_px / size * frame / image_px`` frame pixels: a BCE sum (an
    area) counts ``k^2`` frame pixels per render pixel, an edge sum (a length: a sharp edge's Sobel
    magnitudes sum to about 1 across it) ``k``; each is then divided by the frame's ``frame^2`` pixels.
    """
    k = window_px / size * frame / image_px
    return k * k / frame ** 2, k / frame ** 2


@dataclass
class SparkFitResult:
    """What :func:`spark_fit` returns.

    :param asset: a copy of the input asset with the fitted pivots and angles
    :param hypotheses: the final hypothesis per movable joint
    :param joints: per fitted joint, its start, end and loss (for the report)
    :param curve: the loss per iteration, joints one after another
    :param closed_loss: the closed-image term (before its weight)
    :param timings: seconds per phase, wall and ``*_cpu`` (:class:`~spark_bench.timing.StageTimer`)
    """

    asset: ArticulatedAsset
    hypotheses: dict[str, Hypothesis]
    joints: list[dict]
    curve: list[float]
    closed_loss: float
    timings: dict[str, float]


def spark_fit(asset: ArticulatedAsset, scene: OpenStateScene, closed_mask: np.ndarray, settings,
              progress=None) -> SparkFitResult:
    """SPARK's recipe on every revolute joint of ``asset`` in turn (see the module docstring).

    :param asset: the assembled prior asset (its joints' open values are the prior's upper limits)
    :param scene: the asset against the open-state target (SPARK's mask of the open image)
    :param closed_mask: (H, W) SPARK's mask of the closed (input) image, the camera's size
    :param settings: a :class:`~spark_bench.methods.ours.config.SparkFitConfig`
    :param progress: optional ``callable(str)`` told when each joint is done
    """
    timer = StageTimer()
    stage = Stage(int(settings.size), float(settings.tau), int(settings.iters))
    area, length = frame_scales(scene.camera.width, scene.image_size, stage.size)
    hypotheses = prior_hypotheses(asset)
    with timer("closed_term"), torch.no_grad():
        closed_target = torch.as_tensor(halo_target(scene.crop(closed_mask), stage.size, stage.tau),
                                        dtype=torch.float32)
        at_rest = {n: replace(h, value=0.0) for n, h in hypotheses.items()}
        closed = float(spark_terms(scene.render(at_rest, stage), closed_target, area, length)["total"])
    target = scene.target(stage.size, stage.tau)
    target = (target, edge_map(target))
    low, high = (math.radians(b) for b in settings.angle_bounds)
    rows, curve = [], []
    revolute = [n for n, h in hypotheses.items() if h.type == JointType.REVOLUTE]
    for index, name in enumerate(revolute):
        with timer("fit"):
            hyp, row, losses = _fit_joint(asset, scene, hypotheses, name, index, stage, target,
                                          settings.closed_weight * closed, (low, high), (area, length), settings)
        hypotheses[name] = hyp
        rows.append(row)
        curve += losses
        if progress:
            progress(f"{name}: loss {row['loss_start']:.4f} -> {row['loss_final']:.4f}")
    refined = asset.copy()
    for name in revolute:
        hyp = hypotheses[name]
        set_joint(refined, name, hyp.type, hyp.axis, hyp.value)
        apply_pivot_offset(refined, name, hyp.pivot_offset)
    return SparkFitResult(refined, hypotheses, rows, curve, closed, timer.as_dict())


def _fit_joint(asset, scene, hypotheses, name, index, stage, target, closed_term, bounds, scales, settings):
    """Adam on one joint's pivot shift and angle; returns its hypothesis, report row and loss curve."""
    hyp = hypotheses[name]
    origin_rotation = torch.as_tensor(asset.joints[name].origin[:3, :3], dtype=torch.float64)
    box = child_box(asset, name)
    rng = np.random.default_rng([int(settings.seed), zlib.crc32(asset.name.encode()), index])
    start = np.zeros(3) if box is None else rng.uniform(box[0], box[1])
    lo = hi = None
    if box is not None:
        lo, hi = (torch.as_tensor(b, dtype=torch.float64) for b in box)
    pivot = (origin_rotation @ torch.as_tensor(start, dtype=torch.float64)).clone().requires_grad_(True)
    angle0 = float(np.clip(hyp.value, *bounds))
    delta = torch.zeros((), dtype=torch.float64, requires_grad=True)
    still = scene.still_parts(hypotheses, [name], stage)
    others = [g for g in range(len(scene.link_names)) if g not in set(still.moving)]
    # the links this joint does not move, drawn once: their silhouette (the maximum of their images)
    background = still.images[others].amax(dim=0) if others else torch.zeros(stage.size, stage.size)
    target, target_edges = target
    adam = Adam([pivot, delta], [settings.lr_pivot, settings.lr_angle])
    losses, first = [], None
    for _ in range(stage.steps):
        adam.zero_grad()
        parts = scene.render_parts(hypotheses, stage, {name: (pivot, angle0 + delta)}, still.moving)
        sil = torch.maximum(background, parts.amax(dim=0))
        terms = spark_terms(sil, target, *scales, target_edges)
        loss = (terms["total"].double() + closed_term + settings.reg_pivot * (pivot ** 2).sum()
                + settings.reg_angle * delta ** 2)
        loss.backward()
        adam.step()
        with torch.no_grad():  # the script's projections: pivot into the child's box, angle into bounds
            if lo is not None:
                pivot.copy_(origin_rotation @ torch.minimum(torch.maximum(origin_rotation.T @ pivot, lo), hi))
            delta.copy_((angle0 + delta).clamp(*bounds) - angle0)
        losses.append(float(loss.detach()))
        first = {k: float(v.detach()) for k, v in terms.items()} if first is None else first
    final = replace(hyp, pivot_offset=pivot.detach().numpy().copy(), value=angle0 + float(delta.detach()),
                    tag="spark")
    with torch.no_grad():
        parts = scene.render_parts({**hypotheses, name: final}, stage, None, still.moving)
        sil = torch.maximum(background, parts.amax(dim=0))
        last = {k: float(v) for k, v in spark_terms(sil, target, *scales, target_edges).items()}
    row = {"joint": name, "start_pivot_offset": np.round(start, 6).tolist(),
           "pivot_offset": np.round(final.pivot_offset, 6).tolist(), "start_angle": angle0,
           "angle": final.value, "loss_start": losses[0] if losses else last["total"] + closed_term,
           "loss_final": last["total"] + closed_term + settings.reg_pivot * float((pivot.detach() ** 2).sum())
           + settings.reg_angle * float(delta.detach()) ** 2,
           "terms_start": first, "terms_final": last}
    return final, row, losses
