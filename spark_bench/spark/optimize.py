"""Continuous joint optimization (paper section 3.3): differentiable FK + soft silhouettes + Adam.

For each movable joint the learnable parameters are ``xi = (dt, dtheta)``: ``dt`` moves the joint's axis
line in the parent frame while the part stays where it is at rest (``pivot_offsets`` of
:func:`~spark_bench.asset.torch_fk.link_poses_torch`; prismatic joints have no pivot, so no ``dt``),
and the open value (angle or displacement) starts from the prior's upper limit. The open state
``M^t = G(M^0, dt, theta)`` is rendered as a soft silhouette and compared with the open-state mask:

``L = L_region + w_edge L_edge + lambda_t |dt - dt0|^2 + lambda_theta |theta - theta0|^2``
(``+ w_part L_part`` when the open state comes with per-part visible masks, see
:meth:`OpenStateScene.image_loss`; the paper compares whole silhouettes only)

with ``L_region = 1 - 2 <S, T> / (|S|_1 + |T|_1)`` (soft Dice), ``L_edge`` the L1 distance between the
gradient magnitudes of the two images divided by the target's mean gradient magnitude (so it does not
depend on the resolution), and the regularizer keeping each parameter near where this fit started.
Optimization runs coarse to fine: a list of (size, tau, steps) stages, the learning rate decaying
within each stage.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import torch
import torch.nn.functional as F

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.torch_fk import link_poses_torch
from spark_bench.spark.camera import Camera
from spark_bench.spark.geometry import decimate
from spark_bench.spark.render import (
    HALO_CUTOFF,
    SoftSilhouetteRenderer,
    downsample_mask,
    rasterize_labels,
    rasterize_labels_depth,
)


@dataclass
class Hypothesis:
    """One joint's current guess, in the asset's own frames.

    :param type: ``revolute``, ``prismatic`` or ``fixed``
    :param axis: (3,) axis in the joint frame
    :param pivot_offset: (3,) shift of the axis line in the parent frame (0 = the asset's origin)
    :param value: the open value (rad or benchmark units)
    :param tag: a name for reports (``revolute/up/edge2``...)
    """

    type: str
    axis: np.ndarray
    pivot_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    value: float = 0.0
    tag: str = ""


@dataclass
class Stage:
    """One resolution level: image ``size`` px, edge softness ``tau`` px, ``steps`` Adam steps."""

    size: int
    tau: float
    steps: int


@dataclass
class LossWeights:
    """Weights of the objective: ``w_edge``, ``lambda_t`` (pivot), ``lambda_theta`` (open value), and
    ``w_part``, the weight of the per-part coverage term (used when the open state has part masks)."""

    w_edge: float = 0.2
    lambda_t: float = 0.01
    lambda_theta: float = 0.001
    w_part: float = 0.5


@dataclass
class FitResult:
    """What a fit returns: final hypotheses, final loss (at the last stage) and the loss curve."""

    hypotheses: dict[str, Hypothesis]
    loss: float
    curve: list[float]


#: Padding of the optimization window around the object, as a fraction of its size in the image.
WINDOW_PAD = 0.2


class OpenStateScene:
    """An asset's decimated meshes as tensors, rendered at the open state of a set of hypotheses.

    Images are rendered in a square window of the camera's image around the object (the open-state
    mask and the rest pose's projection, padded by :data:`WINDOW_PAD`), so that its pixels are spent on
    the object: a stage of ``size`` pixels is a ``size x size`` image of that window.

    :param asset: the assembled asset (rest geometry fixed)
    :param camera: the view of the open-state image
    :param target: (H, W) open-state mask in [0, 1], the camera's size
    :param max_faces: per-link face budget for rendering
    :param part_masks: optional (H, W) visible mask of each link in the open-state image (e.g. from the
        case's ``open_seg.png``), keyed by the asset's link names; links without one are unconstrained
    """

    def __init__(self, asset: ArticulatedAsset, camera: Camera, target: np.ndarray, max_faces: int = 600,
                 part_masks: dict[str, np.ndarray] | None = None):
        self.asset = asset
        self.link_names, verts, faces, groups, offset = [], [], [], [], 0
        for name, link in asset.links.items():
            if not link.has_geometry:
                continue
            mesh = decimate(_welded(link.merged_mesh()), max_faces)
            groups.append(torch.full((len(mesh.faces),), len(self.link_names), dtype=torch.long))
            self.link_names.append(name)
            verts.append(torch.as_tensor(mesh.vertices, dtype=torch.float64))
            faces.append(torch.as_tensor(np.asarray(mesh.faces), dtype=torch.long) + offset)
            offset += len(mesh.vertices)
        self.link_vertices = verts
        self.faces = torch.cat(faces) if faces else torch.zeros((0, 3), dtype=torch.long)
        self.face_groups = torch.cat(groups) if groups else torch.zeros((0,), dtype=torch.long)
        target = np.asarray(target, dtype=np.float64)
        x0, y0, side = _window(target, camera, self._rest_vertices())
        self.camera = camera.cropped(x0, y0, side)
        self.target_full = _crop(target, x0, y0, side)
        masks = {n: _crop(np.asarray(m, np.float64), x0, y0, side) for n, m in (part_masks or {}).items()
                 if n in self.link_names}
        self.part_masks_full = masks
        self._renderers: dict[tuple, SoftSilhouetteRenderer] = {}
        self._targets: dict[tuple, torch.Tensor] = {}
        self._part_targets: dict[int, tuple[torch.Tensor, torch.Tensor]] = {}
        self._labels: dict[int, np.ndarray] = {}
        self._blurred: dict[tuple, np.ndarray] = {}

    @property
    def has_part_masks(self) -> bool:
        return bool(self.part_masks_full)

    def _rest_vertices(self) -> np.ndarray:
        poses = self.asset.link_poses()
        parts = [v.numpy() @ poses[n][:3, :3].T + poses[n][:3, 3] for n, v in zip(self.link_names, self.link_vertices)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))

    def renderer(self, size: int, tau: float) -> SoftSilhouetteRenderer:
        key = (size, tau)
        if key not in self._renderers:
            self._renderers[key] = SoftSilhouetteRenderer(self.camera, size, tau=tau)
        return self._renderers[key]

    def target(self, size: int, tau: float) -> torch.Tensor:
        """The mask at ``size`` px with the renderer's edge profile (see :func:`halo_target`)."""
        key = (size, tau)
        if key not in self._targets:
            mask = halo_target(self.target_full, size, tau)
            self._targets[key] = torch.as_tensor(mask, dtype=torch.float32)
        return self._targets[key]

    def part_targets(self, size: int) -> tuple[torch.Tensor, torch.Tensor]:
        """(G, size, size) area-averaged part masks (zeros for links without one) and a (G,) weight
        that is 1 where a link has a non-empty mask at this size."""
        if size not in self._part_targets:
            stack = np.zeros((len(self.link_names), size, size))
            for g, name in enumerate(self.link_names):
                if name in self.part_masks_full:
                    stack[g] = downsample_mask(self.part_masks_full[name], size)
            weight = (stack.sum(axis=(1, 2)) > 0.5).astype(np.float32)
            self._part_targets[size] = (torch.as_tensor(stack, dtype=torch.float32), torch.as_tensor(weight))
        return self._part_targets[size]

    def target_labels(self, size: int) -> np.ndarray:
        """(size, size) label image of the open state sampled at pixel centres: 0 background, g + 1 for
        link ``g``'s mask, -1 for object pixels of no known link (without part masks: 1 = object)."""
        if size not in self._labels:
            full = self.target_full
            idx = ((np.arange(size) + 0.5) * full.shape[0] / size).astype(int)
            labels = np.where(full[np.ix_(idx, idx)] >= 0.5, -1 if self.has_part_masks else 1, 0)
            for g, name in enumerate(self.link_names):
                if name in self.part_masks_full:
                    labels[self.part_masks_full[name][np.ix_(idx, idx)] >= 0.5] = g + 1
            self._labels[size] = labels
        return self._labels[size]

    def world_vertices(self, hypotheses: dict[str, Hypothesis], params: dict | None = None) -> torch.Tensor:
        """World vertices at the open state; ``params`` holds tensors replacing pivot offsets / values."""
        params = params or {}
        q, pivots, axes, types = {}, {}, {}, {}
        for name, hyp in hypotheses.items():
            pivot, value = params.get(name, (None, None))
            types[name] = hyp.type
            axes[name] = torch.as_tensor(hyp.axis, dtype=torch.float64)
            pivots[name] = pivot if pivot is not None else torch.as_tensor(hyp.pivot_offset, dtype=torch.float64)
            q[name] = value if value is not None else float(hyp.value) if hyp.type != "fixed" else 0.0
        poses = link_poses_torch(self.asset, q=q, pivot_offsets=pivots, axes=axes, types=types)
        parts = [v @ poses[n][:3, :3].T + poses[n][:3, 3] for n, v in zip(self.link_names, self.link_vertices)]
        return torch.cat(parts).float()

    def render(self, hypotheses: dict[str, Hypothesis], stage: Stage, params: dict | None = None) -> torch.Tensor:
        """The whole object's soft silhouette (size, size)."""
        return self.renderer(stage.size, stage.tau).render(self.world_vertices(hypotheses, params), self.faces)

    def render_parts(self, hypotheses: dict[str, Hypothesis], stage: Stage, params: dict | None = None
                     ) -> torch.Tensor:
        """One soft silhouette per link with geometry, (G, size, size), in :attr:`link_names` order."""
        return self.renderer(stage.size, stage.tau).render(self.world_vertices(hypotheses, params), self.faces,
                                                           self.face_groups, len(self.link_names))

    def image_loss(self, hypotheses: dict[str, Hypothesis], stage: Stage, weights: LossWeights,
                   params: dict | None = None) -> torch.Tensor:
        """``L_region + w_edge L_edge (+ w_part L_part)`` of the hypotheses, differentiable in ``params``.

        ``L_part`` (only with part masks) is the mean over links with a visible mask of ``1 - recall``,
        the fraction of the link's visible pixels that its rendered silhouette does not cover. Recall,
        not Dice: the masks are what is visible, so a correctly posed part may be partly hidden by
        another, and only its silhouette's coverage of its own visible pixels is free of occlusion bias.
        """
        if not self.has_part_masks or weights.w_part == 0:
            total, _, _ = silhouette_loss(self.render(hypotheses, stage, params),
                                          self.target(stage.size, stage.tau), weights.w_edge)
            return total
        parts = self.render_parts(hypotheses, stage, params)
        total, _, _ = silhouette_loss(parts.amax(dim=0), self.target(stage.size, stage.tau), weights.w_edge)
        masks, weight = self.part_targets(stage.size)
        recall = (parts * masks).sum(dim=(1, 2)) / masks.sum(dim=(1, 2)).clamp_min(1e-6)
        part_loss = ((1.0 - recall) * weight).sum() / weight.sum().clamp_min(1.0)
        return total + weights.w_part * part_loss

    def loss(self, hypotheses: dict[str, Hypothesis], stage: Stage, weights: LossWeights) -> float:
        """The image loss (no regularizer) of fixed hypotheses, without gradients."""
        with torch.no_grad():
            return float(self.image_loss(hypotheses, stage, weights))

    def seg_score(self, hypotheses: dict[str, Hypothesis], size: int, blur: float = 0.0) -> float:
        """Segmentation mismatch in [0, 1] of fixed hypotheses at ``size`` px (lower is better).

        The posed meshes are z-buffered into a label image (:func:`rasterize_labels`) and compared with
        :meth:`target_labels`: with part masks, the mean of ``1 - IoU`` over the whole object and every
        link that is visible in either image (so a small part weighs as much as a large one in its own
        joint's decision); without, ``1 - IoU`` of the object's silhouette.

        :param blur: 0 for the exact IoU; otherwise both indicator images are blurred by a Gaussian of
            this many pixels and compared by soft IoU (``sum min / sum max``), which stays low within
            about ``blur`` pixels of motion (used to rank candidates from a coarse grid of open values)
        """
        with torch.no_grad():
            vertices = self.world_vertices(hypotheses).double().numpy()
        face_labels = self.face_groups.numpy() + 1
        rendered = rasterize_labels(vertices, self.faces.numpy(), face_labels, self.camera.resized(size))
        return self._mismatch(rendered, size, blur)

    def seg_scorer(self, hypotheses: dict[str, Hypothesis], joint: str, size: int, blur: float = 0.0
                   ) -> Callable[[Hypothesis], float]:
        """``h -> seg_score({**hypotheses, joint: h}, size, blur)``, for scoring many hypotheses of one
        joint: the links that do not move with ``joint`` are z-buffered once, and each call rasterizes
        only the moving ones and composes the two by depth."""
        moving_links = self._moving_links(joint)
        moving = torch.as_tensor([n in moving_links for n in self.link_names], dtype=torch.bool)
        face_moving = moving[self.face_groups].numpy() if len(self.face_groups) else np.zeros(0, bool)
        faces, face_labels = self.faces.numpy(), self.face_groups.numpy() + 1
        camera = self.camera.resized(size)
        with torch.no_grad():
            vertices = self.world_vertices(hypotheses).double().numpy()
        still_labels, still_depth = rasterize_labels_depth(vertices, faces[~face_moving], face_labels[~face_moving],
                                                           camera)
        moving_faces, moving_labels = faces[face_moving], face_labels[face_moving]

        def score(hyp: Hypothesis) -> float:
            with torch.no_grad():
                posed = self.world_vertices({**hypotheses, joint: hyp}).double().numpy()
            labels, depth = rasterize_labels_depth(posed, moving_faces, moving_labels, camera)
            return self._mismatch(np.where(depth > still_depth, labels, still_labels), size, blur)

        return score

    def _moving_links(self, joint: str) -> set[str]:
        """The links below ``joint`` (its child and everything under it)."""
        out, stack = set(), [self.asset.joints[joint].child]
        while stack:
            link = stack.pop()
            out.add(link)
            stack.extend(j.child for j in self.asset.joints.values() if j.parent == link)
        return out

    def _mismatch(self, rendered: np.ndarray, size: int, blur: float) -> float:
        """The score of :meth:`seg_score` for a rendered label image (1 + index into ``link_names``)."""
        target = self.target_labels(size)
        regions = [(rendered > 0, "object", target != 0)]
        if self.has_part_masks:
            for g, name in enumerate(self.link_names):
                if name not in self.part_masks_full:
                    continue
                mine, theirs = rendered == g + 1, target == g + 1
                if mine.any() or theirs.any():
                    regions.append((mine, name, theirs))
        if blur <= 0:
            return float(np.mean([1.0 - _iou(mine, theirs) for mine, _, theirs in regions]))
        errors = []
        for mine, key, theirs in regions:
            theirs_soft = self._blurred_target(size, blur, key, theirs)
            errors.append(1.0 - _soft_iou(_blur(mine, blur), theirs_soft))
        return float(np.mean(errors))

    def _blurred_target(self, size: int, blur: float, key: str, indicator: np.ndarray) -> np.ndarray:
        if (size, blur, key) not in self._blurred:
            self._blurred[(size, blur, key)] = _blur(indicator, blur)
        return self._blurred[(size, blur, key)]


def _blur(indicator: np.ndarray, sigma: float) -> np.ndarray:
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(indicator.astype(np.float64), sigma, mode="constant", truncate=3.0)


def _soft_iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.maximum(a, b).sum()
    return float(np.minimum(a, b).sum() / union) if union > 1e-9 else 1.0


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / union) if union else 1.0


def _window(target: np.ndarray, camera: Camera, rest_vertices: np.ndarray) -> tuple[int, int, int]:
    """A square pixel window ``(x0, y0, side)`` around the open-state mask and the rest projection."""
    height, width = target.shape
    rows, cols = np.nonzero(target >= 0.5)
    xs, ys = list(cols), list(rows)
    if len(rest_vertices):
        uv, depth = camera.project(rest_vertices)
        uv = uv[depth > 0]
        xs += [uv[:, 0].min(), uv[:, 0].max()]
        ys += [uv[:, 1].min(), uv[:, 1].max()]
    if not xs:
        return 0, 0, max(width, height)
    lo = np.array([min(xs), min(ys)], float)
    hi = np.array([max(xs), max(ys)], float) + 1
    side = float((hi - lo).max()) * (1 + 2 * WINDOW_PAD)
    side = int(np.ceil(min(side, max(width, height))))
    centre = (lo + hi) / 2
    x0 = int(np.clip(round(centre[0] - side / 2), 0, max(width - side, 0)))
    y0 = int(np.clip(round(centre[1] - side / 2), 0, max(height - side, 0)))
    return x0, y0, side


def _crop(image: np.ndarray, x0: int, y0: int, side: int) -> np.ndarray:
    """``image[y0:y0+side, x0:x0+side]``, zero-padded where the window leaves the image."""
    out = np.zeros((side, side), dtype=np.float64)
    part = image[y0:y0 + side, x0:x0 + side]
    out[:part.shape[0], :part.shape[1]] = part
    return out


def halo_target(mask: np.ndarray, size: int, tau: float, cutoff: float = HALO_CUTOFF) -> np.ndarray:
    """The open-state mask with the soft renderer's edge profile, at ``size`` px.

    The renderer draws 1 inside the projection and ``2 sigmoid(-d / tau)`` at a distance ``d`` (pixels)
    outside it. The same profile is built on the full-resolution mask (a Euclidean distance transform
    in output pixels) and sampled bilinearly at the output pixel centres, so that the loss of the true
    joints is as low as the images allow and its minimum is not biased.
    """
    from scipy.ndimage import distance_transform_edt

    mask = np.asarray(mask, dtype=np.float64)
    inside = mask >= 0.5
    full = max(mask.shape)
    if inside.all() or not inside.any():
        profile = inside.astype(np.float64)
    else:
        outside_px = np.maximum(distance_transform_edt(~inside) - 0.5, 0.0) * (size / full)
        profile = np.where(inside, 1.0, 2.0 / (1.0 + np.exp(outside_px / tau)))
        profile[outside_px > cutoff * tau] = 0.0  # the renderer's halo ends there too
    tensor = torch.as_tensor(profile)[None, None]
    return F.interpolate(tensor, size=(size, size), mode="bilinear", align_corners=False)[0, 0].numpy()


def _welded(mesh):
    """Duplicate vertices merged, so that shared edges are found (see render.face_neighbours)."""
    import trimesh

    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)


