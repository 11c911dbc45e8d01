"""Mesh operations from the SPARK appendix, on trimesh meshes and plain arrays.

- :func:`merge_meshes`: per-link merge by vertex-face concatenation (appendix "Per-Link Geometry
  Cleaning and Merging").
- :func:`make_watertight`: voxelize at a pitch from R and N_min under a memory cap, fill, marching
  cubes, axis-wise rescale to the original extents, cleanup, largest component; meshes already
  watertight only get the cleanup (appendix "Watertight Part Preprocessing"). The voxel steps live
  in :mod:`spark_bench.asset.voxel`.
- :func:`sample_surface`: seeded, area-weighted uniform surface samples.
- :func:`weld`, :func:`vertex_components`: vertices merged on a grid; the pieces that share no vertex (the
  converter's hulls and the inside test of closed parts, :mod:`spark_bench.sim.solid`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from spark_bench.asset.voxel import VOXEL_MEMORY_CAP, fill_holes, voxel_pitch, voxelize_surface

__all__ = ["VOXEL_MEMORY_CAP", "WELD_RADIUS", "WatertightReport", "cleanup", "drop_degenerate_faces", "fill_holes",
           "make_watertight", "merge_meshes", "sample_surface", "sample_triangles", "signed_volume",
           "simplify_manifold", "vertex_components", "voxel_pitch", "voxelize_surface", "weld"]

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


def cleanup(mesh: trimesh.Trimesh, weld_radius: float = WELD_RADIUS, keep_largest: bool = True,
            fix_normals: bool = True) -> trimesh.Trimesh:
    """Weld close vertices, drop degenerate/duplicate faces and unused vertices, fix normals, and
    (``keep_largest``) keep the largest connected component (most faces, then largest volume)."""
    return cleanup_with_watertight(mesh, weld_radius, keep_largest, fix_normals)[0]


def cleanup_with_watertight(mesh: trimesh.Trimesh, weld_radius: float = WELD_RADIUS, keep_largest: bool = True,
             fix_normals: bool = True) -> tuple[trimesh.Trimesh, bool | None]:
    """:func:`cleanup`, and whether the result is watertight where that came for free (else None)."""
    mesh = mesh.copy()
    mesh.merge_vertices(digits_vertex=_weld_digits(weld_radius))
    if min_face_height(mesh) <= 100 * trimesh.tol.merge:  # else no face is degenerate: skip the slow test
        mesh.update_faces(mesh.nondegenerate_faces())
    # a watertight mesh in one piece repeats no face (two copies of a face would be a closed piece of
    # their own): then removing repeated faces would change nothing and is skipped
    structure = edge_structure(mesh.faces) if keep_largest else None
    if structure != (True, True) or len(mesh.faces) <= 2:
        mesh.update_faces(mesh.unique_faces())
        structure = None
    mesh.remove_unreferenced_vertices()
    watertight = None
    if keep_largest:
        # a mesh in one piece is kept as it is: check that first, which costs a fraction of splitting
        one_piece, watertight = structure or edge_structure(mesh.faces)
        parts = [mesh] if one_piece else mesh.split(only_watertight=False)
        if len(parts) > 1:
            mesh = max(parts, key=lambda m: (len(m.faces), abs(m.volume) if m.is_watertight else 0.0))
            watertight = None
    if fix_normals:
        trimesh.repair.fix_normals(mesh)
        watertight = None
    return mesh, watertight


def _weld_digits(weld_radius: float) -> int:
    """The decimals that :func:`cleanup_with_watertight`'s weld rounds vertices to (trimesh's ``digits_vertex``).

    :param weld_radius: the weld radius
    """
    return max(0, int(-np.log10(weld_radius)))


def min_face_height(mesh: trimesh.Trimesh) -> float:
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


def edge_structure(faces: np.ndarray) -> tuple[bool, bool]:
    """``(one piece, watertight)`` of a triangle list, from one sort of its edges.

    One piece: the faces form one connected component, two faces being adjacent when they share an
    edge that no third face has (trimesh's ``face_adjacency``, which ``split`` follows). Watertight:
    every edge has exactly two faces (trimesh's ``is_watertight``).
    """
    count, _, watertight = face_components(faces)
    return count == 1, watertight


def face_components(faces: np.ndarray) -> tuple[int, np.ndarray, bool]:
    """``(number of components, label per face, watertight)`` of a triangle list (see
    :func:`edge_structure`). The labels are scipy's for the face-adjacency graph, numbered in the order
    of each component's first face: the array trimesh's ``split`` groups its faces by.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return 1, np.zeros(0, dtype=np.int32), False
    paired = twin_pairs(faces)
    if paired is not None:  # every edge has exactly two faces, walked in opposite directions
        a, b = paired
        graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(len(faces), len(faces)))
        count, labels = connected_components(graph, directed=False)
        return int(count), labels, True
    # edge k of face f is key 3 f + k: (f0, f1), (f1, f2), (f2, f0), as (smaller, larger) vertex
    u, v = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    key = np.minimum(u, v) * (int(faces.max()) + 1) + np.maximum(u, v)
    order = np.argsort(key)
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    counts = np.diff(np.r_[starts, len(key)])
    pairs = starts[counts == 2]  # edges shared by exactly two faces
    a, b = order[pairs] // 3, order[pairs + 1] // 3
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(len(faces), len(faces)))
    count, labels = connected_components(graph, directed=False)
    return int(count), labels, bool(len(pairs) * 2 == len(key))


