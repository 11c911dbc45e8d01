"""Surface crossings: does a part, carried along its joint's path, pass through another part's surface?

Points sampled on the moving part's own surface (:func:`inset_samples`) are carried step by step; each step is a
segment, cast as a ray against the other part's triangles (MuJoCo's ``mj_ray`` on a mesh geom:
:func:`surface_model`). A point *crosses* where a segment meets a surface head-on; a surface the segment runs along
(within :data:`GRAZING_COS` of its plane: a drawer's side sliding along its runner) is looked past. A point that
meets a surface before it has travelled ``start_tolerance`` met a surface it rests against (a door on its frame),
which a part leaving the right way meets too: that does not count. PartNet-Mobility meshes are triangle soups, so
what is counted is surfaces crossed, not depth inside a solid.

Plain functions on arrays; the converter asks whether a part's own path is free of its parent
(:mod:`spark_bench.sim.phantom`), the check-validity benchmark whether a broken twin is a clean break.
"""

from __future__ import annotations

import numpy as np
import trimesh

from spark_bench.asset.mesh import sample_surface
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.bounds import model_bounds

#: A surface met at a smaller cosine between the segment and the surface's normal is run along, not crossed.
GRAZING_COS = 0.05
#: Recasts past surfaces run along, per segment.
MAX_GRAZES = 4


def surface_model(meshes: list[tuple[np.ndarray, np.ndarray]]):
    """``(model, data)``: a MuJoCo model holding the triangle meshes ``(vertices, faces)`` as static, non-colliding
    geoms in their own frame, ready for ray casts (:func:`first_crossing`)."""
    mujoco = mujoco_module()
    spec = mujoco.MjSpec()
    for index, (vertices, faces) in enumerate(meshes):
        mesh = spec.add_mesh(name=f"surface_{index}")
        mesh.uservert = np.asarray(vertices, np.float64).ravel().tolist()
        mesh.userface = np.asarray(faces, np.int32).ravel().tolist()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"surface_{index}", contype=0,
                                conaffinity=0)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def inset_samples(mesh: trimesh.Trimesh, count: int, inset: float, seed: int = 0) -> np.ndarray:
    """``count`` points on ``mesh``'s surface, each moved ``inset`` along its triangle's normal towards the mesh's
    centroid: off a plane the part rests on, so that a point sliding along its neighbour's coplanar face does not
    run along the edges of that neighbour's other faces."""
    points = sample_surface(mesh, count, seed)
    _, _, triangle = mesh.nearest.on_surface(points)
    normals = np.asarray(mesh.face_normals, float)[triangle]
    inward = np.sign(np.einsum("ij,ij->i", normals, mesh.vertices.mean(axis=0) - points))
    return points + (inset * np.where(inward == 0, 1.0, inward))[:, None] * normals


def first_crossing(model, data, start: np.ndarray, step: np.ndarray) -> float:
    """Where along the segment ``start`` -> ``start + step`` (0..1) it first crosses a surface of ``model``; -1 for
    none (surfaces run along are looked past)."""
    mujoco = mujoco_module()
    geom = np.array([-1], np.int32)
    normal = np.zeros(3)
    offset = 0.0
    for _ in range(MAX_GRAZES):
        hit = mujoco.mj_ray(model, data, start + offset * step, (1.0 - offset) * step, None, 1, -1, geom, normal)
        if not 0.0 <= hit <= 1.0:
            return -1.0
        at = offset + hit * (1.0 - offset)
        if abs(float(normal @ step)) >= GRAZING_COS * float(np.linalg.norm(step)):
            return at
        offset = at + 1e-6  # runs along that surface: look past it
    return -1.0


def crossing_steps(model, data, path: np.ndarray, start_tolerance: float, stop_after: int | None = None) -> np.ndarray:
    """Per point, the first step at whose end it has crossed a surface of ``model`` after travelling more than
    ``start_tolerance`` (-1: never).

    :param path: ``(steps, points, 3)`` positions of the points at each step, in ``model``'s frame
    :param stop_after: stop once this many points have crossed (the later steps are not cast: -1 there)
    """
    lower, upper = model_bounds(model, data)
    margin = 1e-6 * (1.0 + float(np.max(upper - lower)))
    travelled = np.zeros(path.shape[1])
    crossed = np.full(path.shape[1], -1)
    for k in range(1, len(path)):
        step = path[k] - path[k - 1]
        length = np.linalg.norm(step, axis=1)
        # a segment whose box misses the surfaces' box cannot cross them: no ray cast for it
        reaches = ((np.maximum(path[k - 1], path[k]) >= lower - margin)
                   & (np.minimum(path[k - 1], path[k]) <= upper + margin)).all(axis=1)
        for p in np.flatnonzero((crossed < 0) & (length > 0) & reaches):
            hit = first_crossing(model, data, path[k - 1, p], step[p])
            if hit >= 0.0 and travelled[p] + hit * length[p] > start_tolerance:
                crossed[p] = k
        travelled += length
        if stop_after is not None and np.count_nonzero(crossed >= 0) >= stop_after:
            break
    return crossed
