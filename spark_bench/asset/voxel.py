"""Surface voxelization and hole filling of the watertight remesh (SPARK appendix, "Watertight Part
Preprocessing"): the pitch from R and N_min under a memory cap, the voxels a surface passes through
(exactly the cells of sampling each triangle at half a pitch), and the enclosed voxels filled.
:func:`spark_bench.asset.mesh.make_watertight` runs these before marching cubes.
"""

from __future__ import annotations

import functools

import numpy as np
import trimesh

#: Soft cap on the voxel grid, in bytes (one byte per voxel), as in the appendix.
VOXEL_MEMORY_CAP = 400_000_000


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


def _barycentric_grid(n: int) -> np.ndarray:
    """Barycentric weights (k, 3) of the points ``(i/n, j/n)``, ``i + j <= n``, of a triangle (read-only).
    The small grids recur in every mesh and are kept (at most ~10 MB)."""
    return _small_grid(n) if n <= 128 else _grid_weights(n)


@functools.cache
def _small_grid(n: int) -> np.ndarray:
    return _grid_weights(n)


def _grid_weights(n: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    u, v = i[keep] / n, j[keep] / n
    out = np.stack([1.0 - u - v, u, v], axis=1)
    out.flags.writeable = False
    return out


#: Relative cost of a point evaluated alone (row walk) and of one in a triangle's full grid, which is
#: what :func:`voxelize_surface` weighs to choose between walking a triangle's rows and its full grid.
_WALK_COST = 6.0
#: Lattice points per block of the full-grid sampler (small enough for the arrays to stay in cache).
_BLOCK_POINTS = 1 << 16


class VoxelGrid:
    """The voxel grid of :func:`voxelize_surface`, and the one formula from a triangle's lattice point
    to its voxel, shared by both samplers so that a point lands in the same voxel whichever visits it.

    Lattice point ``(i, j)`` of triangle ``(a, b, c)`` with ``n`` steps has barycentric weights
    ``w = (1 - i/n - j/n, i/n, j/n)`` and world coordinates ``(w0 a + w1 b) + w2 c`` (summed in this
    order, as ``einsum("kv,tvd->tkd")`` does).
    """

    def __init__(self, origin: np.ndarray, pitch: float, shape: np.ndarray):
        self.origin, self.pitch, self.shape = origin, pitch, shape
        self.occupancy = np.zeros(tuple(shape), dtype=bool)
        self._scratch: dict[str, np.ndarray] = {}

    def _buffer(self, name: str, shape: tuple[int, ...], dtype) -> np.ndarray:
        """A reused array of ``shape`` (contents undefined): fresh arrays of this size cost a page fault
        per 4 KiB on every block, more than the arithmetic on them."""
        size = int(np.prod(shape))
        buffer = self._scratch.get(name)
        if buffer is None or buffer.size < size:
            buffer = self._scratch[name] = np.empty(max(size, 1), dtype=dtype)
        return buffer[:size].reshape(shape)

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
            # truncation is the floor (and never below 0: it rounds towards 0); the minimum only
            # guards the last voxel against rounding
            index = x.astype(np.intp)
            np.minimum(index, self.shape[d] - 1, out=index)
            flat = index if flat is None else flat * self.shape[d] + index
        self.occupancy.ravel()[flat.ravel()] = True

    def mark_points(self, w0, w1, w2, a, b, c) -> None:
        """:meth:`mark` of :meth:`coordinates` with the same operations in the same order (so the same
        voxels), computed in reused buffers."""
        shape = np.broadcast_shapes(np.shape(w0), a.shape[:-1])
        x, term = self._buffer("x", shape, np.float64), self._buffer("term", shape, np.float64)
        index, flat = self._buffer("index", shape, np.intp), self._buffer("flat", shape, np.intp)
        for d in range(3):
            np.multiply(w0, a[..., d], out=x)
            np.add(x, np.multiply(w1, b[..., d], out=term), out=x)
            np.add(x, np.multiply(w2, c[..., d], out=term), out=x)
            np.subtract(x, self.origin[d], out=x)
            np.divide(x, self.pitch, out=x)
            np.copyto(index, x, casting="unsafe")  # truncation, as astype (see mark)
            np.minimum(index, self.shape[d] - 1, out=index)
            if d == 0:
                np.copyto(flat, index)
            else:
                np.add(np.multiply(flat, self.shape[d], out=flat), index, out=flat)
        self.occupancy.ravel()[flat.ravel()] = True

    def lattice(self, triangles: np.ndarray, i: np.ndarray, j: np.ndarray, n: np.ndarray) -> list[np.ndarray]:
        """Voxel coordinates of lattice point ``(i[p], j[p])`` of ``triangles[p]`` (``n[p]`` steps)."""
        u, v = i / n, j / n
        return self.coordinates(1.0 - u - v, u, v, triangles[:, 0], triangles[:, 1], triangles[:, 2])


def sample_grids(grid: VoxelGrid, triangles: np.ndarray, steps: np.ndarray) -> None:
    """Mark the voxel of every point of every triangle's full lattice (``steps`` per side)."""
    for n in np.unique(steps):
        group = triangles[steps == n]
        weights = _barycentric_grid(int(n))
        w0, w1, w2 = (weights[None, :, k] for k in range(3))
        per_block = max(1, _BLOCK_POINTS // len(weights))
        for start in range(0, len(group), per_block):
            corners = group[start:start + per_block, :, None, :]
            grid.mark_points(w0, w1, w2, corners[:, 0], corners[:, 1], corners[:, 2])


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


def walk_rows(grid: VoxelGrid, triangles: np.ndarray, steps: np.ndarray, family: np.ndarray) -> None:
    """Mark the voxels of every lattice point of ``triangles``, evaluating only the points next to a
    voxel face.

    Along a row the voxel changes only where the row crosses a voxel face, so the row's voxels are
    those of its ends and of the points on either side of each crossing. Each crossing is located
    from the row's ends, and the lattice points around it are evaluated with :meth:`VoxelGrid.lattice`
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
    u, v = i / n[row], j / n[row]  # as lattice(), marked in reused buffers
    triangles = tri[row]
    grid.mark_points(1.0 - u - v, u, v, triangles[:, 0], triangles[:, 1], triangles[:, 2])


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
    grid = VoxelGrid(origin, pitch, shape)
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(1)
    steps = np.maximum(1, np.ceil(edges / (0.5 * pitch))).astype(int)
    # rows along the shortest edge: how many voxel faces a row crosses at most, against the grid's size
    sides = np.stack([triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0],
                      triangles[:, 1] - triangles[:, 2]], axis=1)
    family = np.argmin(np.linalg.norm(sides, axis=2), axis=1)
    span = np.abs(sides[np.arange(len(sides)), family]).sum(1) / pitch
    walked = walk & (_WALK_COST * (steps + 1) * (2 + 2 * (span + 1)) < (steps + 1) * (steps + 2) / 2)
    sample_grids(grid, triangles[~walked], steps[~walked])
    index = np.flatnonzero(walked)
    rows = np.cumsum(steps[index] + 1)
    cuts = np.searchsorted(rows, np.arange(max_rows, rows[-1] if len(rows) else 0, max_rows))
    for block in np.split(index, cuts):
        if len(block):
            walk_rows(grid, triangles[block], steps[block], family[block])
    return grid.occupancy, origin


def fill_holes(occupancy: np.ndarray) -> np.ndarray:
    """``occupancy`` with every empty voxel that the outside cannot reach (through faces) filled.

    The same voxels as ``scipy.ndimage.binary_fill_holes`` (6-connected background), from one
    labelling pass instead of dilating from the border until nothing changes.
    """
    from scipy.ndimage import label

    labels, _ = label(np.pad(~occupancy, 1, constant_values=True))
    return (labels != labels[0, 0, 0])[1:-1, 1:-1, 1:-1]
