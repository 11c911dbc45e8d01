"""Where to grasp the moving part of a joint: its handle, from labels or from geometry.

A link labelled ``handle`` among the part's links (``semantics.txt`` label, or GAPartNet's
annotation ``category``) is the handle. Otherwise the handle is found from the part's surface at rest:
project it on the part's outward direction (the pull direction of a drawer, the swing direction of a
door's far edge), take the front face as the densest level near the front, and keep what stands
proud of it by more than :data:`HANDLE_MIN_PROUD`; the connected clusters of those points are handle
candidates, and the chosen one is the central one (drawers) or the one farthest from the hinge (doors).
A part with neither has the handle of a part hinged to it (a door's lever or knob, its own joint) as its
handle, the piece in front of its front face. A labelled handle whose bounding box's center is not over
the handle (a bucket's bail, an arc) is grasped at its far end (:func:`on_handle`).
A part with nothing proud of its front face but a finger-pull notch cut into an edge of its front
(found by rasterising the front face, :func:`find_notch`) gets an *inside grip*: the closed fingers enter
the notch, the hand presses against the notch's inner wall and the fingers open against its sides
(``inside_grip=True``, ``press`` the direction of that wall). A revolute part with none of these but a
tab standing out past its free edge (a box lid's lifting tab, :func:`find_tab`) is pinched across the tab
from beyond that edge (``outward`` is then the edge's direction, not the swing's). Any other part gets its front face's
center (drawers) or a point of the front face near its free edge (doors), with ``has_handle=False``.

A pinch grasp is then checked against its neighbourhood (:func:`spark_bench.envs.pads.plan_pads`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.transforms import unit
from spark_bench.envs.gripper import GripperConfig
from spark_bench.envs.pads import OBSTACLE_MIN_PROUD, plan_pads

#: A surface point counts as handle when it stands this far (m) in front of the front face (twice
#: :data:`~spark_bench.envs.pads.OBSTACLE_MIN_PROUD`, what counts as in the fingers' way).
HANDLE_MIN_PROUD = 2 * OBSTACLE_MIN_PROUD  # 8 mm
#: Bin width (m) of the front-face level histogram.
LEVEL_BIN = 0.002
#: A histogram level is a face when it holds this fraction of the densest level's points.
FACE_DENSITY = 0.1
#: Surface samples per part.
N_SAMPLES = 20000
#: A cluster of surface samples is a feature (not noise) when it holds this many points, and (for the
#: part's own samples) this fraction of them.
MIN_CLUSTER = 20
MIN_CLUSTER_FRACTION = 0.002
#: Cell size (m) of the front-face raster used to find a notch.
NOTCH_CELL = 0.003
#: Smallest extent (m), both ways, of an uncovered region of the front for it to count as a notch. (The
#: pads' height is fitted to the notch's depth, :data:`spark_bench.envs.scene.NOTCH_CLEARANCE`; across its
#: width the closed default fingers are 24 mm, two 12 mm pads.)
NOTCH_MIN = 0.02
#: Largest notch extent (m) along its open edge: beyond this (and beyond :data:`NOTCH_MAX_FRACTION` of
#: that edge) it is a gap between parts, not a notch.
NOTCH_MAX = 0.35
#: A notch may also be as long as this fraction of its edge (a fridge door's finger-pull runs 0.37 m of a
#: 1.5 m edge).
NOTCH_MAX_FRACTION = 0.3
#: A labelled handle's grasp point must lie over the handle itself: within this distance (m), in the
#: front plane, of a handle point. A bucket's bail is an arc: its bounding box's center is in the air.
HANDLE_ON_TOLERANCE = 0.006
#: A handle reached over its far end (a revolute part's tip): points this close (m) to the handle point
#: farthest from the hinge.
HANDLE_TIP_BAND = 0.02
#: A revolute part's free edge must lie this far (m) from its hinge for a feature past it to be a lid's tab:
#: a shorter part is a lever (a toilet's flush lever, 8 cm), pressed on its face, not pinched at its end.
TAB_MIN_REACH = 0.15
#: How far (m) behind the front face the TCP goes in a notch: the fingertips reach 12 mm further.
NOTCH_DEPTH = 0.004


@dataclass
class GraspTarget:
    """A grasp on the moving part of one joint, world frame at the rest configuration.

    :param point: the grasp point (where the TCP should go)
    :param outward: unit direction out of the part's front (the gripper approaches along ``-outward``)
    :param long_axis: the handle's long direction (perpendicular to ``outward``); fingers close across it
    :param has_handle: whether a handle was found (label or geometry)
    :param source: ``label``, ``geometry``, ``notch`` (a finger-pull notch), ``tab`` (a lid's tab past its
        free edge) or ``face`` (no handle)
    :param grip: ``pinch`` (fingers close across the handle) or ``inside`` (a notch: the closed fingers
        enter it, the hand presses towards its inner wall, the fingers open against its sides)
    :param press: for an ``inside`` grip, the unit direction (in the front plane) from the notch's open
        edge to its inner wall, which the hand presses against while it opens the part
    :param notch_size: for a notch, its extent across the fingers' closing direction and along it, m
    :param opening: finger opening per side (m) to approach with, when a neighbouring feature is in the
        open fingers' sweep (None: approach fully open)
    :param pad_thickness: pad thickness (m) the pads must not exceed to fit beside the handle (None: any)
    :param clearance: room (m) left on each side of a pad placed in a gap beside the handle
    """

    point: np.ndarray
    outward: np.ndarray
    long_axis: np.ndarray
    has_handle: bool
    source: str
    grip: str = "pinch"
    press: np.ndarray | None = None
    notch_size: tuple[float, float] | None = None
    opening: float | None = None
    pad_thickness: float | None = None
    clearance: float | None = None

    @property
    def inside_grip(self) -> bool:
        """Whether the grasp is from inside a notch (the fingers grip by opening)."""
        return self.grip == "inside"

    @property
    def closing(self) -> np.ndarray:
        """The direction the fingers close along: across the handle, in the front plane."""
        c = np.cross(self.outward, self.long_axis)
        return c / np.linalg.norm(c)


def outward_direction(joint_type: str, origin: np.ndarray, axis: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The part's outward direction: the pull direction of a prismatic joint, or the direction in which
    the part's centroid starts to move when a revolute joint opens (``axis x r``).

    :param origin: a point on the joint axis (world)
    :param axis: unit joint axis (world), opening = increasing joint value
    :param points: the part's surface points at rest (world)
    """
    if joint_type == "prismatic":
        return unit(axis)
    r = points.mean(0) - origin
    r = r - np.dot(r, axis) * axis
    if np.linalg.norm(r) < 1e-9:
        raise ValueError("the part's centroid lies on its hinge axis: no outward direction")
    return unit(np.cross(axis, r))


