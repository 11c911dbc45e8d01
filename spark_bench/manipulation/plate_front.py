"""Where a sliding plate is grasped when its front gives nothing to take it by: a sliding window's sash, a
sliding panel or tray moves along its own broad face, and its face in the opening direction (the front the
grasp planner looks at first, :func:`~spark_bench.manipulation.grasp.outward_direction`) is a thin edge, often
inside the frame. People and robots take such a part by its broad face (a pull handle or a recess there,
or a suction cup dragging it by friction) and slide it along the joint. :func:`plate_outward` says from
which face; the grasp planner looks there when the front has nothing to pinch or its way in is blocked
(:func:`~spark_bench.manipulation.grasp.find_grasp`).

Not for parts turning in their own plane (a lever on a door or a toilet's tank, about the door's normal):
taken by their broad face, synth toilets' flush levers opened with the true hinge and with it reversed,
so the score would not tell a right hinge from a wrong one; synth safes' turn handles did not open.

The test is geometric (the part's extents, rays from a face into the rest of the object), never a label.
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.transforms import unit
from spark_bench.manipulation.features import LEVEL_BIN, face_normal, first_hit
from spark_bench.manipulation.handle_search import N_SAMPLES

#: A part is a sliding plate when its thinnest extent across its joint's axis is less than this fraction
#: of its extent along the axis. Measured: partnet_dev's, real_objects' and synth-v1's plates (a sash, an
#: oven's racks, a suitcase's telescoping handle) at most 0.081, their drawers at least 0.19; synth sashes
#: (Window seeds 5000-5099, 24 sliding) 0.05-0.138; synth drawers and trays (every other category, seeds
#: 6000-6014, 174) at least 0.151 (a printer's paper tray, a coffee machine's drip tray). The gap is narrow
#: on synth: a shallow tray counts as a plate only where its front has nothing to take it by, and then only
#: if a broad face of it is clear (a tray inside its machine is covered and keeps its front).
SLIDING_RATIO = 0.145
#: Rays cast from a face to tell whether the object stands in front of it (:func:`face_covered`): from
#: the face point nearest its centre, and from those a quarter of its extent from it along its two
#: directions; the face is covered when at least :data:`COVERED_RAYS` of the five meet the object.
QUARTER = 0.25
COVERED_RAYS = 3
#: Faces facing a direction: their normals within this cosine of it.
FACING_COS = 0.9


def plate_normal(points: np.ndarray, axis: np.ndarray) -> np.ndarray | None:
    """The direction across a plate sliding in its own plane (its thinnest across ``axis``), or None when
    the part is no such plate (:data:`SLIDING_RATIO`).

    :param points: the part's surface samples (world, at rest)
    :param axis: the joint's unit axis
    """
    across = points - points.mean(0)
    across = across - np.outer(across @ axis, axis)
    _, _, principal = np.linalg.svd(across, full_matrices=False)
    thin = unit(principal[1] - (principal[1] @ axis) * axis)
    if float(np.ptp(points @ thin)) >= SLIDING_RATIO * float(np.ptp(points @ axis)):
        return None
    return thin


def face_covered(points: np.ndarray, direction: np.ndarray, others, clear: float) -> bool:
    """Whether the rest of the object stands in front of the part's outermost face along ``direction``,
    within ``clear`` (m): at least :data:`COVERED_RAYS` of five rays from the face meet ``others``.

    :param points: the part's surface samples (world, at rest)
    :param direction: unit direction out of the face
    :param others: the mesh of the object's other links (world, at rest), or None
    :param clear: how far (m) in front of the face the rays go
    """
    if others is None or len(others.faces) == 0:
        return False
    depth = points @ direction
    face = points[depth > depth.max() - 2 * LEVEL_BIN]
    centre = face.mean(0)
    spread = face - centre
    # the face's two directions: its points' principal axes (the face is flat, across ``direction``)
    _, _, axes = np.linalg.svd(spread - np.outer(spread @ direction, direction), full_matrices=False)
    targets = [centre]
    for along in axes[:2]:
        reach = QUARTER * float(np.ptp(spread @ along))
        targets += [centre + reach * along, centre - reach * along]
    origins = [face[int(np.argmin(np.linalg.norm(face - t, axis=1)))] for t in targets]
    triangles = np.asarray(others.triangles)
    hits = sum(first_hit(triangles, origin[None], direction, 1e-4, clear) is not None for origin in origins)
    return hits >= COVERED_RAYS


def plate_outward(part, points: np.ndarray, axis: np.ndarray, others, object_centre: np.ndarray,
                  clear: float) -> np.ndarray | None:
    """The outward direction of the broad face to grasp a sliding plate from (:func:`plate_normal`), or
    None (no such plate, or both its broad faces covered by the rest of the object, :func:`face_covered`).
    Of its two broad faces, the uncovered one facing away from the object's centre most (a sash's outer
    face, not the one towards the other sash); the result is that face's area-weighted normal.

    :param part: the part's mesh (world, at rest)
    :param points: its surface samples
    :param axis: the joint's unit axis
    :param others: the mesh of the object's other links, or None
    :param object_centre: the centre of the object's bounding box
    :param clear: how far (m) in front of a face the object must not stand (the hand's way in)
    """
    thin = plate_normal(points, axis)
    if thin is None:
        return None
    away = points.mean(0) - object_centre
    for side in sorted((thin, -thin), key=lambda side: -float(away @ side)):
        if not face_covered(points, side, others, clear):
            return face_normal(part, side, min_cos=FACING_COS)
    return None


def plate_face(asset, joint: str, clear: float, seed: int = 0) -> np.ndarray | None:
    """The outward direction of the broad face a sliding plate moved by ``joint`` is taken by
    (:func:`plate_outward`), or None (not prismatic, no plate, or no broad face clear).

    :param asset: the object (or a :class:`~spark_bench.manipulation.rest_meshes.RestMeshes` of it)
    :param clear: how far (m) in front of a face the object must not stand (the hand's way in)
    :param seed: seed of the surface sampling
    """
    if asset.joints[joint].type != JointType.PRISMATIC:
        return None
    moving = asset.part_of_joint(joint)
    part = asset.mesh(links=moving)
    if len(part.faces) == 0:
        return None
    others = [name for name in asset.links if name not in moving]
    return plate_outward(part, sample_surface(part, N_SAMPLES, seed=seed), unit(asset.joint_frames()[joint][1]),
                         asset.mesh(links=others) if others else None, asset.mesh().bounds.mean(0), clear)
