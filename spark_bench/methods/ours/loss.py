"""The loss of SPARK's joint optimization (paper section 3.3) and the target it compares against.

``L = L_region + w_edge L_edge``: ``L_region = 1 - Dice`` of the soft silhouette and the open-state
mask, ``L_edge`` the mean L1 difference of their gradient magnitudes (normalized by the target's). The
regularizer ``L_reg`` is added by the fit (:func:`spark_bench.methods.ours.optimize.fit`), which knows the
offsets.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from spark_bench.methods.ours import exact
from spark_bench.methods.ours.render import HALO_CUTOFF


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


def gradient_magnitude(image: torch.Tensor) -> torch.Tensor:
    """|grad I| by forward differences on the (H-1, W-1) interior."""
    dx = image[:-1, 1:] - image[:-1, :-1]
    dy = image[1:, :-1] - image[:-1, :-1]
    return exact.sqrt(dx * dx + dy * dy + 1e-8)


def silhouette_loss(sil: torch.Tensor, target: torch.Tensor, w_edge: float):
    """``(L_region + w_edge L_edge, L_region, L_edge)`` of a soft silhouette against a target mask."""
    region = 1.0 - 2.0 * (sil * target).sum() / (sil.sum() + target.sum() + 1e-8)
    target_grad = gradient_magnitude(target)
    edge = (gradient_magnitude(sil) - target_grad).abs().mean() / (target_grad.mean() + 1e-8)
    return region + w_edge * edge, region, edge
