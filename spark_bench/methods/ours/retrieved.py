"""The ``retrieval`` backends of ``ours``: structure prior and part geometry of a retrieved gallery object.

With ``[prior] backend = "retrieval"`` and/or ``[geometry] backend = "retrieval"`` the pipeline runs the
render-and-compare search of ``--method retrieval`` (:func:`spark_bench.methods.retrieval.search.retrieve`) once
per case, on the input image and the camera only, and both stages read that one :class:`Retrieval`:

- **prior** (:func:`retrieval_prior`): the retrieved object's parts (:func:`~spark_bench.methods.ours.geometry.group_parts`:
  a movable joint's child with everything fixed below it), their labels, joint types (continuous is
  revolute), axes, pivots and limits (the span ``upper - lower`` of each joint; a continuous joint gets
  the ``large`` revolute range). Axes are named in the gallery object's own frame turned by the search's
  yaw (:func:`yaw_axis_frame`), so a gallery object with canonical axes keeps them exactly; the prior
  says ``source = "retrieval"``;
- **geometry** (:func:`retrieval_geometry`): the retrieved object's part meshes in the benchmark frame,
  with the object itself (:attr:`PartGeometry.asset`); the prior's links are its parts by name when
  both stages retrieve (:func:`spark_bench.methods.ours.assemble.prior_names_the_parts`), else they are paired
  by structure.

The gallery is ``[retrieval] gallery`` (default ``synth-gallery-v1``), opened once per process. Like
``--method retrieval``, a gallery holding the case's own object fails the case
(:func:`~spark_bench.methods.retrieval.gallery.source_check`, by content hash); the report says how the check went.
Nothing of the ground truth is read: the case's record is read for its ``source`` (provenance) only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.methods.ours.geometry import PartGeometry, predicted_parts
from spark_bench.methods.ours.prior import ground_truth_structure
from spark_bench.methods.ours.structure import DEFAULT_UPPER, OBJECT_TO_WORLD, PriorStructure

if TYPE_CHECKING:
    from spark_bench.methods.base import CaseInput
    from spark_bench.methods.retrieval.gallery import Gallery
    from spark_bench.methods.retrieval.search import Retrieval

#: ``PriorStructure.source`` of a retrieved prior, and the prefix of a retrieved geometry's ``source``.
RETRIEVAL_SOURCE = "retrieval"
#: Open galleries by folder ("" for the default). :func:`~spark_bench.methods.retrieval.gallery.folder_gallery`
#: already hashes a folder once per process; this also skips its per-call change check (a walk of
#: every file: 0.24 s for the 75 objects of partnet_dev), so a folder edited mid-run is not seen.
_GALLERIES: dict[str, Gallery] = {}


def open_case_gallery(gallery: str) -> Gallery:
    """The gallery of ``[retrieval] gallery`` (``""``: the default ``synth-gallery-v1``), opened once.

    :raises InputError: for an empty or broken gallery folder
    """
    from spark_bench.methods.retrieval.gallery import open_gallery

    key = str(gallery or "")
    if key not in _GALLERIES:
        _GALLERIES[key] = open_gallery(key or None)
    return _GALLERIES[key]


def retrieve_case(case: CaseInput, gallery: str) -> Retrieval:
    """Retrieve the object of ``case``'s input image (its image and camera only) from ``gallery``.

    :param case: the case as ``ours`` sees it (``image`` and ``camera`` declared)
    :param gallery: the ``[retrieval] gallery`` setting
    :raises GalleryLeakError: when the gallery holds the case's own object
    :raises InputError: for an empty or broken gallery, an unreadable image or camera
    """
    from spark_bench.methods.retrieval.gallery import source_check
    from spark_bench.methods.retrieval.search import retrieve

    opened = open_case_gallery(gallery)
    check = source_check(case.case.record, opened)
    found = retrieve(case.image, case.camera, opened)
    found.record["gallery_check"] = check
    return found


def retrieval_summary(found: Retrieval) -> dict:
    """The report's short form of a retrieval: gallery, object, category, hashes, score, pose, check."""
    record = found.record
    keys = ("gallery", "gallery_hash", "object_id", "category", "object_hash", "score", "iou", "yaw_deg",
            "scale", "view", "gallery_check", "timings")
    return {k: record[k] for k in keys if k in record}


def yaw_axis_frame(yaw_deg: float) -> np.ndarray:
    """The 3x3 rotation (object frame) of a turn by ``yaw_deg`` about the world's up axis: the frame whose
    canonical directions are the retrieved gallery object's own (the search turns it by that yaw)."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return OBJECT_TO_WORLD.T @ turn @ OBJECT_TO_WORLD


def retrieval_prior(found: Retrieval) -> tuple[PriorStructure, np.ndarray]:
    """``(prior, axis frame)``: the retrieved object's structure (see the module docstring); assemble it
    with :func:`spark_bench.methods.ours.prior.assemble_prior` and the frame."""
    asset = found.asset
    frame = yaw_axis_frame(float(found.record.get("yaw_deg", 0.0)))
    structure = ground_truth_structure(asset, axis_frame=frame)
    for pj in structure.joints:
        joint = asset.joints[pj.name]
        span = float(joint.upper) - float(joint.lower)
        if joint.type == JointType.CONTINUOUS or not np.isfinite(span) or span <= 0.0:
            span = float(DEFAULT_UPPER[pj.type]["large"])
        pj.upper = span
    structure.source = RETRIEVAL_SOURCE
    return structure, frame


def retrieval_geometry(found: Retrieval) -> PartGeometry:
    """The retrieved object's part meshes (benchmark frame, at rest) with the object itself."""
    record = found.record
    out = predicted_parts(found.asset, f"{RETRIEVAL_SOURCE}:{record.get('gallery', '?')}/{record.get('object_id', '?')}")
    out.record = retrieval_summary(found)
    return out


__all__ = ["RETRIEVAL_SOURCE", "open_case_gallery", "retrieval_geometry", "retrieval_prior", "retrieval_summary",
           "retrieve_case", "yaw_axis_frame"]
