"""Continuous joint optimization (paper section 3.3): differentiable FK + soft silhouettes + Adam.

For each movable joint the learnable parameters are ``xi = (dt, dtheta)``: ``dt`` moves the joint's axis
line in the parent frame while the part stays where it is at rest (``pivot_offsets`` of
:func:`~spark_bench.asset.torch_fk.link_poses_torch`; prismatic joints have no pivot, so no ``dt``),
and the open value (angle or displacement) starts from the prior's upper limit. The open state
``M^t = G(M^0, dt, theta)`` is rendered as a soft silhouette and compared with the open-state mask:

``L = L_region + w_edge L_edge + lambda_t |dt - dt0|^2 + lambda_theta |theta - theta0|^2``

with ``L_region = 1 - 2 <S, T> / (|S|_1 + |T|_1)`` (soft Dice), ``L_edge`` the L1 distance between the
gradient magnitudes of the two images divided by the target's mean gradient magnitude (so it does not
depend on the resolution), and the regularizer keeping each parameter near where this fit started.
Optimization runs coarse to fine: a list of (size, tau, steps) stages, the learning rate decaying
within each stage.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import torch
import torch.nn.functional as F

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.torch_fk import link_poses_torch
from spark_bench.spark.camera import Camera
from spark_bench.spark.geometry import decimate
from spark_bench.spark.render import SoftSilhouetteRenderer


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
    """Weights of the objective: ``w_edge``, ``lambda_t`` (pivot), ``lambda_theta`` (open value)."""

    w_edge: float = 0.2
    lambda_t: float = 0.01
    lambda_theta: float = 0.001


@dataclass
class FitResult:
    """What a fit returns: final hypotheses, final loss (at the last stage) and the loss curve."""

    hypotheses: dict[str, Hypothesis]
    loss: float
    curve: list[float]


class OpenStateScene:
    """An asset's decimated meshes as tensors, rendered at the open state of a set of hypotheses.

    :param asset: the assembled asset (rest geometry fixed)
    :param camera: the view of the open-state image
    :param target: (H, W) open-state mask in [0, 1] at any resolution
    :param max_faces: per-link face budget for rendering
    """

    def __init__(self, asset: ArticulatedAsset, camera: Camera, target: np.ndarray, max_faces: int = 600):
        self.asset = asset
        self.camera = camera
        self.target_full = np.asarray(target, dtype=np.float64)
        self.link_names, verts, faces, offset = [], [], [], 0
        for name, link in asset.links.items():
            if not link.has_geometry:
                continue
            mesh = decimate(_welded(link.merged_mesh()), max_faces)
            self.link_names.append(name)
            verts.append(torch.as_tensor(mesh.vertices, dtype=torch.float64))
            faces.append(torch.as_tensor(np.asarray(mesh.faces), dtype=torch.long) + offset)
            offset += len(mesh.vertices)
        self.link_vertices = verts
        self.faces = torch.cat(faces) if faces else torch.zeros((0, 3), dtype=torch.long)
        self._renderers: dict[tuple, SoftSilhouetteRenderer] = {}
        self._targets: dict[tuple, torch.Tensor] = {}

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
        return self.renderer(stage.size, stage.tau).render(self.world_vertices(hypotheses, params), self.faces)

    def loss(self, hypotheses: dict[str, Hypothesis], stage: Stage, weights: LossWeights) -> float:
        """The image loss (no regularizer) of fixed hypotheses, without gradients."""
        with torch.no_grad():
            total, _, _ = silhouette_loss(self.render(hypotheses, stage), self.target(stage.size, stage.tau),
                                             weights.w_edge)
        return float(total)


def halo_target(mask: np.ndarray, size: int, tau: float) -> np.ndarray:
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
        target = scene.target(stage.size, stage.tau)
        for step in range(stage.steps):
            # finer pixels, finer steps: the step shrinks with the pixel size (1 at 32 px), and decays
            decay = min(1.0, 32.0 / stage.size) * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * step / max(stage.steps, 1))))
            for group, lr in zip(optimizer.param_groups, base_lrs):
                group["lr"] = lr * decay
            optimizer.zero_grad()
            image_loss, _, _ = silhouette_loss(scene.render(hypotheses, stage, params), target, weights.w_edge)
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
