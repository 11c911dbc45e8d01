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

from dataclasses import dataclass, replace

import numpy as np
import torch

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.torch_fk import joint_transform_torch, link_poses_torch
from spark_bench.methods.ours.adam import Adam
from spark_bench.methods.ours.camera import Camera
from spark_bench.methods.ours.hypothesis import FitResult, Hypothesis, LossWeights, Stage
from spark_bench.methods.ours.loss import halo_target, silhouette_loss
from spark_bench.methods.ours.render import (
    SoftSilhouetteRenderer,
    downsample_mask,
    rasterize_labels_depth_batch,
)
from spark_bench.methods.ours.scoring import JointScorer, gaussian_blur, mismatch
from spark_bench.methods.ours.simplify import render_mesh

#: The fewest faces a link's rendered mesh is decimated to (see :class:`OpenStateScene`'s ``max_faces``).
MIN_FACES = 100
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
    :param max_faces: face budget for rendering of a link as large as the object; a smaller link gets
        the share of its size (longest side), at least :data:`MIN_FACES` (a button of 5 % of the object
        covers a few pixels: 600 faces of it cost the renderer their padded bounding boxes and draw
        nothing more than 100 do)
    :param part_masks: optional (H, W) visible mask of each link in the open-state image (e.g. the
        case's open part masks), keyed by the asset's link names; links without one are unconstrained
    """

    def __init__(self, asset: ArticulatedAsset, camera: Camera, target: np.ndarray, max_faces: int = 600,
                 part_masks: dict[str, np.ndarray] | None = None):
        self.asset = asset
        self.link_names, verts, faces, groups, offset = [], [], [], [], 0
        meshes = {name: link.merged_mesh() for name, link in asset.links.items() if link.has_geometry}
        sizes = {name: float(np.ptp(np.asarray(m.vertices), axis=0).max()) if len(m.vertices) else 0.0
                 for name, m in meshes.items()}
        whole = max(sizes.values(), default=0.0) or 1.0
        for name, merged in meshes.items():
            budget = max(MIN_FACES, int(round(max_faces * min(1.0, sizes[name] / whole))))
            mesh = render_mesh(merged, min(budget, max_faces) if max_faces > MIN_FACES else max_faces)
            groups.append(torch.full((len(mesh.faces),), len(self.link_names), dtype=torch.long))
            self.link_names.append(name)
            verts.append(torch.as_tensor(mesh.vertices, dtype=torch.float64))
            faces.append(torch.as_tensor(np.asarray(mesh.faces), dtype=torch.long) + offset)
            offset += len(mesh.vertices)
        self.link_vertices = verts
        self.vertex_groups = np.repeat(np.arange(len(verts)), [len(v) for v in verts]).astype(np.int64)
        self.faces = torch.cat(faces) if faces else torch.zeros((0, 3), dtype=torch.long)
        self.face_groups = torch.cat(groups) if groups else torch.zeros((0,), dtype=torch.long)
        target = np.asarray(target, dtype=np.float64)
        x0, y0, side = _window(target, camera, self._rest_vertices())
        self.window = (x0, y0, side)
        self.image_size = max(camera.width, camera.height)
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
        self._subsets: dict[tuple, tuple[torch.Tensor, torch.Tensor]] = {}
        self._still: dict[tuple, torch.Tensor] = {}
        self._base_poses: dict[tuple, dict[str, torch.Tensor]] = {}
        self._below: dict[str, set[str]] = {}

    def crop(self, image: np.ndarray) -> np.ndarray:
        """A (H, W) image of the camera's size cut to the scene's window (zero-padded outside the image)."""
        return _crop(np.asarray(image, dtype=np.float64), *self.window)

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

    def link_poses(self, hypotheses: dict[str, Hypothesis], params: dict | None = None) -> dict[str, torch.Tensor]:
        """World pose (4x4, float64) of every link at the open state; ``params`` holds tensors replacing
        pivot offsets / values (see :func:`fit`).

        With ``params``, only the links below their joints are posed with autograd; the others come from
        one forward kinematics without gradients, kept for the next calls with the same other joints
        (an object with twenty joints then costs per step what its fitted joints' subtrees cost)."""
        if not params:
            with torch.no_grad():
                return self._poses(hypotheses, {})
        key = _fingerprint(hypotheses, exclude=list(params))
        if key not in self._base_poses:
            if len(self._base_poses) >= 16:
                self._base_poses.clear()
            with torch.no_grad():
                self._base_poses[key] = self._poses(hypotheses, {})
        poses = dict(self._base_poses[key])
        moving = set().union(*(self._moving_links(j) for j in params))
        for joint in self.asset.topological_joints():
            if joint.child not in moving:
                continue
            hyp = hypotheses.get(joint.name)
            if hyp is None:  # not a hypothesis (the root joint, fixed joints): at rest, as in the asset
                local = joint_transform_torch(joint, joint.rest_value if joint.is_movable else 0.0)
            else:
                pivot, value = params.get(joint.name, (None, None))
                local = joint_transform_torch(
                    joint, value if value is not None else (float(hyp.value) if hyp.type != JointType.FIXED else 0.0),
                    axis=torch.as_tensor(hyp.axis, dtype=torch.float64),
                    pivot_offset=pivot if pivot is not None else torch.as_tensor(hyp.pivot_offset, dtype=torch.float64),
                    joint_type=hyp.type)
            poses[joint.child] = poses[joint.parent] @ local
        return poses

    def _poses(self, hypotheses: dict[str, Hypothesis], params: dict) -> dict[str, torch.Tensor]:
        """:func:`~spark_bench.asset.torch_fk.link_poses_torch` of the hypotheses, ``params`` replacing."""
        q, pivots, axes, types = {}, {}, {}, {}
        for name, hyp in hypotheses.items():
            pivot, value = params.get(name, (None, None))
            types[name] = hyp.type
            axes[name] = torch.as_tensor(hyp.axis, dtype=torch.float64)
            pivots[name] = pivot if pivot is not None else torch.as_tensor(hyp.pivot_offset, dtype=torch.float64)
            q[name] = value if value is not None else float(hyp.value) if hyp.type != JointType.FIXED else 0.0
        return link_poses_torch(self.asset, q=q, pivot_offsets=pivots, axes=axes, types=types)

    def world_vertices_from(self, poses: dict[str, torch.Tensor], links: list[int] | None = None) -> torch.Tensor:
        """The vertices of ``links`` (indices into :attr:`link_names`; default all), posed, float64."""
        links = range(len(self.link_names)) if links is None else links
        parts = [self.link_vertices[g] @ poses[self.link_names[g]][:3, :3].T + poses[self.link_names[g]][:3, 3]
                 for g in links]
        return torch.cat(parts) if parts else torch.zeros((0, 3), dtype=torch.float64)

    def world_vertices(self, hypotheses: dict[str, Hypothesis], params: dict | None = None) -> torch.Tensor:
        """World vertices at the open state (float32); ``params`` holds tensors replacing pivot offsets /
        values."""
        return self.world_vertices_from(self.link_poses(hypotheses, params)).float()

    def moving_link_indices(self, joints: list[str]) -> list[int]:
        """Indices into :attr:`link_names` of the links that move with any of ``joints``."""
        moving = set().union(*(self._moving_links(j) for j in joints)) if joints else set()
        return [g for g, n in enumerate(self.link_names) if n in moving]

    def _subset(self, links: list[int]) -> tuple[torch.Tensor, torch.Tensor]:
        """Faces of ``links`` indexed into their concatenated vertices, and each face's position in
        ``links``."""
        key = tuple(links)
        if key not in self._subsets:
            faces, groups, offset = [], [], 0
            starts = np.concatenate([[0], np.cumsum([len(v) for v in self.link_vertices])])
            for k, g in enumerate(links):
                mine = self.face_groups == g
                faces.append(self.faces[mine] - int(starts[g]) + offset)
                groups.append(torch.full((int(mine.sum()),), k, dtype=torch.long))
                offset += len(self.link_vertices[g])
            self._subsets[key] = (torch.cat(faces) if faces else torch.zeros((0, 3), dtype=torch.long),
                                  torch.cat(groups) if groups else torch.zeros((0,), dtype=torch.long))
        return self._subsets[key]

    def render(self, hypotheses: dict[str, Hypothesis], stage: Stage, params: dict | None = None) -> torch.Tensor:
        """The whole object's soft silhouette (size, size)."""
        return self.renderer(stage.size, stage.tau).render(self.world_vertices(hypotheses, params), self.faces)

    def render_parts(self, hypotheses: dict[str, Hypothesis], stage: Stage, params: dict | None = None,
                     links: list[int] | None = None) -> torch.Tensor:
        """One soft silhouette per link with geometry, (G, size, size), in :attr:`link_names` order (or of
        ``links`` only, in their order)."""
        renderer = self.renderer(stage.size, stage.tau)
        if links is None:
            return renderer.render(self.world_vertices(hypotheses, params), self.faces, self.face_groups,
                                   len(self.link_names))
        faces, groups = self._subset(links)
        vertices = self.world_vertices_from(self.link_poses(hypotheses, params), links).float()
        return renderer.render(vertices, faces, groups, len(links))

    def still_parts(self, hypotheses: dict[str, Hypothesis], active: list[str], stage: Stage) -> StillParts:
        """The per-link images of the links that ``active`` joints do not move, rendered once for a fit
        (and kept for the next fits with the same other joints: the short fits of one joint's candidates)."""
        moving = self.moving_link_indices(active)
        key = (stage.size, stage.tau, tuple(moving), _fingerprint(hypotheses, exclude=active))
        if key not in self._still:
            still = [g for g in range(len(self.link_names)) if g not in moving]
            images = torch.zeros((len(self.link_names), stage.size, stage.size))
            if still:
                with torch.no_grad():
                    images[still] = self.render_parts(hypotheses, stage, None, still)
            if len(self._still) >= 16:
                self._still.clear()
            self._still[key] = images
        return StillParts(moving, self._still[key])

    def image_loss(self, hypotheses: dict[str, Hypothesis], stage: Stage, weights: LossWeights,
                   params: dict | None = None, still: StillParts | None = None) -> torch.Tensor:
        """``L_region + w_edge L_edge (+ w_part L_part)`` of the hypotheses, differentiable in ``params``.

        ``L_part`` (only with part masks) is the mean over links with a visible mask of ``1 - recall``,
        the fraction of the link's visible pixels that its rendered silhouette does not cover. Recall,
        not Dice: the masks are what is visible, so a correctly posed part may be partly hidden by
        another, and only its silhouette's coverage of its own visible pixels is free of occlusion bias.

        :param still: images of the links that ``params`` do not move (:meth:`still_parts`, at this
            stage): only the others are rendered (the same loss, at the cost of the moving parts only)
        """
        use_parts = self.has_part_masks and weights.w_part != 0
        if still is not None:
            moved = self.render_parts(hypotheses, stage, params, still.moving)
            parts = still.images.index_copy(0, torch.as_tensor(still.moving, dtype=torch.long), moved)
        elif use_parts:
            parts = self.render_parts(hypotheses, stage, params)
        else:
            total, _, _ = silhouette_loss(self.render(hypotheses, stage, params),
                                          self.target(stage.size, stage.tau), weights.w_edge)
            return total
        total, _, _ = silhouette_loss(parts.amax(dim=0), self.target(stage.size, stage.tau), weights.w_edge)
        if not use_parts:
            return total
        masks, weight = self.part_targets(stage.size)
        recall = (parts * masks).sum(dim=(1, 2)) / masks.sum(dim=(1, 2)).clamp_min(1e-6)
        part_loss = ((1.0 - recall) * weight).sum() / weight.sum().clamp_min(1.0)
        return total + weights.w_part * part_loss

    def loss(self, hypotheses: dict[str, Hypothesis], stage: Stage, weights: LossWeights) -> float:
        """The image loss (no regularizer) of fixed hypotheses, without gradients."""
        with torch.no_grad():
            return float(self.image_loss(hypotheses, stage, weights))

    def seg_score(self, hypotheses: dict[str, Hypothesis], size: int, blur: float = 0.0) -> float:
        """Segmentation mismatch in [0, 1] of fixed hypotheses at ``size`` px (lower is better; see
        :mod:`spark_bench.methods.ours.scoring`): the posed meshes z-buffered into a label image
        (:func:`~spark_bench.methods.ours.render.rasterize_labels`) against :meth:`target_labels`.

        :param blur: 0 for the exact IoU; otherwise the Gaussian blur (px) of the soft IoU
        """
        with torch.no_grad():
            vertices = self.world_vertices_from(self.link_poses(hypotheses)).numpy()
        face_labels = self.face_groups.numpy() + 1
        rendered, _ = rasterize_labels_depth_batch(vertices[None], self.faces.numpy(), face_labels,
                                                   self.camera.resized(size))
        return float(self.mismatch(rendered, size, blur)[0])

    def seg_scorer(self, hypotheses: dict[str, Hypothesis], joint: str, size: int, blur: float = 0.0
                   ) -> JointScorer:
        """``h -> seg_score({**hypotheses, joint: h}, size, blur)`` for many hypotheses of one joint
        (:class:`~spark_bench.methods.ours.scoring.JointScorer`; ``.scores(list)`` scores a batch)."""
        return JointScorer(self, hypotheses, joint, size, blur)

    def _moving_links(self, joint: str) -> set[str]:
        """The links below ``joint`` (its child and everything under it)."""
        if joint not in self._below:
            out, stack = set(), [self.asset.joints[joint].child]
            while stack:
                link = stack.pop()
                out.add(link)
                stack.extend(j.child for j in self.asset.joints.values() if j.parent == link)
            self._below[joint] = out
        return self._below[joint]

    def mismatch(self, rendered: np.ndarray, size: int, blur: float) -> np.ndarray:
        """The score of :meth:`seg_score` for (B, size, size) rendered label images (1 + index into
        ``link_names``)."""
        part_labels = [g + 1 for g, n in enumerate(self.link_names) if n in self.part_masks_full]
        return mismatch(rendered, self.target_labels(size), part_labels, blur,
                        lambda label, indicator: self._blurred_target(size, blur, label, indicator))

    def _blurred_target(self, size: int, blur: float, key, indicator: np.ndarray) -> np.ndarray:
        if (size, blur, key) not in self._blurred:
            self._blurred[(size, blur, key)] = gaussian_blur(indicator.astype(np.float64), blur)
        return self._blurred[(size, blur, key)]


def _fingerprint(hypotheses: dict[str, Hypothesis], exclude: list[str]) -> tuple:
    """A hashable summary of the hypotheses of the joints not in ``exclude``."""
    return tuple((n, h.type, np.asarray(h.axis, float).tobytes(), np.asarray(h.pivot_offset, float).tobytes(),
                  float(h.value)) for n, h in sorted(hypotheses.items()) if n not in exclude)


@dataclass
class StillParts:
    """Per-link images (G, size, size) of a fit's stage, of which the ``moving`` links are re-rendered
    at every step (:meth:`OpenStateScene.image_loss`)."""

    moving: list[int]
    images: torch.Tensor


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


def fit(scene: OpenStateScene, hypotheses: dict[str, Hypothesis], active: list[str], stages: list[Stage],
        weights: LossWeights, lr_pivot: float, lr_value: float) -> FitResult:
    """Adam on the pivot offsets and open values of the ``active`` joints, coarse to fine.

    :param scene: the asset, camera and target
    :param hypotheses: every movable joint's hypothesis (inactive ones stay as they are)
    :param active: the joints to optimize
    :param stages: resolution levels, in order
    :param weights: loss weights
    :param lr_pivot: Adam step for pivot offsets (benchmark units)
    :param lr_value: Adam step for open values (rad or benchmark units)
    """
    params, start, tensors, lrs = {}, {}, [], []
    for name in active:
        hyp = hypotheses[name]
        if hyp.type == JointType.FIXED:
            continue
        value = torch.tensor(float(hyp.value), dtype=torch.float64, requires_grad=True)
        tensors.append(value)
        lrs.append(lr_value)
        pivot = None
        if hyp.type == JointType.REVOLUTE:
            pivot = torch.tensor(hyp.pivot_offset, dtype=torch.float64, requires_grad=True)
            tensors.append(pivot)
            lrs.append(lr_pivot)
        params[name] = (pivot, value)
        start[name] = (torch.as_tensor(hyp.pivot_offset, dtype=torch.float64), float(hyp.value))
    curve: list[float] = []
    loss_value = float("nan")
    if not tensors:
        loss_value = scene.loss(hypotheses, stages[-1], weights)
        return FitResult(dict(hypotheses), loss_value, [loss_value])
    optimizer = Adam(tensors, lrs)
    for stage in stages:
        still = scene.still_parts(hypotheses, list(params), stage)
        for step in range(stage.steps):
            # finer pixels, finer steps: the step shrinks with the pixel size (1 at 32 px), and decays
            decay = min(1.0, 32.0 / stage.size) * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * step / max(stage.steps, 1))))
            optimizer.zero_grad()
            image_loss = scene.image_loss(hypotheses, stage, weights, params, still)
            reg = image_loss.new_zeros(()).double()
            for name, (pivot, value) in params.items():
                pivot0, value0 = start[name]
                if pivot is not None:
                    reg = reg + weights.lambda_t * ((pivot - pivot0) ** 2).sum()
                reg = reg + weights.lambda_theta * (value - value0) ** 2
            total = image_loss.double() + reg
            total.backward()
            optimizer.step(decay)
            curve.append(float(total.detach()))
        with torch.no_grad():
            loss_value = float(scene.image_loss(_with_params(hypotheses, params), stage, weights, None, still))
    return FitResult(_with_params(hypotheses, params), loss_value, curve)


def _with_params(hypotheses: dict[str, Hypothesis], params: dict) -> dict[str, Hypothesis]:
    out = dict(hypotheses)
    for name, (pivot, value) in params.items():
        out[name] = replace(hypotheses[name], value=float(value.detach()),
                            pivot_offset=pivot.detach().numpy().copy() if pivot is not None
                            else hypotheses[name].pivot_offset)
    return out
