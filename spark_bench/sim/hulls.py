"""Collision shapes of every link: primitives and convex meshes as given, CoACD hulls for the rest.

Per link, the collision elements (``<collision>``; the visuals when there are none) are sorted:

1. primitives and convex meshes are used as they are;
2. a non-convex element whose own convex hull stays within ``convex_tolerance`` of its surface (a
   panel, a box, a bevelled board: most PartNet-Mobility parts) is replaced by that hull, which is what
   CoACD would return for it, at no cost;
3. otherwise its connected components are tried the same way, and what remains non-convex is
   decomposed: exactly into boxes where it is an orthogonal polyhedron (a drawer, an appliance's open
   body), else by CoACD (its own manifold preprocessing makes the open, zero-thickness PartNet surfaces
   watertight).

Flat and thin hulls are thickened to ``min_thickness`` (a plane has no convex volume, which is why
MuJoCo's importer fails on such objects); a link with more than ``hull_budget`` hulls has its
closest hulls merged greedily, cheapest added volume first.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError, cKDTree

from spark_bench.asset.mesh import vertex_components, weld
from spark_bench.asset.model import ArticulatedAsset, Link
from spark_bench.sim.decompose import decompose_many, normalized
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.shape_cache import as_cached, link_key, load_shapes, store_shapes
from spark_bench.sim.shapes import CollisionReport, CollisionShape

#: Most connected components an element is split into before it goes to CoACD whole (triangle soups).
MAX_COMPONENTS = 48


# ----- convex hulls on plain arrays -------------------------------------------------------------
def thicken_points(points: np.ndarray, thickness: float, toward: np.ndarray | None = None) -> np.ndarray:
    """Points of a flat or thin set extruded along its thinnest principal axis so that the set is at
    least ``thickness`` thick (unchanged when it already is).

    :param toward: grow towards this point (the link's center: a door's flat face thickens into the
        door, not into the carcass behind it) when it lies farther than ``thickness`` off the plane;
        otherwise grow symmetrically
    """
    points = np.asarray(points, dtype=float)
    centered = points - points.mean(0)
    _, _, vt = np.linalg.svd(centered, full_matrices=False)
    for axis in vt[::-1]:  # thinnest first; a segment or a point needs two axes
        along = centered @ axis
        width = float(np.ptp(along))
        if width >= thickness:
            break
        grow = thickness - width
        side = 0.0 if toward is None else float(np.dot(np.asarray(toward) - points.mean(0), axis))
        if abs(side) > thickness:
            points = np.concatenate([points, points + np.sign(side) * grow * axis])
        else:
            points = np.concatenate([points + 0.5 * grow * axis, points - 0.5 * grow * axis])
        centered = points - points.mean(0)
    return points


def erode_hull(vertices: np.ndarray, depth: float) -> np.ndarray:
    """Vertices of a convex hull with every face moved ``depth`` inwards (an exact inward offset).
    Directions thinner than ``4 * depth`` are not eroded: the hull is returned unchanged then."""
    from scipy.spatial import HalfspaceIntersection

    if depth <= 0:
        return vertices
    try:
        hull = ConvexHull(vertices, qhull_options="Qt")
    except QhullError:
        return vertices
    equations = hull.equations.copy()  # n . x + d <= 0 inside, |n| = 1
    center = vertices[hull.vertices].mean(0)
    if np.max(equations[:, :3] @ center + equations[:, 3]) > -2.0 * depth:
        return vertices  # too thin somewhere: keep the hull (a thin hull keeps its thickness)
    equations[:, 3] += depth
    try:
        return HalfspaceIntersection(equations, center).intersections
    except (QhullError, ValueError):
        return vertices


def convex_hull(points: np.ndarray, thickness: float, max_vertices: int = 0,
                toward: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Convex hull ``(vertices, faces)`` of ``points`` thickened to ``thickness``, outward-facing faces.

    :param max_vertices: when positive, keep at most this many hull vertices (farthest-point subset of
        the hull's vertices, re-hulled), which MuJoCo and PyBullet collide fastest with
    """
    points = thicken_points(np.unique(np.round(np.asarray(points, dtype=float), 12), axis=0), thickness, toward)
    try:
        hull = ConvexHull(points, qhull_options="Qt")
    except QhullError:
        hull = ConvexHull(points, qhull_options="Qt QJ")
    vertices = points[hull.vertices]
    if max_vertices and len(vertices) > max_vertices:
        vertices = vertices[farthest_points(vertices, max_vertices)]
        hull = ConvexHull(vertices, qhull_options="Qt")
        vertices = vertices[hull.vertices]
    mesh = trimesh.convex.convex_hull(vertices)
    return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64)


