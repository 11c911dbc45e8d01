"""Mesh operations from the SPARK appendix, on trimesh meshes and plain arrays.

- :func:`merge_meshes`: per-link merge by vertex-face concatenation (appendix "Per-Link Geometry
  Cleaning and Merging").
- :func:`make_watertight`: voxelize at a pitch from R and N_min under a memory cap, fill, marching
  cubes, axis-wise rescale to the original extents, cleanup, largest component; meshes already
  watertight only get the cleanup (appendix "Watertight Part Preprocessing").
- :func:`sample_surface`: seeded, area-weighted uniform surface samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

#: Soft cap on the voxel grid, in bytes (one byte per voxel), as in the appendix.
VOXEL_MEMORY_CAP = 400_000_000
WELD_RADIUS = 1e-6


def merge_meshes(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate vertices and faces (offsetting face indices), with no repair or processing."""
    meshes = [m for m in meshes if m is not None and len(m.vertices)]
    if not meshes:
        return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)
    if len(meshes) == 1:
        return trimesh.Trimesh(meshes[0].vertices.copy(), meshes[0].faces.copy(), process=False)
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    vertices = np.concatenate([m.vertices for m in meshes])
    faces = np.concatenate([m.faces + off for m, off in zip(meshes, offsets)])
    return trimesh.Trimesh(vertices, faces, process=False)


def voxel_pitch(extents: np.ndarray, resolution: int = 200, n_min: int = 3,
                memory_cap: float = VOXEL_MEMORY_CAP) -> float:
    """The appendix's pitch: ``min(max(e)/R, min(e)/N_min)``, relaxed to fit ``memory_cap`` voxels.

    Zero extents (a flat part) are ignored for the thin-axis term: a plane has no thickness to keep.
    """
    extents = np.asarray(extents, dtype=float)
    pitch = extents.max() / resolution
    positive = extents[extents > 1e-9 * max(extents.max(), 1e-12)]
    if len(positive):
        pitch = min(pitch, positive.min() / n_min)
    n_voxels = np.prod(np.ceil(np.maximum(extents, pitch) / pitch) + 2)
    if n_voxels > memory_cap:
        pitch *= (n_voxels / memory_cap) ** (1.0 / 3.0)
    return float(pitch)


def cleanup(mesh: trimesh.Trimesh, weld_radius: float = WELD_RADIUS, keep_largest: bool = True,
            fix_normals: bool = True) -> trimesh.Trimesh:
    """Weld close vertices, drop degenerate/duplicate faces and unused vertices, fix normals, and
    (``keep_largest``) keep the largest connected component (most faces, then largest volume)."""
    return _cleanup(mesh, weld_radius, keep_largest, fix_normals)[0]


def _cleanup(mesh: trimesh.Trimesh, weld_radius: float = WELD_RADIUS, keep_largest: bool = True,
             fix_normals: bool = True) -> tuple[trimesh.Trimesh, bool | None]:
    """:func:`cleanup`, and whether the result is watertight where that came for free (else None)."""
    mesh = mesh.copy()
    mesh.merge_vertices(digits_vertex=max(0, int(-np.log10(weld_radius))))
    if _min_height(mesh) <= 100 * trimesh.tol.merge:  # else no face is degenerate: skip the slow test
        mesh.update_faces(mesh.nondegenerate_faces())
    # a watertight mesh in one piece repeats no face (two copies of a face would be a closed piece of
    # their own): then removing repeated faces would change nothing and is skipped
    structure = _edge_structure(mesh.faces) if keep_largest else None
    if structure != (True, True) or len(mesh.faces) <= 2:
        mesh.update_faces(mesh.unique_faces())
        structure = None
    mesh.remove_unreferenced_vertices()
    watertight = None
    if keep_largest:
        # a mesh in one piece is kept as it is: check that first, which costs a fraction of splitting
        one_piece, watertight = structure or _edge_structure(mesh.faces)
        parts = [mesh] if one_piece else mesh.split(only_watertight=False)
        if len(parts) > 1:
            mesh = max(parts, key=lambda m: (len(m.faces), abs(m.volume) if m.is_watertight else 0.0))
            watertight = None
    if fix_normals:
        trimesh.repair.fix_normals(mesh)
        watertight = None
    return mesh, watertight


