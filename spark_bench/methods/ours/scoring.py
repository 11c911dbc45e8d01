"""Segmentation mismatch of posed hypotheses: the exact (not differentiable) score of the discrete refinement.

A hypothesis set is posed, z-buffered into a label image (:func:`~spark_bench.methods.ours.render.rasterize_labels`)
and compared with the open state's label image: with part masks, the mean of ``1 - IoU`` over the whole
object and every link that is visible in either image (so a small part weighs as much as a large one in
its own joint's decision); without, ``1 - IoU`` of the object's silhouette. With ``blur > 0`` both
indicator images are blurred by a Gaussian of that many pixels and compared by soft IoU
(``sum min / sum max``), which stays low within about ``blur`` pixels of motion (used to rank candidates
from a coarse grid of open values).

:class:`JointScorer` scores many hypotheses of one joint fast: the links that do not move with the joint
are z-buffered once; the links that do are posed by one rigid motion of the world (a rotation about the
hypothesis's axis line or a translation along it, from where they are with that joint at rest), and many
poses are rasterized in one batched call.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import torch

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.methods.ours.render import compose_labels, rasterize_labels_depth_batch

#: Poses rasterized per batched call (bounds the memory of the pixel pairs).
BATCH = 48


def mismatch(rendered: np.ndarray, target: np.ndarray, part_labels: Sequence[int], blur: float,
             blurred_target: Callable[[int, np.ndarray], np.ndarray]) -> np.ndarray:
    """The score (see the module docstring) of each rendered label image against ``target``.

    :param rendered: (B, H, W) label images (0 background, ``g + 1`` for link ``g``)
    :param target: (H, W) target labels (0 background, ``g + 1`` for link ``g``'s mask, -1 for object
        pixels of no known link)
    :param part_labels: the labels ``g + 1`` of the links that have a mask (empty: object only)
    :param blur: Gaussian sigma in pixels (0: exact IoU)
    :param blurred_target: ``(label, indicator) -> blurred indicator`` of the target (cached by the
        caller; label 0 is the whole object)
    :returns: (B,) scores in [0, 1], lower is better
    """
    rendered = np.asarray(rendered)
    labels = [0, *part_labels]
    mine = np.stack([rendered > 0] + [rendered == g for g in part_labels])  # (R, B, H, W)
    theirs = np.stack([target != 0] + [target == g for g in part_labels])  # (R, H, W)
    counted = np.ones(mine.shape[:2], dtype=bool)
    counted[1:] = mine[1:].any(axis=(2, 3)) | theirs[1:].any(axis=(1, 2))[:, None]
    iou = np.empty(mine.shape[:2])
    # a region drawn alike in every image (a part the scored joint never covers) is compared once
    alike = np.array([bool((m == m[:1]).all()) for m in mine])
    for rows, images in ((np.nonzero(~alike)[0], slice(None)), (np.nonzero(alike)[0], slice(0, 1))):
        if len(rows):
            iou[rows] = _iou(mine[rows][:, images], theirs[rows], [labels[r] for r in rows], blur, blurred_target)
    return ((1.0 - iou) * counted).sum(axis=0) / counted.sum(axis=0)


def _iou(mine: np.ndarray, theirs: np.ndarray, labels: list[int], blur: float,
         blurred_target: Callable[[int, np.ndarray], np.ndarray]) -> np.ndarray:
    """(R, B) IoU (blur 0) or soft IoU of indicator images (R, B, H, W) against targets (R, H, W)."""
    if blur <= 0:
        inter = (mine & theirs[:, None]).sum(axis=(2, 3))
        union = (mine | theirs[:, None]).sum(axis=(2, 3))
        return np.where(union > 0, inter / np.maximum(union, 1), 1.0)
    soft = gaussian_blur(mine.astype(np.float64), blur)
    soft_target = np.stack([blurred_target(g, t) for g, t in zip(labels, theirs)])[:, None]
    union = np.maximum(soft, soft_target).sum(axis=(2, 3))
    inter = np.minimum(soft, soft_target).sum(axis=(2, 3))
    return np.where(union > 1e-9, inter / np.where(union > 1e-9, union, 1.0), 1.0)


def gaussian_blur(images: np.ndarray, sigma: float) -> np.ndarray:
    """Blur the last two axes of ``images`` by a Gaussian of ``sigma`` pixels (zero outside)."""
    from scipy.ndimage import gaussian_filter

    sigmas = (0.0,) * (images.ndim - 2) + (sigma, sigma)
    return gaussian_filter(images, sigmas, mode="constant", truncate=3.0)


def rigid_motions(hypotheses: Sequence, parent_pose: np.ndarray, origin: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """World rotations (B, 3, 3) and translations (B, 3) by which each hypothesis moves its part from
    where the part is with the joint at rest: ``x -> R x + t``.

    The joint's child is posed at ``P O' M(q) O'^-1 O`` (``P`` the parent's world pose, ``O`` the joint
    origin, ``O'`` the origin with its translation shifted by the pivot offset, ``M`` the motion), so
    relative to rest it moves by ``P O' M O'^-1 P^-1``: a rotation by ``q`` about the world line through
    ``P (o + pivot offset)`` along ``P_R O_R axis``, or a translation by ``q`` along that direction.

    :param hypotheses: the joint's hypotheses (``type``, ``axis`` in the joint frame, ``pivot_offset`` in
        the parent frame, ``value``)
    :param parent_pose: (4, 4) world pose of the joint's parent link
    :param origin: (4, 4) the joint's origin in the parent frame
    """
    frame = parent_pose[:3, :3] @ origin[:3, :3]
    rotations = np.tile(np.eye(3), (len(hypotheses), 1, 1))
    translations = np.zeros((len(hypotheses), 3))
    for k, hyp in enumerate(hypotheses):
        if hyp.type == JointType.FIXED:
            continue
        direction = frame @ np.asarray(hyp.axis, float)
        direction = direction / np.linalg.norm(direction)
        if hyp.type == JointType.PRISMATIC:
            translations[k] = hyp.value * direction
            continue
        centre = parent_pose[:3, :3] @ (origin[:3, 3] + np.asarray(hyp.pivot_offset, float)) + parent_pose[:3, 3]
        rotation = axis_angle_matrix(direction, hyp.value)
        rotations[k], translations[k] = rotation, centre - rotation @ centre
    return rotations, translations


class JointScorer:
    """Scores of many hypotheses of one joint, the other joints fixed (see the module docstring).

    :param scene: an :class:`~spark_bench.methods.ours.optimize.OpenStateScene`
    :param hypotheses: every movable joint's hypothesis (the scored joint's is replaced)
    :param joint: the joint whose hypotheses are scored
    :param size: image size in pixels
    :param blur: Gaussian blur of the score (0: exact IoU)
    """

    def __init__(self, scene, hypotheses: dict, joint: str, size: int, blur: float = 0.0):
        self.scene, self.size, self.blur = scene, int(size), float(blur)
        self.camera = scene.camera.resized(size)
        joint_obj = scene.asset.joints[joint]
        moving_links = scene.moving_link_indices([joint])
        moving = np.isin(np.arange(len(scene.link_names)), moving_links)
        face_groups = scene.face_groups.numpy()
        faces = scene.faces.numpy()
        face_moving = moving[face_groups] if len(face_groups) else np.zeros(0, bool)
        at_rest = {**hypotheses}
        if joint in at_rest:
            at_rest[joint] = replace(at_rest[joint], value=0.0)
        with torch.no_grad():
            poses = scene.link_poses(at_rest)
            vertices = scene.world_vertices_from(poses).numpy()
        self.parent_pose = poses[joint_obj.parent].numpy()
        self.origin = np.asarray(joint_obj.origin, float)
        still_labels, still_depth = rasterize_labels_depth_batch(
            vertices[None], faces[~face_moving], face_groups[~face_moving] + 1, self.camera)
        self.still_labels, self.still_depth = still_labels[0], still_depth[0]
        vertex_moving = moving[scene.vertex_groups]
        self.moving_vertices = vertices[vertex_moving]
        remap = np.cumsum(vertex_moving) - 1
        self.moving_faces = remap[faces[face_moving]]
        self.moving_labels = face_groups[face_moving] + 1

    def scores(self, hypotheses: Sequence) -> np.ndarray:
        """(B,) scores of the joint's ``hypotheses`` (lower is better)."""
        out = np.zeros(len(hypotheses))
        for start in range(0, len(hypotheses), BATCH):
            chunk = hypotheses[start:start + BATCH]
            rotations, translations = rigid_motions(chunk, self.parent_pose, self.origin)
            posed = np.einsum("bij,nj->bni", rotations, self.moving_vertices) + translations[:, None]
            labels, depth = rasterize_labels_depth_batch(posed, self.moving_faces, self.moving_labels, self.camera)
            composed = compose_labels(labels, depth, self.still_labels, self.still_depth)
            out[start:start + len(chunk)] = self.scene.mismatch(composed, self.size, self.blur)
        return out

    def __call__(self, hypothesis) -> float:
        return float(self.scores([hypothesis])[0])