def _face_normal(mesh, guess: np.ndarray, min_cos: float = 0.95) -> np.ndarray:
    """The area-weighted mean normal of the faces facing ``guess`` (the front face's true normal)."""
    normals = mesh.face_normals
    weights = mesh.area_faces * (normals @ guess > min_cos)
    if weights.sum() <= 0:
        return guess
    return unit(weights @ normals)


def _perpendicular_basis(n: np.ndarray) -> np.ndarray:
    """Two unit vectors spanning the plane perpendicular to ``n``, the first as vertical as possible."""
    up = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    v = unit(up - np.dot(up, n) * n)
    return np.stack([v, np.cross(n, v)])


def front_level(depth: np.ndarray, window: float = 0.12) -> float:
    """The front face's level along the outward direction: the densest histogram bin within
    ``window`` of the front-most point (faces are flat, so a face fills one bin)."""
    top = depth.max()
    near = depth[depth > top - window]
    bins = np.arange(near.min(), top + LEVEL_BIN, LEVEL_BIN)
    if len(bins) < 2:
        return float(top)
    counts, edges = np.histogram(near, bins=bins)
    # the front-most of the dense levels: a door's back face is as dense as its front face
    k = int(np.flatnonzero(counts >= FACE_DENSITY * counts.max()).max())
    return float(0.5 * (edges[k] + edges[k + 1]))