def _min_height(mesh: trimesh.Trimesh) -> float:
    """The smallest height of a face over its first two edges (what trimesh's ``nondegenerate_faces``
    compares with its tolerance), in plain float64 arithmetic: 0 for a face with a zero-length edge."""
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    if len(faces) == 0:
        return np.inf
    (ax, ay, az), (bx, by, bz) = ([vertices[faces[:, k], d] - vertices[faces[:, 0], d] for d in range(3)]
                                  for k in (1, 2))
    area2 = np.sqrt((ay * bz - az * by) ** 2 + (az * bx - ax * bz) ** 2 + (ax * by - ay * bx) ** 2)
    length = np.sqrt(np.maximum(ax * ax + ay * ay + az * az, bx * bx + by * by + bz * bz))
    with np.errstate(divide="ignore", invalid="ignore"):
        height = np.where(length > 0, area2 / length, 0.0)
    return float(np.min(height))


def _edge_structure(faces: np.ndarray) -> tuple[bool, bool]:
    """``(one piece, watertight)`` of a triangle list, from one sort of its edges.

    One piece: the faces form one connected component, two faces being adjacent when they share an
    edge that no third face has (trimesh's ``face_adjacency``, which ``split`` follows). Watertight:
    every edge has exactly two faces (trimesh's ``is_watertight``).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return True, False
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = edges[:, 0] * (int(faces.max()) + 1) + edges[:, 1]
    order = np.argsort(key)
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    counts = np.diff(np.r_[starts, len(key)])
    pairs = starts[counts == 2]  # edges shared by exactly two faces
    a, b = order[pairs] // 3, order[pairs + 1] // 3
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(len(faces), len(faces)))
    return bool(connected_components(graph, directed=False)[0] == 1), bool(len(pairs) * 2 == len(key))


def signed_volume(mesh: trimesh.Trimesh) -> float:
    """The signed volume of a closed mesh (positive when its faces wind outwards): trimesh's volume
    integral, without the inertia that ``mesh.volume`` computes along with it."""
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    x, y, z = (vertices[faces, d] for d in range(3))  # (F, 3) each
    cross_x = (y[:, 1] - y[:, 0]) * (z[:, 2] - z[:, 0]) - (z[:, 1] - z[:, 0]) * (y[:, 2] - y[:, 0])
    return float(np.dot(cross_x, x[:, 0] + x[:, 1] + x[:, 2])) / 6.0


def _barycentric_grid(n: int) -> np.ndarray:
    """Barycentric weights (k, 3) of the points ``(i/n, j/n)``, ``i + j <= n``, of a triangle."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    u, v = i[keep] / n, j[keep] / n
    return np.stack([1.0 - u - v, u, v], axis=1)


#: Relative cost of a point evaluated alone (row walk) and of one in a triangle's full grid, which is
#: what :func:`voxelize_surface` weighs to choose between walking a triangle's rows and its full grid.
_WALK_COST = 6.0
#: Lattice points per block of the full-grid sampler (small enough for the arrays to stay in cache).
_BLOCK_POINTS = 1 << 16