def farthest_points(points: np.ndarray, k: int) -> np.ndarray:
    """Indices of ``k`` points chosen by farthest-point sampling (deterministic, starts at the
    point farthest from the centroid)."""
    dist = np.linalg.norm(points - points.mean(0), axis=1)
    chosen = [int(np.argmax(dist))]
    dist = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(1, min(k, len(points))):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(points - points[nxt], axis=1))
    return np.array(chosen)


def concavity(mesh: trimesh.Trimesh, hull_vertices: np.ndarray, hull_faces: np.ndarray, spacing: float) -> float:
    """How far the hull surface gets from the mesh surface: the largest distance from samples of the
    hull's surface to samples of the mesh's surface (spaced ``spacing`` apart, an over-estimate by at
    most about ``spacing``). The same quantity CoACD thresholds."""
    hull = trimesh.Trimesh(hull_vertices, hull_faces, process=False)
    n_mesh = int(np.clip(mesh.area / spacing ** 2, 256, 60_000))
    n_hull = int(np.clip(hull.area / spacing ** 2, 64, 2_000))
    mesh_points = np.concatenate([mesh.vertices, trimesh.sample.sample_surface(mesh, n_mesh, seed=0)[0]])
    hull_points = np.concatenate([hull_vertices, trimesh.sample.sample_surface(hull, n_hull, seed=1)[0]])
    distance, _ = cKDTree(mesh_points).query(hull_points)
    return float(distance.max())


# ----- per link -----------------------------------------------------------------------------------
@dataclass
class _Pending:
    link: str
    mesh: trimesh.Trimesh


