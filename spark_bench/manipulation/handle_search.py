"""Where a part's handle candidates are looked for (:mod:`spark_bench.manipulation.grasp`): the part's own links
labelled ``handle``, the labelled handles of parts hinged to it (a safe's lever), and its geometry
standing proud of the front face (with the parts hinged to it: a dial, a knob); which links move with a
part but are parts of their own; and which points of a labelled handle are grasped (:func:`on_handle`).
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.manipulation.features import MIN_CLUSTER, Front, clusters, long_axis, proud_samples
from spark_bench.manipulation.gripper import GripperConfig
from spark_bench.manipulation.pads import OBSTACLE_MIN_PROUD, SWEEP_MARGIN

#: A surface point counts as handle when it stands this far (m) in front of the front face (twice
#: :data:`~spark_bench.manipulation.pads.OBSTACLE_MIN_PROUD`, what counts as in the fingers' way).
HANDLE_MIN_PROUD = 2 * OBSTACLE_MIN_PROUD  # 8 mm
#: Surface samples per part.
N_SAMPLES = 20000
#: Surface samples of a labelled handle, or of the parts hinged to the grasped one.
N_HANDLE_SAMPLES = 4000
#: Sample spacing (m) on a small part hinged to the grasped one (:func:`_hinged_samples`).
HINGED_SPACING = 0.0015
#: A labelled handle's grasp point must lie over the handle itself: within this distance (m), in the
#: front plane, of a handle point. A bucket's bail is an arc: its bounding box's center is in the air.
HANDLE_ON_TOLERANCE = 0.006
#: A handle reached over its far end (a revolute part's tip): points this close (m) to the handle point
#: farthest from the hinge.
HANDLE_TIP_BAND = 0.02
#: How far (m) around a handle, in the front plane, the surface it stands on is looked at (a pad's thickness
#: and margin: what the pads would touch reaching down beside it).
BASE_MARGIN = 0.016
#: A feature is elongated (pinched across its width, :func:`feature_base`) when it is this many times longer than
#: wide in the front plane.
ELONGATED = 2.0
#: The pads' extent along an elongated handle (m): :class:`GripperConfig`'s pad height.
PAD_HEIGHT = GripperConfig().pad_height
#: Smallest extent (m), both ways in the front plane, of a feature standing out of the front for it to be
#: a handle candidate (a screw head is not).
MIN_FEATURE = 0.002


def _handle_links(asset: ArticulatedAsset, links: list[str]) -> list[str]:
    out = []
    for name in links:
        link = asset.links[name]
        category = str(link.annotations.get("category", "")) if isinstance(link.annotations, dict) else ""
        if "handle" in link.label.lower() or "handle" in category.lower():
            out.append(name)
    return out


def carried_links(asset: ArticulatedAsset, joint: str, links: list[str]) -> list[str]:
    """Links that move with ``joint`` but belong to parts of their own, hinged below it (a door's lever).

    :param links: the joint's own part (:meth:`ArticulatedAsset.part_of_joint`)
    """
    moving, own = set(asset.moving_links(joint)), set(links)
    return [name for name in asset.links if name in moving and name not in own]


def on_handle(handle: np.ndarray, basis: np.ndarray, origin: np.ndarray | None, axis: np.ndarray) -> np.ndarray:
    """The handle points to grasp: all of them when their bounding box's center (in the front plane) lies
    over the handle, else its far end (the points within :data:`HANDLE_TIP_BAND` of the one farthest from
    a hinge at ``origin`` along ``axis``; ``origin`` None: of the one nearest that center).
    A bucket's bail is an arc: the center of its box is in the air, its grip at the top of the arc."""
    uv = handle @ basis.T
    center = 0.5 * (uv.min(0) + uv.max(0))
    gap = np.linalg.norm(uv - center, axis=1)
    if gap.min() <= HANDLE_ON_TOLERANCE:
        return handle
    if origin is None:
        anchor = handle[int(np.argmin(gap))]
        return handle[np.linalg.norm(handle - anchor, axis=1) < HANDLE_TIP_BAND]
    r = handle - origin
    radial = np.linalg.norm(r - np.outer(r @ axis, axis), axis=1)
    return handle[radial > radial.max() - HANDLE_TIP_BAND]


def handle_searches(asset: ArticulatedAsset, joint: str, front: Front, seed: int):
    """The handle searches, in order of preference: ``(source, points, groups)`` with ``groups`` the clusters
    of ``points`` that are handle candidates, each as ``(indices, anchor, base)``: ``anchor`` is, for a
    handle on a hinge of its own (a safe's lever, a wheel), that hinge's ``(origin, axis)`` (it is best held
    near that axis, where a pull does not turn it), else None; ``base`` the level the pads may reach down to
    (the highest surface of the part around the handle: a knob in a door's recessed panel stands out of
    the panel, not of the door's rim)."""
    links = asset.part_of_joint(joint)
    own_labelled = _handle_links(asset, links)
    if own_labelled:
        pts = sample_surface(asset.mesh(links=own_labelled), N_HANDLE_SAMPLES, seed=seed)
        rest = [name for name in links if name not in own_labelled and asset.links[name].has_geometry]
        surface = sample_surface(asset.mesh(links=rest), N_SAMPLES // 2, seed=seed) if rest else None
        # one link may hold several pieces (a wide drawer's two knobs): grasp one of them, not between
        groups = [g for g in clusters(pts) if len(g) >= MIN_CLUSTER] or [np.arange(len(pts))]
        bases = [feature_base(surface, pts[g], front) for g in groups]
        # a labelled handle sunk into the part (a recessed grip) is no pinch: the notch search sees it
        yield "label", pts, [(g, None, base) for g, base in zip(groups, bases)
                             if base is None or float(np.max(pts[g] @ front.outward)) - base >= OBSTACLE_MIN_PROUD]
    carried = [name for name in carried_links(asset, joint, links) if asset.links[name].has_geometry]
    frames = asset.joint_frames()

    def hinged(name: str):
        hinge = _own_joint(asset, name)
        return frames[hinge] if hinge is not None and asset.joints[hinge].is_rotational else None

    def standing(pts: np.ndarray, anchor) -> list[tuple]:
        """The clusters of a hinged part's points standing out of the part around them, those points kept."""
        out = []
        for g in clusters(pts):
            base = feature_base(front.points, pts[g], front)
            if base is not None:
                g = g[pts[g] @ front.outward > base]
            floor = base if base is not None else front.face
            if len(g) >= MIN_CLUSTER and float(np.max(pts[g] @ front.outward)) - floor >= HANDLE_MIN_PROUD:
                out.append((g, anchor, base))
        return out

    for name in _handle_links(asset, carried):  # a handle hinged to the part (a door's lever) is its handle too
        pts = _hinged_samples(asset.mesh(links=[name]), seed)
        yield "label", pts, standing(pts, hinged(name))
    # what stands out of the front, sampled densely (a 15 mm knob on a large drawer is a few of the part's
    # samples): the part's own, and a dial or knob on its own joint, which stands out like any handle
    pts = proud_samples(front.part, front.outward, front.face + HANDLE_MIN_PROUD, N_HANDLE_SAMPLES, seed)
    groups = [(g, None, front.face) for g in clusters(pts)
              if len(g) >= MIN_CLUSTER and np.ptp(pts[g] @ front.basis.T, axis=0).min() >= MIN_FEATURE]
    for name in carried:
        extra = _hinged_samples(asset.mesh(links=[name]), seed)
        groups += [(g + len(pts), anchor, base) for g, anchor, base in standing(extra, hinged(name))]
        pts = np.concatenate([pts, extra])
    yield "geometry", pts, groups


def _hinged_samples(mesh, seed: int) -> np.ndarray:
    """Surface samples of a part hinged to the grasped one: :data:`N_HANDLE_SAMPLES`, or one per
    :data:`HINGED_SPACING` squared of its area when that is fewer (a safe's door carries a dozen 2 cm
    buttons: 4000 samples on each put every pair of them within a cluster's reach, 10^7 pairs)."""
    count = int(np.clip(float(mesh.area) / HINGED_SPACING ** 2, 2 * MIN_CLUSTER, N_HANDLE_SAMPLES))
    return sample_surface(mesh, count, seed=seed)


def feature_base(surface: np.ndarray | None, feature: np.ndarray, front: Front) -> float | None:
    """The level the pads may reach down to beside ``feature``: the highest of the ``surface`` points under
    the feature or within a pad's thickness and margin of it (in the front plane; along an elongated
    feature, only as far as the pads reach past its ends); None when there are none (the feature stands
    free: a bucket's bail)."""
    if surface is None or len(surface) == 0:
        return None
    along = long_axis(feature, front.basis)
    axes = np.stack([along, np.cross(front.outward, along)])
    uv, near = feature @ axes.T, surface @ axes.T
    length, width = np.ptp(uv, axis=0)
    grow = np.full(2, BASE_MARGIN)
    if length >= ELONGATED * width:
        # an elongated handle is pinched across its width: the pads lie beside it there, and along it they
        # cover its length, or their own height (centred on it) when it is shorter. A feature standing
        # beside its end (a safe's keypad beside its lever's tip) is not under the pads
        grow[0] = max(0.5 * PAD_HEIGHT - 0.5 * length, 0.0) + SWEEP_MARGIN
    inside = np.all((near > uv.min(0) - grow) & (near < uv.max(0) + grow), axis=1)
    if not inside.any():
        return None
    return float(np.max(surface[inside] @ front.outward))


def _own_joint(asset: ArticulatedAsset, link: str) -> str | None:
    """The movable joint whose part ``link`` belongs to (the nearest movable joint above it), or None."""
    parents = {j.child: j for j in asset.joints.values()}
    while link in parents:
        j = parents[link]
        if j.is_movable:
            return j.name
        link = j.parent
    return None
