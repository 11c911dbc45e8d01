"""Surface features of a part that the grasp planner reads (:mod:`spark_bench.manipulation.grasp`): the front
face's level and normal, connected clusters of surface points, a feature's long direction, and
finger-pull notches cut into the front (found on a raster of the front face), and the grasped part's
front as the planner sees it (:class:`Front`).

Everything here is plain geometry on surface samples and triangles, in the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.transforms import unit

#: Bin width (m) of the front-face level histogram.
LEVEL_BIN = 0.002
#: A histogram level is a face when it holds this fraction of the densest level's points.
FACE_DENSITY = 0.1
#: A cluster of surface samples is a feature (not noise) when it holds this many points, and (for the
#: part's own samples) this fraction of them.
MIN_CLUSTER = 20
MIN_CLUSTER_FRACTION = 0.002
#: Cell size (m) of the front-face raster used to find a notch.
NOTCH_CELL = 0.003
#: Smallest extent (m), both ways, of an uncovered region of the front for it to count as a notch. (The
#: pads' height is fitted to the notch's depth, :data:`spark_bench.manipulation.scene.NOTCH_CLEARANCE`; across its
#: width the closed default fingers are 24 mm, two 12 mm pads.)
NOTCH_MIN = 0.02
#: Largest notch extent (m) along its open edge: beyond this (and beyond :data:`NOTCH_MAX_FRACTION` of
#: that edge) it is a gap between parts, not a notch.
NOTCH_MAX = 0.35
#: A notch may also be as long as this fraction of its edge (a fridge door's finger-pull runs 0.37 m of a
#: 1.5 m edge).
NOTCH_MAX_FRACTION = 0.3


def face_normal(mesh, guess: np.ndarray, min_cos: float = 0.95) -> np.ndarray:
    """The area-weighted mean normal of the faces facing ``guess`` (the front face's true normal)."""
    normals = mesh.face_normals
    weights = mesh.area_faces * (normals @ guess > min_cos)
    if weights.sum() <= 0:
        return guess
    return unit(weights @ normals)


def perpendicular_basis(n: np.ndarray) -> np.ndarray:
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


def min_cluster(n_points: int) -> int:
    """The fewest of a part's ``n_points`` surface samples a feature's cluster holds."""
    return max(MIN_CLUSTER, int(MIN_CLUSTER_FRACTION * n_points))


def long_axis(points: np.ndarray, basis: np.ndarray) -> np.ndarray:
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


def proud_samples(mesh, outward: np.ndarray, level: float, count: int, seed: int) -> np.ndarray:
    """``count`` surface samples of the triangles of ``mesh`` reaching above ``level`` along ``outward``,
    those above it kept (an empty array when nothing reaches it)."""
    from trimesh import Trimesh

    triangles = np.asarray(mesh.triangles)
    keep = (triangles @ outward).max(1) > level
    if not keep.any():
        return np.zeros((0, 3))
    sub = Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)[keep], process=False)
    try:
        points = sample_surface(sub, count, seed=seed)
    except ValueError:  # zero-area triangles only
        return np.zeros((0, 3))
    return points[points @ outward > level]


@dataclass
class Front:
    """The grasped part at rest (world frame).

    :param part: its mesh
    :param points: its surface samples
    :param outward: unit direction out of its front
    :param basis: two unit vectors spanning the front plane (rows), the first as vertical as possible
    :param face: the front face's level along ``outward``
    :param origin: a point on its joint's axis
    :param axis: its joint's unit axis
    :param rotational: whether the joint is revolute or continuous
    """

    part: object
    points: np.ndarray
    outward: np.ndarray
    basis: np.ndarray
    face: float
    origin: np.ndarray
    axis: np.ndarray
    rotational: bool

    def lateral_score(self, group_points: np.ndarray) -> float:
        """Lower is better: doors far from the hinge, drawers central (of the points' centroid)."""
        return float(self.point_scores(group_points.mean(0)[None])[0])

    def point_scores(self, points: np.ndarray) -> np.ndarray:
        """:meth:`lateral_score` of each point."""
        if self.rotational:
            r = points - self.origin
            return -np.linalg.norm(r - np.outer(r @ self.axis, self.axis), axis=1)
        return np.linalg.norm((points - self.points.mean(0)) @ self.basis.T, axis=1)


def first_hit(triangles: np.ndarray, origins: np.ndarray, direction: np.ndarray, near: float, far: float
              ) -> float | None:
    """The smallest ``t`` (``near < t < far``) at which one of the rays ``origins + t * direction`` crosses a
    triangle, or None (Moller-Trumbore, all rays against all triangles).

    :param triangles: (F, 3, 3) triangle corners
    :param origins: (R, 3) ray origins
    :param direction: unit direction shared by the rays
    """
    if len(triangles) == 0:
        return None
    a, e1, e2 = triangles[:, 0], triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    p = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    a, e1, e2, p, det = a[ok], e1[ok], e2[ok], p[ok], det[ok]
    best = None
    for origin in np.atleast_2d(origins):
        s = origin - a
        u = np.einsum("ij,ij->i", s, p) / det
        q = np.cross(s, e1)
        v = (q @ direction) / det
        t = np.einsum("ij,ij->i", e2, q) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > near) & (t < far)
        if np.any(hit):
            far = float(t[hit].min())
            best = far
    return best

