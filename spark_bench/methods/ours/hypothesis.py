"""The vocabulary of the continuous joint fit (:mod:`spark_bench.methods.ours.optimize`): a joint's
hypothesis, a resolution level, the objective's weights, a fit's result, and two facts of a hypothesis
(its part's rest box, its canonical sign) the searches around the fit use.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset


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
    ``w_part``, the weight of the per-part coverage term (used when the open state has part masks).
    Their defaults are the ``optimize`` section's (:class:`~spark_bench.methods.ours.config.OptimizeConfig`)."""

    w_edge: float
    lambda_t: float
    lambda_theta: float
    w_part: float


@dataclass
class FitResult:
    """What a fit returns: final hypotheses, final loss (at the last stage) and the loss curve."""

    hypotheses: dict[str, Hypothesis]
    loss: float
    curve: list[float]


def child_box(asset: ArticulatedAsset, joint: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The rest bounding box of the joint's part (its child and the links fixed to it) in the child's
    link frame, or None when the part has no geometry."""
    meshes = asset.link_meshes(links=asset.part_of_joint(joint))
    if not meshes:
        return None
    world = np.concatenate([m.vertices for m in meshes.values()])
    pose = asset.link_poses()[asset.joints[joint].child]
    local = (world - pose[:3, 3]) @ pose[:3, :3]
    return local.min(axis=0), local.max(axis=0)


def canonical_sign(hyp: Hypothesis) -> Hypothesis:
    """``(axis, value)`` and ``(-axis, -value)`` are the same motion; keep the one with ``value >= 0``."""
    if hyp.type != JointType.FIXED and hyp.value < 0:
        return replace(hyp, axis=-np.asarray(hyp.axis, float), value=-hyp.value)
    return hyp
