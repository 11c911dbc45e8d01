"""Exact convex decomposition of an orthogonal polyhedron (every face on an axis plane) into boxes.

A part built of axis-aligned boxes (a drawer: a bottom and four walls; an appliance's open body; most
parts of the ``synth`` generator) has an exact convex decomposition that needs no search: the planes of
its faces cut space into a grid, each grid cell is wholly inside or wholly outside, and the inside cells
merge into boxes. CoACD approximates such a part by Monte-Carlo search instead, with hulls that bulge past
its surface. Measured on the main job (``docs/conventions-history.md``, conv-8): 77 of its 121 CoACD calls
were orthogonal parts, and cutting them into boxes took CoACD's CPU time in the sim stage from 348 to 37
seconds; in 21 of the 50 predictions their hulls had overlapped a moving part's at rest, which switched
that pair's contacts off. The boxes are exact (their union
is the part, to float rounding), take milliseconds, and depend on no thread count or random seed.

The grid's cells are classified by ray parity along each of the three axes; the three classifications
must agree and the boxes' volume must equal the mesh's, else the mesh is not taken as orthogonal and goes
to CoACD as before; so does a mesh whose faces are not exactly the boundary of the inside cells (its
area differs: a hole, faces inside the part or doubled). T-junctions (a box's face meeting two boxes'
edges) are fine: parity needs a closed surface, not a manifold triangulation.
"""

from __future__ import annotations

import numpy as np
import trimesh

from spark_bench.asset.mesh import signed_volume

#: Coordinates closer than this (in units of the part's largest side) lie on one plane.
PLANE_TOLERANCE = 1e-7
#: Most grid cells a part may cut space into (beyond it the part is left to CoACD).
MAX_CELLS = 200_000
#: Where in a cell its parity ray passes (fractions of the cell's two sides): off the cell's center,
#: so that a ray never runs along the diagonal edge two triangles of one face share.
RAY_OFFSET = (0.5 + 0.0123581, 0.5 - 0.0371353)
#: The twelve triangles of a box whose corners are numbered by bits (x: 1, y: 2, z: 4), outward.
BOX_FACES = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                      [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]], np.int64)


def grid_boundary_area(inside: np.ndarray, planes: list[np.ndarray]) -> float:
    """The area of the boundary of the inside cells of a grid (cell faces between an inside cell and an
    outside one, or the grid's edge)."""
    sides = [np.diff(p) for p in planes]
    total = 0.0
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        padded = np.pad(inside, [(1, 1) if a == axis else (0, 0) for a in range(3)])
        changes = np.diff(padded.astype(np.int8), axis=axis) != 0  # per plane along axis
        area = np.multiply.outer(sides[u], sides[v])
        total += float((np.moveaxis(changes, axis, 0) * area).sum())
    return total


def triangle_areas(corners: np.ndarray) -> np.ndarray:
    """The area of each triangle of an ``(F, 3, 3)`` array of corners."""
    return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)


def face_axes(vertices: np.ndarray, faces: np.ndarray, tolerance: float) -> np.ndarray | None:
    """Per face, the axis (0, 1, 2) its plane is normal to, -1 for a face of no area; None when a face
    with area lies on no axis plane (its three vertices differ along every axis by more than
    ``tolerance``)."""
    corners = vertices[faces]  # (F, 3 corners, 3 axes)
    spread = corners.max(axis=1) - corners.min(axis=1)  # (F, 3)
    flat = spread <= tolerance
    empty = (flat.sum(axis=1) >= 2) | (triangle_areas(corners) <= tolerance ** 2)
    if not np.all(flat.any(axis=1) | empty):
        return None
    return np.where(empty, -1, np.argmax(flat, axis=1))


def axis_planes(values: np.ndarray, tolerance: float) -> np.ndarray:
    """The distinct coordinates among ``values``, those within ``tolerance`` of the previous one merged."""
    values = np.sort(np.asarray(values, float))
    keep = np.concatenate([[True], np.diff(values) > tolerance])
    return values[keep]


def crossings_along(axis: int, vertices: np.ndarray, faces: np.ndarray, axes: np.ndarray,
                    planes: list[np.ndarray]) -> np.ndarray:
    """Which cells are inside, by the parity of the faces a ray along ``axis`` crosses: a boolean grid
    of shape ``(cells along x, y, z)``."""
    u, v = [a for a in range(3) if a != axis]
    pu = planes[u][:-1] + RAY_OFFSET[0] * np.diff(planes[u])
    pv = planes[v][:-1] + RAY_OFFSET[1] * np.diff(planes[v])
    flips = np.zeros((len(planes[axis]), len(pu), len(pv)), bool)
    for face in faces[axes == axis]:
        tri = vertices[face]
        level = int(np.argmin(np.abs(planes[axis] - tri[:, axis].mean())))
        # only the rays through the triangle's bounding box can cross it
        u0, u1 = np.searchsorted(pu, tri[:, u].min()), np.searchsorted(pu, tri[:, u].max(), side="right")
        v0, v1 = np.searchsorted(pv, tri[:, v].min()), np.searchsorted(pv, tri[:, v].max(), side="right")
        if u0 < u1 and v0 < v1:
            grid_u, grid_v = np.meshgrid(pu[u0:u1], pv[v0:v1], indexing="ij")
            flips[level, u0:u1, v0:v1] ^= _inside_triangle(grid_u, grid_v, tri[:, u], tri[:, v])
    inside = np.cumsum(flips, axis=0)[:-1] % 2 == 1  # cell c lies between planes c and c + 1
    return np.moveaxis(inside, 0, axis) if axis else inside