def twin_pairs(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The pairs of faces sharing an edge, when every directed edge ``u -> v`` of the faces occurs
    exactly once and so does its twin ``v -> u`` (a closed, consistently oriented surface: marching
    cubes'); None otherwise. Then every edge has exactly two faces, and these are the pairs of
    trimesh's ``face_adjacency``, found by two sparse-matrix transposes instead of sorting the edges.
    """
    from scipy.sparse import csr_matrix

    u, v = faces.ravel(), faces[:, [1, 2, 0]].ravel()  # directed edge k of face f is 3 f + k
    if (u == v).any():
        return None
    n = int(faces.max()) + 1
    half = csr_matrix((np.arange(1, len(u) + 1, dtype=np.int64), (u, v)), shape=(n, n))
    if half.nnz != len(u):  # a directed edge repeated (its entries were summed)
        return None
    half.sort_indices()
    twin = half.T.tocsr()  # entry (u, v) holds the directed edge v -> u
    twin.sort_indices()
    if not (np.array_equal(half.indptr, twin.indptr) and np.array_equal(half.indices, twin.indices)):
        return None
    a, b = (half.data - 1) // 3, (twin.data - 1) // 3
    keep = a < b  # each edge once
    return a[keep], b[keep]


def vertex_spacing(grid_vertices: np.ndarray) -> float:
    """A lower bound of the largest per-axis difference between any two distinct marching-cubes
    vertices, in voxels (0: two coincide).

    A vertex at the midpoint of a grid edge (one coordinate a half-integer, the other two integers)
    differs from every other such vertex by at least half a voxel along some axis. Lewiner's cases
    with a vertex inside the cube add a few others: each is checked against its nearest neighbour.
    """
    vertices = np.asarray(grid_vertices)
    twice = vertices * 2  # exact: a power of two
    steps = twice.astype(np.int64)
    odd = (steps & 1).sum(1)
    midpoint = (odd == 1) & (steps == twice).all(1)  # one half-integer coordinate, two integers
    others = vertices[~midpoint].astype(np.float64)
    if len(others) == 0 or len(vertices) < 2:
        return 0.5
    from scipy.spatial import cKDTree

    # the nearest two of each: the vertex itself, then its nearest other (per-axis distance)
    distance, _ = cKDTree(vertices.astype(np.float64)).query(others, k=2, p=np.inf)
    return float(min(0.5, distance[:, 1].min()))


def shell_cleanup(mesh: trimesh.Trimesh, spacing: float) -> tuple[trimesh.Trimesh, bool] | None:
    """:func:`cleanup_with_watertight` (``fix_normals=False``) of a marching-cubes shell whose vertices lie at least
    ``spacing`` apart along some axis, without the steps it can prove change nothing; None where a
    proof fails (then the caller runs :func:`cleanup_with_watertight`). Byte-identical to :func:`cleanup_with_watertight`.

    - Welding at ``WELD_RADIUS`` merges only vertices that round to the same multiple of it on every
      axis, so none when ``spacing`` exceeds twice that and every vertex is used: the weld keeps them
      all, in order.
    - No face is degenerate (:func:`min_face_height` above trimesh's tolerance): none is dropped.
    - Every edge has exactly two faces (watertight) and every piece at least four faces: no face is
      repeated (two copies of a face would be a closed piece of two), so the dedupe keeps them all.
    - The largest piece (most faces, then largest volume) is trimesh's ``split`` piece: the same
      component labels, grouped by trimesh's own ``group``, the faces and the vertices they use in
      the order ``submesh`` keeps them. Each piece is watertight, so ``split``'s hole repair adds none.

    :param mesh: the shell (vertices and faces; nothing cached is used)
    :param spacing: a lower bound of the distance between two vertices along the axis where they
        differ most (:func:`vertex_spacing` times the pitch, times the smallest rescale)
    :returns: ``(mesh, True)``: the cleaned shell, watertight, or None
    """
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    quantum = 10.0 ** -_weld_digits(WELD_RADIUS)  # what cleanup_with_watertight's merge_vertices rounds to
    if len(faces) <= 2 or not spacing > 2.0 * quantum:
        return None
    used = np.zeros(len(vertices), dtype=bool)
    used[faces] = True
    if not used.all() or min_face_height(mesh) <= 100 * trimesh.tol.merge:
        return None
    count, labels, watertight = face_components(faces)
    if not watertight:
        return None
    if count > 1:
        from trimesh.grouping import group

        sizes = np.bincount(labels)
        if sizes.min() < 4:
            return None
        pieces = group(labels)  # as split: by label, each piece's faces in this order
        largest = [p for p in pieces if len(p) == sizes.max()]
        if len(largest) > 1:  # a tie in faces: the larger volume, as trimesh computes it
            volumes = [abs(m.volume) for m in mesh.submesh(largest, only_watertight=False, repair=False)]
            largest = [largest[int(np.argmax(volumes))]]  # argmax and max both keep the first maximum
        kept = faces[largest[0]]
        unique = np.unique(kept.reshape(-1))
        remap = np.arange(len(vertices))
        remap[unique] = np.arange(len(unique))
        vertices, faces = vertices[unique], remap[kept]
    return trimesh.Trimesh(vertices, faces, process=False), True


def signed_volume(mesh: trimesh.Trimesh) -> float:
    """The signed volume of a closed mesh (positive when its faces wind outwards): trimesh's volume
    integral, without the inertia that ``mesh.volume`` computes along with it."""
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    x, y, z = (vertices[faces, d] for d in range(3))  # (F, 3) each
    cross_x = (y[:, 1] - y[:, 0]) * (z[:, 2] - z[:, 0]) - (z[:, 1] - z[:, 0]) * (y[:, 2] - y[:, 0])
    return float(np.dot(cross_x, x[:, 0] + x[:, 1] + x[:, 2])) / 6.0


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
    grid_verts, faces, _, _ = marching_cubes(np.pad(occupancy, 1).astype(np.float32), level=0.5)
    verts = origin + (grid_verts - 1.0 + 0.5) * pitch  # voxel centers sit at half a pitch from the origin
    shell = trimesh.Trimesh(verts, faces[:, ::-1], process=False)
    # axis-wise rescale back to the original extents, about the original center
    center_orig = mesh.bounds.mean(0)
    center_shell = shell.bounds.mean(0)
    scale = extents / np.maximum(shell.extents, 1e-12)
    scale[extents <= 0] = 1.0
    shell.vertices = (shell.vertices - center_shell) * scale + center_orig
    # how far apart the vertices are at least (what decides whether welding merges any), less the
    # rounding of the float32 arithmetic above
    spacing = vertex_spacing(grid_verts) - 8 * float(np.spacing(np.float32(np.abs(grid_verts).max() + 2)))
    # marching cubes orients its faces consistently: skip fix_normals, the slowest part of cleanup
    fast = shell_cleanup(shell, spacing * pitch * float(scale.min()))
    shell, watertight = fast if fast is not None else cleanup_with_watertight(shell, fix_normals=False)
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


def weld(mesh: trimesh.Trimesh, tolerance: float) -> trimesh.Trimesh:
    """``mesh`` with vertices on the same ``tolerance`` grid cell merged (a grid in units of the
    tolerance, so that a scaled mesh welds the same) and degenerate faces dropped."""
    tolerance = max(tolerance, 1e-12)
    vertices = np.asarray(mesh.vertices, np.float64)
    _, first, inverse = np.unique(np.round(vertices / tolerance), axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[np.asarray(mesh.faces, np.int64)]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    welded = trimesh.Trimesh(vertices[first], faces, process=False)
    welded.update_faces(welded.nondegenerate_faces())
    welded.remove_unreferenced_vertices()
    return welded


def vertex_components(mesh: trimesh.Trimesh) -> list[trimesh.Trimesh]:
    """Pieces of ``mesh`` that share no vertex (after welding). Unlike trimesh's ``split``, which follows
    shared manifold edges, this keeps two-sided and non-manifold surfaces in one piece."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(mesh.faces)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]])
    n = len(mesh.vertices)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    if count <= 1:
        return [mesh]
    face_label = labels[faces[:, 0]]
    out = []
    for label in np.unique(face_label):
        part = trimesh.Trimesh(mesh.vertices, faces[face_label == label], process=False)
        part.remove_unreferenced_vertices()
        out.append(part)
    return out


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