class _Grid:
    """The voxel grid of :func:`voxelize_surface`, and the one formula from a triangle's lattice point
    to its voxel, shared by both samplers so that a point lands in the same voxel whichever visits it.

    Lattice point ``(i, j)`` of triangle ``(a, b, c)`` with ``n`` steps has barycentric weights
    ``w = (1 - i/n - j/n, i/n, j/n)`` and world coordinates ``(w0 a + w1 b) + w2 c`` (summed in this
    order, as ``einsum("kv,tvd->tkd")`` does).
    """

    def __init__(self, origin: np.ndarray, pitch: float, shape: np.ndarray):
        self.origin, self.pitch, self.shape = origin, pitch, shape
        self.occupancy = np.zeros(tuple(shape), dtype=bool)

    def coordinates(self, w0, w1, w2, a, b, c) -> list[np.ndarray]:
        """Continuous voxel coordinates (voxel ``k`` spans ``[k, k+1)``) of the points with weights
        ``w0, w1, w2`` of the corners ``a, b, c`` (each ``(..., 3)``, broadcast together), per axis."""
        out = []
        for d in range(3):
            x = w0 * a[..., d]
            x += w1 * b[..., d]
            x += w2 * c[..., d]
            x -= self.origin[d]
            x /= self.pitch
            out.append(x)
        return out

    def mark(self, coordinates: list[np.ndarray]) -> None:
        """Mark the voxels holding the points of :meth:`coordinates`."""
        flat = None
        for d, x in enumerate(coordinates):
            # every point lies in the bounding box, half a pitch inside the grid, so x > 0 and
            # truncation is the floor; the clip only guards the last voxel against rounding
            index = x.astype(np.intp)
            np.clip(index, 0, self.shape[d] - 1, out=index)
            flat = index if flat is None else flat * self.shape[d] + index
        self.occupancy.ravel()[flat.ravel()] = True

    def lattice(self, triangles: np.ndarray, i: np.ndarray, j: np.ndarray, n: np.ndarray) -> list[np.ndarray]:
        """Voxel coordinates of lattice point ``(i[p], j[p])`` of ``triangles[p]`` (``n[p]`` steps)."""
        u, v = i / n, j / n
        return self.coordinates(1.0 - u - v, u, v, triangles[:, 0], triangles[:, 1], triangles[:, 2])