def simplify(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """A watertight ``mesh`` with more than ``max_faces`` faces simplified to about that many
    (quadric decimation, deterministic); any other mesh, or any with ``max_faces`` 0, unchanged.

    Only closed meshes are simplified: CoACD remeshes an open one itself (at its preprocessing
    resolution, far coarser), and decimating a triangle soup can fold its thin panels.
    """
    if max_faces <= 0 or len(mesh.faces) <= max_faces or not mesh.is_watertight:
        return mesh
    import fast_simplification

    # on the mesh's normalized coordinates (:func:`~spark_bench.sim.decompose.normalized`), so that a
    # scaled or moved copy simplifies the same: the decimation turns float noise into other decisions
    # (2498 or 2497 vertices for one part and its copy scaled by 0.81), rounding to 2^-30 removes it
    unit, center, extent = normalized(np.asarray(mesh.vertices, np.float64))
    vertices, faces = fast_simplification.simplify(unit, np.asarray(mesh.faces, np.int64),
                                                   target_reduction=1.0 - max_faces / len(mesh.faces))
    if len(faces) < 4:  # nothing sensible left: keep the original
        return mesh
    return trimesh.Trimesh(np.asarray(vertices, np.float64) * extent + center, faces, process=False)


def _element_meshes(link: Link, options: ConvertOptions) -> tuple[list[CollisionShape], list[trimesh.Trimesh]]:
    """Shapes usable as they are, and the non-convex element meshes (in the link frame)."""
    ready, meshes = [], []
    for col in link.collisions:
        if col.kind != "mesh":
            ready.append(CollisionShape(col.kind, "primitive", origin=np.asarray(col.origin, float),
                                        size=np.asarray(col.size, float)))
        elif col.mesh is not None and len(col.mesh.faces):
            mesh = col.to_trimesh()
            if col.is_convex:
                ready.append(CollisionShape("mesh", "convex", vertices=np.asarray(mesh.vertices, float),
                                            faces=np.asarray(mesh.faces, np.int64)))
            else:
                meshes.append(mesh)
    if not link.collisions and options.decompose_visuals:
        meshes = [v.mesh for v in link.visuals if len(v.mesh.faces)]
    return ready, meshes


@dataclass
class _LinkGeometry:
    """Tolerances of one link's decomposition (lengths in metres)."""

    tolerance: float
    thickness: float
    spacing: float
    max_vertices: int
    center: np.ndarray
    diagonal: float

    def hull(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return convex_hull(points, self.thickness, self.max_vertices, toward=self.center)


def _sort_element(mesh: trimesh.Trimesh, geo: _LinkGeometry, depth: int = 0
                  ) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[trimesh.Trimesh]]:
    """Hulls for the near-convex pieces of ``mesh`` and the pieces that need CoACD."""
    vertices, faces = geo.hull(mesh.vertices)
    if concavity(mesh, vertices, faces, geo.spacing) <= geo.tolerance + geo.thickness:
        return [(vertices, faces)], []
    if depth == 0:
        parts = vertex_components(mesh)
        if 1 < len(parts) <= MAX_COMPONENTS:
            hulls, rest = [], []
            for part in parts:
                h, r = _sort_element(part, geo, depth=1)
                hulls += h
                rest += r
            return hulls, rest
    return [], [mesh]


def object_collision_shapes(asset: ArticulatedAsset, options: ConvertOptions | None = None,
                            cache: Path | None = None, report: CollisionReport | None = None,
                            progress: bool = False, size: float | None = None) -> dict[str, list[CollisionShape]]:
    """Convex collision shapes of every link, in link frames (links without geometry get none).

    :param asset: the object
    :param options: conversion options (tolerances, CoACD parameters, budget)
    :param cache: CoACD cache folder (None: no cache)
    :param report: filled with counts per method and CoACD statistics
    :param progress: show progress of the CoACD calls
    :param size: :func:`object_size` of ``asset`` when the caller has it (it merges every link's meshes)
    """
    options = options or ConvertOptions()
    report = report if report is not None else CollisionReport()
    size = _object_size(asset) if size is None else size
    thickness = options.min_thickness * size

    shapes: dict[str, list[CollisionShape]] = {}
    geometry: dict[str, _LinkGeometry] = {}
    pending: list[_Pending] = []
    keys: dict[str, str] = {}
    for link in asset.links.values():
        ready, meshes = _element_meshes(link, options)
        shapes[link.name] = ready
        if not meshes:
            continue
        if cache is not None and options.use_cache:
            keys[link.name] = link_key(meshes, ready, options, size)
            cached = load_shapes(cache, keys[link.name], size)
            if cached is not None:
                shapes[link.name] = cached
                report.cached_links += 1
                continue
        points = np.concatenate([m.vertices for m in meshes])
        link_diag = float(np.linalg.norm(np.ptp(points, axis=0)))
        tolerance = options.convex_tolerance * link_diag
        geo = geometry[link.name] = _LinkGeometry(
            tolerance, thickness, max(tolerance / 3.0, 1e-4 * size), options.max_hull_vertices,
            0.5 * (points.min(0) + points.max(0)), link_diag)
        for mesh in meshes:
            welded = simplify(weld(mesh, 1e-7 * size), options.max_part_faces)
            if len(welded.faces) == 0:
                continue
            hulls, rest = _sort_element(welded, geo)
            shapes[link.name] += [CollisionShape("mesh", "hull", vertices=v, faces=f) for v, f in hulls]
            pending += [_Pending(link.name, part) for part in rest]
    boxed_before = len(report.coacd.boxed)  # a report may be shared: this call's boxed indices come after
    decomposed = decompose_many([(p.mesh.vertices, p.mesh.faces) for p in pending], options.coacd,
                                cache=cache if options.use_cache else None, workers=options.workers,
                                stats=report.coacd, progress=progress, exact_boxes=options.exact_boxes)
    report.coacd_failures += [f"{pending[index].link}: {why} (convex hull used instead)"
                              for index, why in sorted(report.coacd.failed.items())]
    boxed = set(report.coacd.boxed[boxed_before:])
    for index, (item, hulls) in enumerate(zip(pending, decomposed)):
        method = "boxes" if index in boxed else "coacd"
        for v, _ in hulls:
            if len(v) >= 4:
                hv, hf = geometry[item.link].hull(v)
                shapes[item.link].append(CollisionShape("mesh", method, vertices=hv, faces=hf))
    erosion = 0.5 * options.clearance * size
    for name, link_shapes in shapes.items():
        if name in geometry:  # computed now (not cached, not only given shapes)
            budget = link_budget(options.hull_budget, geometry[name].diagonal, size)
            merged = merge_to_budget(link_shapes, budget, thickness, options.max_hull_vertices)
            report.merged += len(link_shapes) - len(merged)
            link_shapes = [_eroded(s, erosion) for s in merged]
            if name in keys and not report.coacd.failed:
                store_shapes(cache, keys[name], link_shapes, size)
            # used as the cache gives them back, stored or not: a first and a later run build the same model
            link_shapes = shapes[name] = as_cached(link_shapes, size)
        report.hulls[name] = len(link_shapes)
        for shape in link_shapes:
            report.methods[shape.method] = report.methods.get(shape.method, 0) + 1
    return shapes


def link_budget(budget: int, link_diagonal: float, object_size: float) -> int:
    """Hull budget of a link: ``budget`` for a link as large as the object, shrinking with the square
    root of its relative size (a 2 cm button of a 2 m object gets a fifth), at least 4."""
    return max(4, int(round(budget * np.sqrt(min(1.0, link_diagonal / max(object_size, 1e-9))))))


def _eroded(shape: CollisionShape, depth: float) -> CollisionShape:
    """Our own hulls shrink by ``depth`` (half the clearance); given primitives and convex meshes stay."""
    if shape.kind != "mesh" or shape.method in ("convex", "primitive") or depth <= 0:
        return shape
    mesh = trimesh.convex.convex_hull(erode_hull(shape.vertices, depth))
    return CollisionShape("mesh", shape.method, vertices=np.asarray(mesh.vertices, float),
                          faces=np.asarray(mesh.faces, np.int64))


def _object_size(asset: ArticulatedAsset) -> float:
    """The object's bounding-box diagonal at rest (from visuals, else collisions), at least 1 mm."""
    try:
        lo, hi = asset.bounds()
        return max(float(np.linalg.norm(hi - lo)), 1e-3)
    except ValueError:
        points = []
        poses = asset.link_poses()
        for link in asset.links.values():
            for col in link.collisions:
                mesh = col.to_trimesh() if (col.kind != "mesh" or col.mesh is not None) else None
                if mesh is not None:
                    points.append(trimesh.transform_points(mesh.vertices, poses[link.name]))
        if not points:
            return 1.0
        pts = np.concatenate(points)
        return max(float(np.linalg.norm(np.ptp(pts, axis=0))), 1e-3)


def object_size(asset: ArticulatedAsset) -> float:
    """Public alias of the size every relative tolerance refers to (bounding-box diagonal at rest)."""
    return _object_size(asset)


# ----- hull budget --------------------------------------------------------------------------------
def merge_to_budget(shapes: list[CollisionShape], budget: int, thickness: float,
                    max_vertices: int, neighbours: int = 6) -> list[CollisionShape]:
    """Merge mesh hulls pairwise (the pair whose joint hull adds the least volume, among each hull's
    nearest ``neighbours``) until at most ``budget`` shapes remain; primitives are never merged."""
    if budget <= 0 or len(shapes) <= budget:
        return shapes
    fixed = [s for s in shapes if s.kind != "mesh"]
    hulls = [(s.vertices, s.method) for s in shapes if s.kind == "mesh"]
    volumes = [ConvexHull(v).volume for v, _ in hulls]
    alive = set(range(len(hulls)))

    def cost(i: int, j: int) -> float:
        return ConvexHull(np.concatenate([hulls[i][0], hulls[j][0]])).volume - volumes[i] - volumes[j]

    def candidates(i: int) -> list[tuple[float, int, int]]:
        others = [j for j in alive if j != i]
        if not others:
            return []
        centers = np.array([hulls[j][0].mean(0) for j in others])
        near = np.argsort(np.linalg.norm(centers - hulls[i][0].mean(0), axis=1))[:neighbours]
        return [(cost(i, others[k]), min(i, others[k]), max(i, others[k])) for k in near]

    import heapq

    heap = [c for i in alive for c in candidates(i)]
    heapq.heapify(heap)
    while len(alive) + len(fixed) > budget and heap:
        _, i, j = heapq.heappop(heap)
        if i not in alive or j not in alive:
            continue
        vertices, _ = convex_hull(np.concatenate([hulls[i][0], hulls[j][0]]), thickness, max_vertices)
        hulls.append((vertices, "merged"))
        volumes.append(ConvexHull(vertices).volume)
        alive -= {i, j}
        new = len(hulls) - 1
        alive.add(new)
        for c in candidates(new):
            heapq.heappush(heap, c)
    out = list(fixed)
    for index in sorted(alive):
        vertices, method = hulls[index]
        hv, hf = convex_hull(vertices, thickness, max_vertices)
        out.append(CollisionShape("mesh", method, vertices=hv, faces=hf))
    return out
