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


def cleanup(mesh: trimesh.Trimesh, weld_radius: float = WELD_RADIUS) -> trimesh.Trimesh:
    """Weld close vertices, drop degenerate/duplicate faces and unused vertices, fix normals,
    keep the largest connected component (most faces, then largest volume)."""
    mesh = mesh.copy()
    mesh.merge_vertices(digits_vertex=max(0, int(-np.log10(weld_radius))))
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    parts = mesh.split(only_watertight=False)
    if len(parts) > 1:
        mesh = max(parts, key=lambda m: (len(m.faces), abs(m.volume) if m.is_watertight else 0.0))
    trimesh.repair.fix_normals(mesh)
    return mesh


@dataclass
class WatertightReport:
    """What :func:`make_watertight` did: ``method`` is ``cleanup`` (already watertight) or ``voxel``."""

    method: str
    pitch: float | None
    watertight: bool
    n_faces: int


def make_watertight(mesh: trimesh.Trimesh, resolution: int = 200, n_min: int = 3,
                    memory_cap: float = VOXEL_MEMORY_CAP, target_faces: int = 0
                    ) -> tuple[trimesh.Trimesh, WatertightReport]:
    """A watertight version of ``mesh`` following the SPARK appendix.

    :param mesh: input mesh (any quality)
    :param resolution: voxels along the largest axis (R)
    :param n_min: minimum voxels across the thinnest axis (N_min)
    :param memory_cap: voxel budget in bytes
    :param target_faces: quadric decimation target; 0 disables it (the paper's setting)
    """
    if len(mesh.faces) == 0:
        raise ValueError("empty mesh")
    if mesh.is_watertight:
        cleaned = cleanup(mesh)
        if cleaned.is_watertight:
            return cleaned, WatertightReport("cleanup", None, True, len(cleaned.faces))
    from skimage.measure import marching_cubes

    extents = mesh.extents
    pitch = voxel_pitch(extents, resolution, n_min, memory_cap)
    grid = mesh.voxelized(pitch).fill()
    # pad by one empty voxel so marching cubes closes the surface at the grid border
    occupancy = np.pad(grid.matrix.astype(np.float32), 1)
    verts, faces, _, _ = marching_cubes(occupancy, level=0.5)
    verts = (verts - 1.0) @ grid.transform[:3, :3].T + grid.transform[:3, 3]
    shell = trimesh.Trimesh(verts, faces[:, ::-1], process=False)
    # axis-wise rescale back to the original extents, about the original center
    center_orig = mesh.bounds.mean(0)
    center_shell = shell.bounds.mean(0)
    scale = extents / np.maximum(shell.extents, 1e-12)
    scale[extents <= 0] = 1.0
    shell.vertices = (shell.vertices - center_shell) * scale + center_orig
    shell = cleanup(shell)
    if target_faces and len(shell.faces) > target_faces:
        shell = shell.simplify_quadric_decimation(face_count=target_faces)
    return shell, WatertightReport("voxel", pitch, bool(shell.is_watertight), len(shell.faces))


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
