"""Seeded, area-weighted uniform surface samples, ordered by face.

The points follow the same distribution as :func:`spark_bench.asset.mesh.sample_surface` (i.i.d.,
uniform over the surface area, faces picked by inverse CDF of the cumulative area), with one change:
the uniform numbers that pick the faces are drawn already sorted (normalized cumulative sums of
exponential variables, O(n)), so the points come out grouped by face. Mesh faces are stored with
spatial coherence (a part, a panel, a strip), so face-ordered points are roughly spatially ordered,
which makes the k-d tree queries of the shape metrics faster (memory locality).

The inverse CDF matters: the samples are a continuous function of the geometry for a fixed seed, so
two surfaces that differ by rounding get the same samples up to rounding (a per-face multinomial
count would jump at the first count that rounding changes, turning 1e-16 into sampling noise).
"""

from __future__ import annotations

import numpy as np

#: Below this many points per surface, two threads cost more than they save.
PARALLEL_MIN_SAMPLES = 20_000


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """Area of each triangle of an (F, 3, 3) array."""
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return 0.5 * np.sqrt(np.einsum("ij,ij->i", cross, cross))


def sample_triangles(triangles: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
    """``n`` uniform samples (float64, grouped by face) on an (F, 3, 3) array of triangles.

    :param triangles: the surface as triangles, vertices in rows
    :param n: number of points
    :param seed: seed of the NumPy generator: the same surface and seed give the same points
    :raises ValueError: when there is no triangle or the surface area is zero or not finite
    """
    triangles = np.asarray(triangles, dtype=np.float64)
    if triangles.ndim != 3 or triangles.shape[1:] != (3, 3) or len(triangles) == 0:
        raise ValueError("cannot sample an empty mesh")
    areas = triangle_areas(triangles)
    total = float(areas.sum())
    if not np.isfinite(total) or total <= 0.0:
        raise ValueError("cannot sample a mesh with zero or non-finite surface area")
    rng = np.random.default_rng(seed)
    n = int(n)
    # n sorted uniforms in O(n): U_(k) = S_k / S_(n+1) with S the cumulative sum of Exp(1) draws
    spacing = np.cumsum(rng.standard_exponential(n + 1))
    cumulative = np.cumsum(areas)
    picks = spacing[:-1] * (cumulative[-1] / spacing[-1])
    face = np.minimum(np.searchsorted(cumulative, picks, side="right"), len(triangles) - 1)
    uv = rng.random((n, 2))
    # fold the unit square onto the triangle: (u, v) with u + v > 1 maps to (1 - u, 1 - v)
    u, v = uv[:, 0], uv[:, 1]
    flip = (u + v) > 1.0
    u, v = np.where(flip, 1.0 - u, u), np.where(flip, 1.0 - v, v)
    # origin + u (p1 - origin) + v (p2 - origin), edges per face, gathered once per sample
    edge_1 = triangles[:, 1] - triangles[:, 0]
    edge_2 = triangles[:, 2] - triangles[:, 0]
    out = edge_1[face]
    out *= u[:, None]
    out += triangles[face, 0]
    second = edge_2[face]
    second *= v[:, None]
    out += second
    return out


def sample_pair(triangles_a: np.ndarray, triangles_b: np.ndarray, n: int, seed: int = 0
                ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sample_triangles` on two surfaces with the same ``n`` and ``seed``, in two threads
    (NumPy releases the GIL in the heavy steps) when ``n`` is large enough to pay for it."""
    if n < PARALLEL_MIN_SAMPLES:
        return sample_triangles(triangles_a, n, seed), sample_triangles(triangles_b, n, seed)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:
        a = pool.submit(sample_triangles, triangles_a, n, seed)
        b = pool.submit(sample_triangles, triangles_b, n, seed)
        return a.result(), b.result()