def _sample_grids(grid: _Grid, triangles: np.ndarray, steps: np.ndarray) -> None:
    """Mark the voxel of every point of every triangle's full lattice (``steps`` per side)."""
    for n in np.unique(steps):
        group = triangles[steps == n]
        weights = _barycentric_grid(int(n))
        w0, w1, w2 = (weights[None, :, k] for k in range(3))
        per_block = max(1, _BLOCK_POINTS // len(weights))
        for start in range(0, len(group), per_block):
            corners = group[start:start + per_block, :, None, :]
            grid.mark(grid.coordinates(w0, w1, w2, corners[:, 0], corners[:, 1], corners[:, 2]))


def _lattice_rows(triangles: np.ndarray, steps: np.ndarray, family: np.ndarray) -> dict[str, np.ndarray]:
    """Each triangle's lattice as rows: row ``r`` is the points ``(i0 + t di, j0 + t dj)``, ``t = 0..m``.

    ``family`` 0 runs the rows along edge ``ab`` (``i`` varies), 1 along ``ac`` (``j`` varies), 2 along
    ``cb`` (``i`` up, ``j`` down); each family covers every lattice point exactly once.
    """
    per = steps + 1
    owner = np.repeat(np.arange(len(triangles)), per)
    r = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
    n, fam = steps[owner], family[owner]
    along_ac = fam == 1
    return {"owner": owner, "n": n,
            "i0": np.where(along_ac, r, 0), "j0": np.where(along_ac, 0, r),
            "di": np.where(along_ac, 0, 1), "dj": np.select([along_ac, fam == 2], [1, -1], 0),
            "m": np.where(fam == 2, r, n - r)}


def _walk_rows(grid: _Grid, triangles: np.ndarray, steps: np.ndarray, family: np.ndarray) -> None:
    """Mark the voxels of every lattice point of ``triangles``, evaluating only the points next to a
    voxel face.

    Along a row the voxel changes only where the row crosses a voxel face, so the row's voxels are
    those of its ends and of the points on either side of each crossing. Each crossing is located
    from the row's ends, and the lattice points around it are evaluated with :meth:`_Grid.lattice`
    (the formula of the full-grid sampler), with one more on each side where the crossing falls
    within 1e-6 steps of a lattice point. Rounding can move a point across a face only within ~1e-13
    voxels of it, so a point two steps from every crossing has the voxel of its run, unless the row
    runs along a face (less than 1e-6 voxels per step across it, within 1e-9 voxels of it): such a
    row is evaluated point by point. Hence the same voxels as evaluating every point.
    """
    rows = _lattice_rows(triangles, steps, family)
    tri, n, m = triangles[rows["owner"]], rows["n"], rows["m"]
    first = np.stack(grid.lattice(tri, rows["i0"], rows["j0"], n), axis=1)
    last = np.stack(grid.lattice(tri, rows["i0"] + m * rows["di"], rows["j0"] + m * rows["dj"], n), axis=1)
    grid.mark(list(first.T))
    grid.mark(list(last.T))
    low, high = np.floor(np.minimum(first, last)), np.floor(np.maximum(first, last))
    spread = np.abs(last - first)
    gap = np.minimum(np.abs(first - np.rint(first)), np.abs(last - np.rint(last)))
    along_face = ((spread < 1e-6 * m[:, None]) & (gap < 1e-9 + spread)).any(1) & (m > 1)
    count = (high - low).astype(np.int64)
    count[along_face] = 0
    count = count.ravel()
    pair = np.repeat(np.arange(count.size), count)  # (row, axis) of each crossing
    row = pair // 3
    face = low.ravel()[pair] + 1 + (np.arange(len(pair)) - np.repeat(np.cumsum(count) - count, count))
    start, end = first.ravel()[pair], last.ravel()[pair]
    at = (face - start) / (end - start) * m[row]  # the crossing, in steps along the row
    before = np.floor(at).astype(np.int64)
    near = np.abs(at - np.rint(at)) < 1e-6
    nearest = np.rint(at[near]).astype(np.int64)
    # rows along a face: every point
    whole = np.flatnonzero(along_face)
    length = m[whole] + 1
    every = np.arange(length.sum()) - np.repeat(np.cumsum(length) - length, length)
    t = np.concatenate([before, before + 1, nearest - 1, nearest + 1, every])
    row = np.concatenate([row, row, row[near], row[near], np.repeat(whole, length)])
    if not len(row):
        return
    t = np.clip(t, 0, m[row])
    i, j = rows["i0"][row] + t * rows["di"][row], rows["j0"][row] + t * rows["dj"][row]
    grid.mark(grid.lattice(tri[row], i, j, n[row]))


def voxelize_surface(mesh: trimesh.Trimesh, pitch: float, walk: bool = True, max_rows: int = 200_000
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Boolean occupancy of the voxels that the surface passes through.

    Each triangle is sampled on a barycentric grid with spacing at most ``pitch / 2`` and every
    sample marks its voxel: the same cells as subdividing until edges are shorter than the pitch
    (trimesh's ``voxelized``), without building the subdivided mesh, which is what made that slow.
    A long thin triangle has a grid of n^2/2 points for a handful of voxels: its grid is walked in
    rows along its shortest edge instead, evaluating only the points where the voxel changes, which
    marks the same voxels.

    :param walk: walk the rows of thin triangles (False: evaluate every lattice point, the reference
        that the walk must reproduce)
    :param max_rows: rows walked at once (bounds the memory of the row walk)
    :returns: ``(occupancy of shape (nx, ny, nz), origin)``; voxel ``(i, j, k)`` covers
        ``origin + pitch * [i, i+1) x [j, j+1) x [k, k+1)``
    """
    triangles = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)]
    origin = triangles.reshape(-1, 3).min(0) - 0.5 * pitch
    shape = np.ceil((triangles.reshape(-1, 3).max(0) + 0.5 * pitch - origin) / pitch).astype(int) + 1
    grid = _Grid(origin, pitch, shape)
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(1)
    steps = np.maximum(1, np.ceil(edges / (0.5 * pitch))).astype(int)
    # rows along the shortest edge: how many voxel faces a row crosses at most, against the grid's size
    sides = np.stack([triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0],
                      triangles[:, 1] - triangles[:, 2]], axis=1)
    family = np.argmin(np.linalg.norm(sides, axis=2), axis=1)
    span = np.abs(sides[np.arange(len(sides)), family]).sum(1) / pitch
    walked = walk & (_WALK_COST * (steps + 1) * (2 + 2 * (span + 1)) < (steps + 1) * (steps + 2) / 2)
    _sample_grids(grid, triangles[~walked], steps[~walked])
    index = np.flatnonzero(walked)
    rows = np.cumsum(steps[index] + 1)
    cuts = np.searchsorted(rows, np.arange(max_rows, rows[-1] if len(rows) else 0, max_rows))
    for block in np.split(index, cuts):
        if len(block):
            _walk_rows(grid, triangles[block], steps[block], family[block])
    return grid.occupancy, origin


def fill_holes(occupancy: np.ndarray) -> np.ndarray:
    """``occupancy`` with every empty voxel that the outside cannot reach (through faces) filled.

    The same voxels as ``scipy.ndimage.binary_fill_holes`` (6-connected background), from one
    labelling pass instead of dilating from the border until nothing changes.
    """
    from scipy.ndimage import label

    labels, _ = label(np.pad(~occupancy, 1, constant_values=True))
    return (labels != labels[0, 0, 0])[1:-1, 1:-1, 1:-1]


@dataclass
class WatertightReport:
    """What :func:`make_watertight` did: ``method`` is ``cleanup`` (already watertight) or ``voxel``."""

    method: str
    pitch: float | None
    watertight: bool
    n_faces: int


def make_watertight(mesh: trimesh.Trimesh, resolution: int = 200, n_min: int = 3,
                    memory_cap: float = VOXEL_MEMORY_CAP, target_faces: int = 0,
                    simplify: float = 0.0) -> tuple[trimesh.Trimesh, WatertightReport]:
    """A watertight version of ``mesh`` following the SPARK appendix.

    :param mesh: input mesh (any quality)
    :param resolution: voxels along the largest axis (R)
    :param n_min: minimum voxels across the thinnest axis (N_min)
    :param memory_cap: voxel budget in bytes
    :param target_faces: quadric decimation target; 0 disables it (the paper's setting)
    :param simplify: manifold-preserving simplification of the voxel shell (manifold3d), with this
        tolerance in pitches; 0 disables it (the paper's setting). The shell stays watertight, while
        marching cubes' staircase (hundreds of thousands of faces) shrinks to a few thousand.
    """
    if len(mesh.faces) == 0:
        raise ValueError("empty mesh")
    if mesh.is_watertight:
        # a link made of several closed pieces (panels, a handle) is watertight as it is: the
        # largest-component filter is for voxel fragments, so it does not apply here
        cleaned = cleanup(mesh, keep_largest=False)
        if not cleaned.is_watertight:
            # dropping a zero-area sliver can open a mesh that was closed: keep the input as it is
            cleaned = trimesh.Trimesh(mesh.vertices.copy(), mesh.faces.copy(), process=False)
        return cleaned, WatertightReport("cleanup", None, True, len(cleaned.faces))
    from skimage.measure import marching_cubes

    extents = mesh.extents
    pitch = voxel_pitch(extents, resolution, n_min, memory_cap)
    occupancy, origin = voxelize_surface(mesh, pitch)
    occupancy = fill_holes(occupancy)
    # pad by one empty voxel so marching cubes closes the surface at the grid border
    verts, faces, _, _ = marching_cubes(np.pad(occupancy, 1).astype(np.float32), level=0.5)
    verts = origin + (verts - 1.0 + 0.5) * pitch  # voxel centers sit at half a pitch from the origin
    shell = trimesh.Trimesh(verts, faces[:, ::-1], process=False)
    # axis-wise rescale back to the original extents, about the original center
    center_orig = mesh.bounds.mean(0)
    center_shell = shell.bounds.mean(0)
    scale = extents / np.maximum(shell.extents, 1e-12)
    scale[extents <= 0] = 1.0
    shell.vertices = (shell.vertices - center_shell) * scale + center_orig
    # marching cubes orients its faces consistently: skip fix_normals, the slowest part of cleanup
    shell, watertight = _cleanup(shell, fix_normals=False)
    if signed_volume(shell) < 0:
        shell.invert()  # flips every face: the same edges, as watertight as before
    if simplify > 0:
        shell, watertight = simplify_manifold(shell, simplify * pitch), None
    if target_faces and len(shell.faces) > target_faces:
        shell, watertight = shell.simplify_quadric_decimation(face_count=target_faces), None
    watertight = bool(shell.is_watertight) if watertight is None else watertight
    return shell, WatertightReport("voxel", pitch, watertight, len(shell.faces))


def simplify_manifold(mesh: trimesh.Trimesh, tolerance: float) -> trimesh.Trimesh:
    """Simplify a watertight mesh within ``tolerance`` (world units) while keeping it a manifold."""
    import manifold3d

    solid = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32),
                                                tri_verts=np.asarray(mesh.faces, np.uint32)))
    out = solid.simplify(tolerance).to_mesh()
    simplified = trimesh.Trimesh(np.asarray(out.vert_properties[:, :3], float), np.asarray(out.tri_verts),
                                 process=False)
    return simplified if simplified.is_watertight and len(simplified.faces) else mesh


def drop_degenerate_faces(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Drop zero-area faces and unused vertices (MuJoCo rejects degenerate meshes).

    :returns: ``(vertices, faces)``, or None when nothing with an area (or nothing finite) is left
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0 or not np.isfinite(vertices).all():
        return None
    # the cross product and its norm one axis at a time: the operations (and the rounding) of
    # ``np.cross`` and ``np.linalg.norm``, without building the (F, 3, 3) array of triangles
    (ax, ay, az), (bx, by, bz) = ([vertices[faces[:, k], d] - vertices[faces[:, 0], d] for d in range(3)]
                                  for k in (1, 2))
    area = 0.5 * np.sqrt((ay * bz - az * by) ** 2 + (az * bx - ax * bz) ** 2 + (ax * by - ay * bx) ** 2)
    faces = faces[area > 1e-14 * max(1.0, float(np.ptp(vertices, axis=0).max()) ** 2)]
    if len(faces) == 0:
        return None
    referenced = np.zeros(len(vertices), dtype=bool)
    referenced[faces] = True
    used = np.flatnonzero(referenced)  # np.unique(faces), without sorting every index
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces]


def sample_surface(mesh: trimesh.Trimesh, n: int, seed: int = 0) -> np.ndarray:
    """``n`` points uniformly distributed over the surface area of ``mesh`` (seeded, float64).

    :param mesh: a triangle mesh (faces with zero area are never sampled)
    :param n: number of points
    :param seed: seed of the NumPy generator: the same seed gives the same points
    """
    return sample_triangles(np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)], n, seed)


def sample_triangles(triangles: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
    """``n`` area-weighted uniform samples on an (F, 3, 3) array of triangles."""
    if len(triangles) == 0:
        raise ValueError("cannot sample an empty mesh")
    a = triangles[:, 1] - triangles[:, 0]
    b = triangles[:, 2] - triangles[:, 0]
    areas = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
    total = areas.sum()
    if not np.isfinite(total) or total <= 0:
        raise ValueError("cannot sample a mesh with zero or non-finite surface area")
    rng = np.random.default_rng(seed)
    face = np.searchsorted(np.cumsum(areas) / total, rng.random(n), side="right")
    face = np.minimum(face, len(triangles) - 1)
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1.0
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    return triangles[face, 0] + u[:, None] * a[face] + v[:, None] * b[face]