def gradient_magnitude(image: torch.Tensor) -> torch.Tensor:
    """|grad I| by forward differences on the (H-1, W-1) interior."""
    dx = image[:-1, 1:] - image[:-1, :-1]
    dy = image[1:, :-1] - image[:-1, :-1]
    return torch.sqrt(dx * dx + dy * dy + 1e-8)


def silhouette_loss(sil: torch.Tensor, target: torch.Tensor, w_edge: float):
    """``(L_region + w_edge L_edge, L_region, L_edge)`` of a soft silhouette against a target mask."""
    region = 1.0 - 2.0 * (sil * target).sum() / (sil.sum() + target.sum() + 1e-8)
    target_grad = gradient_magnitude(target)
    edge = (gradient_magnitude(sil) - target_grad).abs().mean() / (target_grad.mean() + 1e-8)
    return region + w_edge * edge, region, edge


def fit(scene: OpenStateScene, hypotheses: dict[str, Hypothesis], active: list[str], stages: list[Stage],
        weights: LossWeights, lr_pivot: float = 0.01, lr_value: float = 0.03) -> FitResult:
    """Adam on the pivot offsets and open values of the ``active`` joints, coarse to fine.

    :param scene: the asset, camera and target
    :param hypotheses: every movable joint's hypothesis (inactive ones stay as they are)
    :param active: the joints to optimize
    :param stages: resolution levels, in order
    :param weights: loss weights
    :param lr_pivot: Adam step for pivot offsets (benchmark units)
    :param lr_value: Adam step for open values (rad or benchmark units)
    """
    params, start, groups = {}, {}, []
    for name in active:
        hyp = hypotheses[name]
        if hyp.type == "fixed":
            continue
        value = torch.tensor(float(hyp.value), dtype=torch.float64, requires_grad=True)
        groups.append({"params": [value], "lr": lr_value})
        pivot = None
        if hyp.type == "revolute":
            pivot = torch.tensor(hyp.pivot_offset, dtype=torch.float64, requires_grad=True)
            groups.append({"params": [pivot], "lr": lr_pivot})
        params[name] = (pivot, value)
        start[name] = (torch.as_tensor(hyp.pivot_offset, dtype=torch.float64), float(hyp.value))
    curve: list[float] = []
    loss_value = float("nan")
    if not groups:
        loss_value = scene.loss(hypotheses, stages[-1], weights)
        return FitResult(dict(hypotheses), loss_value, [loss_value])
    optimizer = torch.optim.Adam(groups)
    base_lrs = [g["lr"] for g in groups]
    for stage in stages:
        for step in range(stage.steps):
            # finer pixels, finer steps: the step shrinks with the pixel size (1 at 32 px), and decays
            decay = min(1.0, 32.0 / stage.size) * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * step / max(stage.steps, 1))))
            for group, lr in zip(optimizer.param_groups, base_lrs):
                group["lr"] = lr * decay
            optimizer.zero_grad()
            image_loss = scene.image_loss(hypotheses, stage, weights, params)
            reg = image_loss.new_zeros(()).double()
            for name, (pivot, value) in params.items():
                pivot0, value0 = start[name]
                if pivot is not None:
                    reg = reg + weights.lambda_t * ((pivot - pivot0) ** 2).sum()
                reg = reg + weights.lambda_theta * (value - value0) ** 2
            total = image_loss.double() + reg
            total.backward()
            optimizer.step()
            curve.append(float(total.detach()))
        loss_value = scene.loss(_with_params(hypotheses, params), stage, weights)
    return FitResult(_with_params(hypotheses, params), loss_value, curve)


def _with_params(hypotheses: dict[str, Hypothesis], params: dict) -> dict[str, Hypothesis]:
    out = dict(hypotheses)
    for name, (pivot, value) in params.items():
        out[name] = replace(hypotheses[name], value=float(value.detach()),
                            pivot_offset=pivot.detach().numpy().copy() if pivot is not None
                            else hypotheses[name].pivot_offset)
    return out


def canonical_sign(hyp: Hypothesis) -> Hypothesis:
    """``(axis, value)`` and ``(-axis, -value)`` are the same motion; keep the one with ``value >= 0``."""
    if hyp.type != "fixed" and hyp.value < 0:
        return replace(hyp, axis=-np.asarray(hyp.axis, float), value=-hyp.value)
    return hyp
