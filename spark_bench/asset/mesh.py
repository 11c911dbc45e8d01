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
    mesh = mesh.copy()
    mesh.merge_vertices(digits_vertex=max(0, int(-np.log10(weld_radius))))
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    parts = mesh.split(only_watertight=False) if keep_largest else [mesh]
    if len(parts) > 1:
        mesh = max(parts, key=lambda m: (len(m.faces), abs(m.volume) if m.is_watertight else 0.0))
    if fix_normals:
        trimesh.repair.fix_normals(mesh)
    return mesh


def _barycentric_grid(n: int) -> np.ndarray:
    """Barycentric weights (k, 3) of the points ``(i/n, j/n)``, ``i + j <= n``, of a triangle."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    u, v = i[keep] / n, j[keep] / n
    return np.stack([1.0 - u - v, u, v], axis=1)


def voxelize_surface(mesh: trimesh.Trimesh, pitch: float, chunk_points: int = 2_000_000
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Boolean occupancy of the voxels that the surface passes through.

    Each triangle is sampled on a barycentric grid with spacing at most ``pitch / 2`` and every
    sample marks its voxel: the same cells as subdividing until edges are shorter than the pitch
    (trimesh's ``voxelized``), without building the subdivided mesh, which is what made that slow.

    :returns: ``(occupancy of shape (nx, ny, nz), origin)``; voxel ``(i, j, k)`` covers
        ``origin + pitch * [i, i+1) x [j, j+1) x [k, k+1)``
    """
    triangles = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)]
    origin = triangles.reshape(-1, 3).min(0) - 0.5 * pitch
    shape = np.ceil((triangles.reshape(-1, 3).max(0) + 0.5 * pitch - origin) / pitch).astype(int) + 1
    occupancy = np.zeros(shape, dtype=bool)
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(1)
    steps = np.maximum(1, np.ceil(edges / (0.5 * pitch))).astype(int)
    for n in np.unique(steps):
        group = triangles[steps == n]
        weights = _barycentric_grid(int(n))
        per_chunk = max(1, chunk_points // len(weights))
        for start in range(0, len(group), per_chunk):
            points = np.einsum("kv,tvd->tkd", weights, group[start:start + per_chunk]).reshape(-1, 3)
            index = np.floor((points - origin) / pitch).astype(int)
            np.clip(index, 0, shape - 1, out=index)
            occupancy[index[:, 0], index[:, 1], index[:, 2]] = True
    return occupancy, origin


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
    from scipy.ndimage import binary_fill_holes
    from skimage.measure import marching_cubes

    extents = mesh.extents
    pitch = voxel_pitch(extents, resolution, n_min, memory_cap)
    occupancy, origin = voxelize_surface(mesh, pitch)
    occupancy = binary_fill_holes(occupancy)
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
    shell = cleanup(shell, fix_normals=False)
    if shell.volume < 0:
        shell.invert()
    if simplify > 0:
        shell = simplify_manifold(shell, simplify * pitch)
    if target_faces and len(shell.faces) > target_faces:
        shell = shell.simplify_quadric_decimation(face_count=target_faces)
    return shell, WatertightReport("voxel", pitch, bool(shell.is_watertight), len(shell.faces))


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
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    faces = faces[area > 1e-14 * max(1.0, float(np.ptp(vertices, axis=0).max()) ** 2)]
    if len(faces) == 0:
        return None
    used = np.unique(faces)
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