def _inside_triangle(px: np.ndarray, py: np.ndarray, tx: np.ndarray, ty: np.ndarray) -> np.ndarray:
    """Whether each point ``(px, py)`` lies inside the triangle ``(tx, ty)`` (either winding)."""
    d1 = (px - tx[1]) * (ty[0] - ty[1]) - (tx[0] - tx[1]) * (py - ty[1])
    d2 = (px - tx[2]) * (ty[1] - ty[2]) - (tx[1] - tx[2]) * (py - ty[2])
    d3 = (px - tx[0]) * (ty[2] - ty[0]) - (tx[2] - tx[0]) * (py - ty[0])
    negative = (d1 < 0) | (d2 < 0) | (d3 < 0)
    positive = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return ~(negative & positive)


def merge_cells(inside: np.ndarray) -> list[tuple[tuple[int, int, int], tuple[int, int, int]]]:
    """The inside cells as boxes of cells ``(low, high)`` (high exclusive): greedily, from the first
    free cell in x, y, z order, the longest run along z, then as many such runs along y, then as many
    such slabs along x."""
    free = np.array(inside, bool)
    boxes = []
    for i, j, k in zip(*np.nonzero(free)):
        if not free[i, j, k]:
            continue
        k1 = k + 1
        while k1 < free.shape[2] and free[i, j, k1]:
            k1 += 1
        j1 = j + 1
        while j1 < free.shape[1] and free[i, j1, k:k1].all():
            j1 += 1
        i1 = i + 1
        while i1 < free.shape[0] and free[i1, j:j1, k:k1].all():
            i1 += 1
        free[i:i1, j:j1, k:k1] = False
        boxes.append(((int(i), int(j), int(k)), (int(i1), int(j1), int(k1))))
    return boxes


def box_corners(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The eight corners of the box ``[low, high]``, numbered by bits (x: 1, y: 2, z: 4)."""
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
    return np.where(bits == 1, high, low).astype(float)


def box_decomposition(vertices: np.ndarray, faces: np.ndarray, tolerance: float = PLANE_TOLERANCE,
                      max_cells: int = MAX_CELLS) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """The exact decomposition of an orthogonal polyhedron into boxes, or None when ``(vertices,
    faces)`` is not one (a face off the axis planes, an open mesh, too fine a grid) or the construction
    does not check out.

    :param vertices: ``(V, 3)`` vertices, best in units of the part's largest side (``tolerance`` is
        absolute)
    :param faces: ``(F, 3)`` triangles of a closed mesh
    :param tolerance: coordinates within this lie on one plane
    :param max_cells: most grid cells to classify
    :returns: per box its eight corners and :data:`BOX_FACES`
    """
    vertices, faces = np.asarray(vertices, float), np.asarray(faces, np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3 or not len(faces) or faces.min() < 0 or faces.max() >= len(vertices):
        return None
    axes = face_axes(vertices, faces, tolerance)
    if axes is None:
        return None
    planes = [axis_planes(vertices[:, a], tolerance) for a in range(3)]
    if min(len(p) for p in planes) < 2 or np.prod([len(p) - 1 for p in planes]) > max_cells:
        return None
    inside = crossings_along(0, vertices, faces, axes, planes)
    for axis in (1, 2):
        if not np.array_equal(inside, crossings_along(axis, vertices, faces, axes, planes)):
            return None
    if not inside.any():
        return None
    boxes = [box_corners(np.array([planes[a][lo[a]] for a in range(3)]),
                         np.array([planes[a][hi[a]] for a in range(3)])) for lo, hi in merge_cells(inside)]
    volume = sum(float(np.prod(b[7] - b[0])) for b in boxes)
    if abs(volume - abs(signed_volume(trimesh.Trimesh(vertices, faces, process=False)))) > 1e-6 * max(volume, tolerance):
        return None  # the mesh is not the closed surface of the cells (a hole, a flipped face)
    area = grid_boundary_area(inside, planes)
    if abs(area - float(triangle_areas(vertices[faces]).sum())) > 1e-6 * max(area, tolerance):
        return None  # faces inside the volume or on top of one another
    return [(b, BOX_FACES.copy()) for b in boxes]