def clusters(points: np.ndarray, radius: float = 0.015) -> list[np.ndarray]:
    """Connected groups of points (neighbours closer than ``radius``), largest first, as index arrays."""
    if len(points) == 0:
        return []
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    _, labels = connected_components(graph, directed=False)
    groups = [np.flatnonzero(labels == k) for k in np.unique(labels)]
    return sorted(groups, key=len, reverse=True)


def _min_cluster(n_points: int) -> int:
    """The fewest of a part's ``n_points`` surface samples a feature's cluster holds."""
    return max(MIN_CLUSTER, int(MIN_CLUSTER_FRACTION * n_points))


def _handle_links(asset: ArticulatedAsset, links: list[str]) -> list[str]:
    out = []
    for name in links:
        link = asset.links[name]
        category = str(link.annotations.get("category", "")) if isinstance(link.annotations, dict) else ""
        if "handle" in link.label.lower() or "handle" in category.lower():
            out.append(name)
    return out


def _long_axis(points: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """The principal direction of ``points`` in the plane spanned by ``basis`` (vertical if round)."""
    uv = (points - points.mean(0)) @ basis.T
    if len(uv) < 3:
        return basis[0]
    evals, evecs = np.linalg.eigh(np.cov(uv.T))
    if evals[1] < 1.5 * max(evals[0], 1e-12):  # a knob: no long axis; a vertical one closes sideways
        return basis[0]
    return unit(evecs[:, 1] @ basis)


@dataclass
class Notch:
    """A notch cut into an edge of a front, in the front plane's 2-D coordinates (``basis`` rows).

    :param center: the notch's center, 2-D
    :param press: unit 2-D direction from its open edge to its inner wall
    :param depth: extent along ``press``, m
    :param width: extent along the open edge, m
    """

    center: np.ndarray
    press: np.ndarray
    depth: float
    width: float


def rasterise_front(part, n: np.ndarray, basis: np.ndarray, face: float, cell: float = NOTCH_CELL
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The front face as a boolean image: cells of ``cell`` m in the plane ``basis`` spans, True where a
    triangle facing ``n`` at level ``face`` covers the cell's center. Returns (image, 2-D origin)."""
    from skimage.draw import polygon

    tri = np.asarray(part.triangles)
    level = tri.mean(1) @ n
    keep = (part.face_normals @ n > 0.95) & (np.abs(level - face) < 2 * LEVEL_BIN)
    uv = tri[keep] @ basis.T
    if len(uv) == 0:
        return np.zeros((0, 0), bool), np.zeros(2)
    lo = uv.reshape(-1, 2).min(0)
    shape = tuple(np.maximum(np.ceil((uv.reshape(-1, 2).max(0) - lo) / cell).astype(int), 1))
    image = np.zeros(shape, bool)
    for t in (uv - lo) / cell - 0.5:  # cell (i, j) has its center at lo + (i + 0.5, j + 0.5) * cell
        rr, cc = polygon(t[:, 0], t[:, 1], shape)
        image[rr, cc] = True
    # close the one-cell cracks along shared triangle edges (padding keeps the border intact)
    padded = np.pad(image, 2, constant_values=True)
    image = ndimage.binary_closing(padded, structure=np.ones((3, 3)))[2:-2, 2:-2]
    return image, lo


def find_notch(image: np.ndarray, lo: np.ndarray, cell: float = NOTCH_CELL) -> list[Notch]:
    """Notches of a rasterised front (:func:`rasterise_front`): uncovered regions that open onto one
    edge of the front's bounding box, fill at least 70 % of their own bounding box, are at least
    :data:`NOTCH_MIN` across both ways, and along that edge at most :data:`NOTCH_MAX` or
    :data:`NOTCH_MAX_FRACTION` of the edge, whichever is longer."""
    if image.size == 0:
        return []
    labels, _ = ndimage.label(~image)
    out = []
    for k, region in enumerate(ndimage.find_objects(labels), start=1):
        mask = labels[region] == k
        extent = np.array([region[0].stop - region[0].start, region[1].stop - region[1].start]) * cell
        if extent.min() < NOTCH_MIN or mask.mean() < 0.7:  # too small, or not a rectangle-like cut
            continue
        # the edge it opens onto: the one border of the image it touches (a corner cut touches two)
        touches = {(0, -1): region[0].start == 0, (0, 1): region[0].stop == image.shape[0],
                   (1, -1): region[1].start == 0, (1, 1): region[1].stop == image.shape[1]}
        sides = [key for key, hit in touches.items() if hit]
        if len(sides) != 1:
            continue
        axis, sign = sides[0]
        if extent[1 - axis] > max(NOTCH_MAX, NOTCH_MAX_FRACTION * image.shape[1 - axis] * cell):
            continue
        press = np.zeros(2)
        press[axis] = -sign
        cells = np.argwhere(labels == k)
        center = lo + (0.5 * (cells.min(0) + cells.max(0)) + 0.5) * cell
        out.append(Notch(center=center, press=press, depth=float(extent[axis]), width=float(extent[1 - axis])))
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


def find_tab(part, points: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> GraspTarget | None:
    """A tab standing out past the free edge of a revolute part (a box lid's lifting tab), or None.

    The free edge faces away from the hinge (``radial``, from the hinge to the part's centroid); a feature
    proud of that edge's face by more than :data:`HANDLE_MIN_PROUD` is pinched from beyond the edge,
    the fingers closing across its thickness. The edge's face is the densest level near the far end (a
    tab's own end face is a level too, but a smaller one).

    :param part: the part's mesh (world, at rest)
    :param points: the part's surface points at rest (world)
    :param origin: a point on the hinge axis
    :param axis: unit hinge axis
    """
    r = points - origin
    r = r - np.outer(r @ axis, axis)
    radial = _face_normal(part, unit(r.mean(0)))
    depth = points @ radial
    near = depth[depth > depth.max() - 0.12]
    counts, edges = np.histogram(near, bins=np.arange(near.min(), depth.max() + 2 * LEVEL_BIN, LEVEL_BIN))
    k = int(np.argmax(counts))
    edge = float(0.5 * (edges[k] + edges[k + 1]))
    if edge - float(origin @ radial) < TAB_MIN_REACH:
        return None
    tip = points[depth > edge + HANDLE_MIN_PROUD]
    groups = [g for g in clusters(tip) if len(g) >= _min_cluster(len(points))]
    if not groups:
        return None
    basis = _perpendicular_basis(radial)
    best = tip[max(groups, key=len)]
    uv = best @ basis.T
    point = 0.5 * (uv.min(0) + uv.max(0)) @ basis + float(np.median(best @ radial)) * radial
    return GraspTarget(point=point, outward=radial, long_axis=_long_axis(best, basis), has_handle=True,
                       source="tab")


def find_grasp(asset: ArticulatedAsset, joint: str, seed: int = 0,
               gripper: GripperConfig | None = None) -> GraspTarget:
    """The grasp on the part moved by ``joint``, at the asset's rest configuration.

    :param asset: the object
    :param joint: a movable joint's name
    :param seed: seed of the surface sampling
    :param gripper: the gripper's dimensions, for fitting the pads beside the handle (default gripper)
    """
    spec = asset.joints[joint]
    links = asset.part_of_joint(joint)
    part = asset.mesh(links=links)
    if len(part.faces) == 0:
        raise ValueError(f"{asset.name}: the part moved by {joint} has no geometry")
    origin, axis = asset.joint_frames()[joint]
    points = sample_surface(part, N_SAMPLES, seed=seed)
    n = outward_direction(spec.type, origin, axis, points)
    if spec.type != "prismatic":
        n = _face_normal(part, n)
    basis = _perpendicular_basis(n)
    depth = points @ n
    face = front_level(depth)
    rotational = spec.type != "prismatic"

    def lateral_score(group_points: np.ndarray) -> float:
        center = group_points.mean(0)
        if rotational:  # doors: far from the hinge
            r = center - origin
            return -float(np.linalg.norm(r - np.dot(r, axis) * axis))
        return float(np.linalg.norm((center - points.mean(0)) @ basis.T))  # drawers: central

    labelled = _handle_links(asset, links)
    if labelled:
        handle_pts = sample_surface(asset.mesh(links=labelled), 4000, seed=seed)
        # one link may hold several pieces (a wide drawer's two knobs): grasp one of them, not between
        groups = [g for g in clusters(handle_pts) if len(g) >= MIN_CLUSTER] or [np.arange(len(handle_pts))]
        source = "label"
    else:
        proud = np.flatnonzero(depth > face + HANDLE_MIN_PROUD)
        handle_pts = points[proud]
        groups = [g for g in clusters(handle_pts) if len(g) >= _min_cluster(len(points))]
        source = "geometry"
    if not groups:
        # a handle hinged to the part (a door's lever or knob) is the part's handle too: the one in front
        carried = _handle_links(asset, carried_links(asset, joint, links))
        if carried:
            handle_pts = sample_surface(asset.mesh(links=carried), 4000, seed=seed)
            groups = [g for g in clusters(handle_pts)
                      if len(g) >= MIN_CLUSTER and np.median(handle_pts[g] @ n) > face + HANDLE_MIN_PROUD]
            source = "label"
    if groups:
        scores = [lateral_score(handle_pts[g]) for g in groups]
        best = on_handle(handle_pts[groups[int(np.argmin(scores))]], basis, origin if rotational else None, axis)
        uv = best @ basis.T
        lateral = 0.5 * (uv.min(0) + uv.max(0))
        along = float(np.median(best @ n))
        point = lateral @ basis + along * n
        grasp = GraspTarget(point=point, outward=n, long_axis=_long_axis(best, basis), has_handle=True,
                            source=source)
        others = [name for name in asset.links if name not in links]
        pads = plan_pads(part, asset.mesh(links=others) if others else None, point, n, grasp.closing,
                         grasp.long_axis, face, gripper or GripperConfig())
        if pads is not None:
            grasp.point = point + pads["shift"] * grasp.closing
            grasp.opening, grasp.pad_thickness = pads["opening"], pads["pad_thickness"]
            grasp.clearance = pads["clearance"]
        return grasp

    image, lo = rasterise_front(part, n, basis, face)
    notches = find_notch(image, lo)
    if notches:
        def notch_score(notch: Notch) -> float:
            return lateral_score(np.atleast_2d(notch.center @ basis + face * n))

        notch = min(notches, key=notch_score)
        press = notch.press @ basis
        return GraspTarget(point=notch.center @ basis + (face - NOTCH_DEPTH) * n, outward=n, long_axis=press,
                           has_handle=True, source="notch", grip="inside", press=press,
                           notch_size=(notch.depth, notch.width))

    if rotational:  # a lid's tab standing out past its free edge, pinched from beyond that edge
        tab = find_tab(part, points, origin, axis)
        if tab is not None:
            return tab

    # no handle: a point of the front face, central (drawer) or near the free edge (door)
    front = points[np.abs(depth - face) < 2 * LEVEL_BIN]
    uv = front @ basis.T
    if rotational:
        r = front - origin
        radial = np.linalg.norm(r - np.outer(r @ axis, axis), axis=1)
        keep = radial > np.quantile(radial, 0.85)
        center_v = 0.5 * (uv[:, 0].min() + uv[:, 0].max())
        lateral = np.array([center_v, np.median(uv[keep, 1])])
    else:
        lateral = 0.5 * (uv.min(0) + uv.max(0))
    point = lateral @ basis + face * n
    return GraspTarget(point=point, outward=n, long_axis=basis[0] if rotational else basis[1],
                       has_handle=False, source="face")
