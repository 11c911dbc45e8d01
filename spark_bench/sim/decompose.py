"""Convex decomposition: orthogonal parts exactly into boxes, the rest by CoACD with a content-hash cache
and a process pool.

A part whose faces all lie on the planes of its own frame (:func:`flat_frame`) is decomposed exactly into
boxes (:mod:`spark_bench.sim.boxes`) and never reaches CoACD or the cache.

A decomposition is keyed by the SHA-256 of the mesh (vertices relative to their bounding-box center
and in units of its largest extent, rounded to 1e-9, and faces) and of every CoACD parameter, so the
same part decomposes once: on a second conversion, for identical parts at different places (the four
handles of a cabinet), and for the same part at another scale (a benchmark case's ground truth in the
benchmark frame, which the sim checks convert, and in metres, which the opener converts). CoACD runs
on the normalized mesh (:func:`normalized`), so a key's hulls, placed back by each mesh's own frame,
do not depend on which copy was decomposed first (``tests/sim/test_scale_cache.py``). A flat-faced
mesh turned away from the coordinate planes is turned into the frame of its own planes first
(:func:`flat_frame`), as CoACD cuts along the coordinate planes only. Results
are stored normalized as ``<cache>/coacd/<key[:2]>/<key>.npz`` and written atomically, so concurrent
conversions share one cache safely.

CoACD parallelizes its search inside a call with OpenMP; its hulls did not depend on the thread count where
measured (one non-convex test mesh, a ring beside a bar, threshold 0.05: the same hulls on 1, 2, 4, 8 and 16
threads). Independent calls run in worker processes
(:mod:`spark_bench.sim.coacd_worker`, started as scripts), largest mesh first, dealt round-robin. A
worker crash (CoACD segfaults or aborts on some degenerate inputs) or a call that runs over
:data:`JOB_TIMEOUT_S` costs only its own mesh, which then falls back to its convex hull;
``DecomposeStats.failed`` says which and why.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from spark_bench.sim.boxes import box_decomposition
from spark_bench.sim.file_cache import atomic_savez, entry_path, load_npz
from spark_bench.sim.options import CoacdParams

#: Bumped whenever the stored result of the same input would change.
CACHE_VERSION = "coacd-cache-3"
#: A CoACD call still running after this many seconds is taken as hung: its worker is killed and the
#: mesh gets its convex hull. A safety bound, far above the calls of ``benchmarks/measure_convert.py``.
JOB_TIMEOUT_S = 600.0

Hull = tuple[np.ndarray, np.ndarray]  # (vertices (V, 3) float64, faces (F, 3) int64)


@dataclass
class DecomposeStats:
    """What :func:`decompose_many` did: calls run, cache hits, CPU seconds spent in CoACD, and the
    meshes CoACD failed on (index in the input -> why: the worker's signal or exit status and the last
    line it printed, or the time limit), which got their convex hull instead; how many meshes were
    decomposed turned into their own planes' frame (:func:`flat_frame`); and which meshes (indices) were
    orthogonal polyhedra, decomposed exactly into boxes without CoACD (:mod:`spark_bench.sim.boxes`)."""

    calls: int = 0
    cache_hits: int = 0
    coacd_cpu_s: float = 0.0
    failed: dict[int, str] = field(default_factory=dict)
    turned: int = 0
    boxed: list[int] = field(default_factory=list)


def mesh_key(vertices: np.ndarray, faces: np.ndarray, params: CoacdParams) -> str:
    """The cache key of decomposing ``(vertices, faces)`` with ``params`` (invariant to translation and
    scale: see :func:`_frame`)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    center, extent = _frame(vertices)
    rounded = np.round((vertices - center) / extent * 1e9).astype(np.int64)
    digest = hashlib.sha256()
    digest.update(CACHE_VERSION.encode())
    digest.update(json.dumps(asdict(params), sort_keys=True).encode())
    digest.update(rounded.tobytes())
    digest.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    return digest.hexdigest()


def pack_hulls(hulls: Sequence[Hull]) -> dict[str, np.ndarray]:
    """Hulls as four arrays: all vertices, all faces, and the vertex and face count of each hull
    (the layout of cache entries and of :mod:`.coacd_worker` outputs)."""
    return dict(
        vertices=np.concatenate([h[0] for h in hulls]) if hulls else np.zeros((0, 3)),
        faces=np.concatenate([h[1] for h in hulls]).astype(np.int64) if hulls else np.zeros((0, 3), np.int64),
        n_vertices=np.array([len(h[0]) for h in hulls], dtype=np.int64),
        n_faces=np.array([len(h[1]) for h in hulls], dtype=np.int64),
    )


def unpack_hulls(data) -> list[Hull]:
    """The hulls of :func:`pack_hulls` arrays (copies: ``data`` may be an open ``.npz``)."""
    vertices, faces = data["vertices"], data["faces"]
    hulls, v0, f0 = [], 0, 0
    for a, b in zip(data["n_vertices"], data["n_faces"]):
        hulls.append((vertices[v0:v0 + a].copy(), faces[f0:f0 + b].copy()))
        v0, f0 = v0 + a, f0 + b
    return hulls


def load_cached(key: str, cache: Path) -> list[Hull] | None:
    """Hulls stored under ``key`` (normalized: :func:`_frame`), or None when absent or unreadable."""
    return load_npz(entry_path(cache, key), unpack_hulls)


def store_cached(key: str, cache: Path, hulls: Sequence[Hull]) -> None:
    """Write ``hulls`` under ``key``, atomically (write a temporary file, then rename)."""
    atomic_savez(entry_path(cache, key), pack_hulls(hulls))


def _hull_of(points: np.ndarray) -> Hull:
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points, qhull_options="QJ")
    return points[hull.vertices], np.zeros((0, 3), np.int64)


def _frame(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """``(center, extent)``: the bounding box's center and largest side (1 for a point or no vertex);
    a mesh is keyed and its hulls stored as ``(vertices - center) / extent``."""
    if not len(vertices):
        return np.zeros(3), 1.0
    lo, hi = vertices.min(0), vertices.max(0)
    extent = float(np.max(hi - lo))
    return 0.5 * (lo + hi), extent if extent > 0 else 1.0


#: Normalized coordinates are rounded to this grid (about 1e-9 of the part's size).
GRID = 2.0 ** -30


def normalized(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(unit, center, extent)``: ``vertices`` centered on their box, divided by its largest side
    (:func:`_frame`) and rounded to :data:`GRID`, so that a scaled or moved copy of a mesh gives the
    same numbers bit for bit (float noise aside exactly at a grid boundary), and what CoACD or a
    decimation makes of them is the same."""
    center, extent = _frame(vertices)
    return np.round((vertices - center) / extent / GRID) * GRID, center, extent


#: Faces whose normals are within this angle of a frame axis lie on that axis's planes.
FLAT_TOLERANCE_DEG = 3.0
#: :func:`flat_frame` turns a mesh whose faces lie on three orthogonal plane families covering at least
#: this share of its area...
FLAT_MIN_SHARE = 0.7
#: ... and at least this much more of it than the coordinate planes do (faces within
#: :data:`ALIGNED_DEG` of them), when turned more than :data:`ALIGNED_DEG` from them.
FLAT_GAIN = 0.1
ALIGNED_DEG = 1.0


def _plane_share(normals: np.ndarray, area: np.ndarray, axes: np.ndarray, degrees: float) -> float:
    """The share of the area whose face normals are within ``degrees`` of one of ``axes`` (rows)."""
    near = np.max(np.abs(normals @ axes.T), axis=1) > np.cos(np.radians(degrees))
    return float(area[near].sum() / area.sum())


def flat_frame(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray | None:
    """The rotation ``R`` (rows: the new axes) that makes a mostly flat-faced mesh axis-aligned, or None.

    CoACD cuts only along the coordinate planes (and its ``pca`` option turns by the covariance of the
    vertices, which is arbitrary for a cube-like part or an unevenly meshed one). A box-like part turned
    in its own file (a predicted cabinet carcass 7 degrees off the vertical: 74 faces) then gets cut
    into ever thinner slivers: CoACD ran past 600 s on it, and took 1 s once turned back. The frame is
    that of the part's own planes: the normal direction carrying the most face area, the one
    orthogonal to it carrying the most, and their cross product (each the area-weighted mean of the
    normals within :data:`FLAT_TOLERANCE_DEG` of it). It is used only where these three plane families
    carry at least :data:`FLAT_MIN_SHARE` of the area (curved and free-form parts keep their frame) and
    :data:`FLAT_GAIN` more than the coordinate planes, turned more than :data:`ALIGNED_DEG` (an
    axis-aligned part decomposes exactly as before; so does one whose planes are as well served by the
    axes, such as an octagonal prism).
    Rows are ordered and signed to stay close to the identity.

    :param vertices: ``(V, 3)`` mesh vertices
    :param faces: ``(F, 3)`` triangle indices
    :returns: a ``(3, 3)`` rotation (apply as ``vertices @ R.T``; undo as ``@ R``), or None
    """
    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    if len(f) < 4 or f.ndim != 2 or f.shape[1] != 3 or f.min() < 0 or f.max() >= len(v) \
            or not np.all(np.isfinite(v)):
        return None  # not a mesh to judge: CoACD gets it as it is (and its worker's failure says why)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(cross, axis=1)
    keep = area > 1e-12 * area.max() if area.max() > 0 else np.zeros(len(area), bool)
    if not keep.any():
        return None
    normals, area = cross[keep] / area[keep, None], area[keep]
    cos_tol = np.cos(np.radians(FLAT_TOLERANCE_DEG))
    largest = np.lexsort((np.arange(len(area)), -area))[:64]  # candidate directions: the largest faces'

    def family(candidates: np.ndarray) -> np.ndarray | None:  # the candidate carrying the most area, refined
        if not len(candidates):
            return None
        carried = [area[np.abs(normals @ normals[i]) > cos_tol].sum() for i in candidates]
        axis = normals[candidates[int(np.argmax(carried))]]
        near = np.abs(normals @ axis) > cos_tol
        mean = (area[near, None] * normals[near] * np.sign(normals[near] @ axis)[:, None]).sum(0)
        return mean / np.linalg.norm(mean)

    first = family(largest)
    second = family(largest[np.abs(normals[largest] @ first) < np.sin(np.radians(FLAT_TOLERANCE_DEG))])
    if second is None:
        return None
    second = second - (second @ first) * first
    axes = np.stack([first, second / np.linalg.norm(second), np.zeros(3)])
    axes[2] = np.cross(axes[0], axes[1])
    share = _plane_share(normals, area, axes, FLAT_TOLERANCE_DEG)
    if share < FLAT_MIN_SHARE or share < _plane_share(normals, area, np.eye(3), ALIGNED_DEG) + FLAT_GAIN:
        return None
    nearest = np.argmax(np.abs(axes), axis=0)  # the axis closest to x, y, z: keep the turn small
    if len(set(nearest.tolist())) == 3:
        axes = axes[nearest]
        axes *= np.where(np.diag(axes) < 0, -1.0, 1.0)[:, None]
    if np.linalg.det(axes) < 0:
        axes[2] *= -1.0
    turn = np.degrees(np.arccos(np.clip((np.trace(axes) - 1.0) / 2.0, -1.0, 1.0)))
    return axes if turn > ALIGNED_DEG else None  # the axes already are the part's planes


def decompose_many(meshes: Sequence[Hull], params: CoacdParams, cache: Path | None = None,
                   workers: int = 0, stats: DecomposeStats | None = None,
                   progress: bool = False, timeout: float = JOB_TIMEOUT_S, exact_boxes: bool = True
                   ) -> list[list[Hull]]:
    """Decompose each mesh into convex hulls: an orthogonal polyhedron exactly into boxes
    (:func:`~spark_bench.sim.boxes.box_decomposition`), any other mesh with CoACD, reusing and filling the
    cache.

    :param meshes: ``(vertices, faces)`` per mesh, each a closed (watertight) or open triangle mesh
    :param params: CoACD parameters (part of the cache key)
    :param cache: cache folder; None disables caching
    :param workers: worker processes (0: one per CPU core)
    :param stats: filled with the number of calls, cache hits and CoACD CPU seconds
    :param progress: show a progress bar for the calls that run
    :param timeout: seconds one CoACD call may take before its worker is killed as hung
    :param exact_boxes: cut orthogonal polyhedra into boxes (False: every mesh goes to CoACD)
    :returns: per mesh, its hulls as ``(vertices, faces)`` in the mesh's own coordinates
    """
    stats = stats if stats is not None else DecomposeStats()
    results: list[list[Hull] | None] = [None] * len(meshes)
    turns = [flat_frame(v, f) for v, f in meshes]
    stats.turned += sum(turn is not None for turn in turns)
    meshes = [(np.asarray(v, np.float64) if turn is None else np.asarray(v, np.float64) @ turn.T, f)
              for (v, f), turn in zip(meshes, turns)]  # CoACD sees each mesh in its own planes' frame
    units = [normalized(v) for v, _ in meshes]  # what the boxes and CoACD see: each mesh normalized once
    frames = [(center, extent) for _, center, extent in units]

    def placed(index: int, hulls: list[Hull]) -> list[Hull]:  # normalized hulls -> the mesh's coordinates
        center, extent = frames[index]
        turn = turns[index]
        return [(v * extent + center if turn is None else (v * extent + center) @ turn, f) for v, f in hulls]

    todo: dict[str, list[int]] = {}
    for index, (vertices, faces) in enumerate(meshes):
        boxes = box_decomposition(units[index][0], faces) if exact_boxes else None
        if boxes is not None:  # exact, and cheaper than reading a cache entry
            stats.boxed.append(index)
            results[index] = placed(index, boxes)
            continue
        key = mesh_key(vertices, faces, params)
        cached = load_cached(key, cache) if cache is not None else None
        if cached is not None:
            stats.cache_hits += 1
            results[index] = placed(index, cached)
        else:
            todo.setdefault(key, []).append(index)  # identical parts decompose once
    jobs = sorted(todo.items(), key=lambda item: -len(meshes[item[1][0]][1]))
    outputs, errors = _run_jobs([(units[idx[0]][0], meshes[idx[0]][1])
                                 for _, idx in jobs], params, workers, progress, timeout)
    for job, ((key, indices), output) in enumerate(zip(jobs, outputs)):
        stats.calls += 1
        if output is None:  # the worker died on this mesh: its convex hull stands in, uncached
            stats.failed.update({index: errors.get(job, "CoACD wrote no result") for index in indices})
            center, extent = frames[indices[0]]
            hulls = [_hull_of((np.asarray(meshes[indices[0]][0], float) - center) / extent)]
        else:
            hulls, cpu = output
            stats.coacd_cpu_s += cpu
            if cache is not None:
                store_cached(key, cache, hulls)
        for index in indices:
            results[index] = placed(index, hulls)
    return [r if r is not None else [] for r in results]


def _read_result(path: Path) -> tuple[list[Hull], float] | None:
    return load_npz(path, lambda data: (unpack_hulls(data), float(data["cpu"])))


@dataclass
class _Worker:
    """A running worker process, its batch, and when it last finished a mesh (or started)."""

    proc: subprocess.Popen
    batch: list[Path]
    stderr: Path
    since: float
    finished: int = 0

    def outputs(self) -> int:
        return sum(1 for p in self.batch if p.with_suffix(".out.npz").is_file())


def _why_failed(worker: _Worker, timeout: float | None) -> str:
    """One line: how the worker ended, and the last line it printed (CoACD's assertion, say)."""
    if timeout is not None:
        return f"CoACD ran over {timeout:g} s (taken as hung; worker killed)"
    code = worker.proc.returncode
    try:
        how = f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit status {code}"
    except ValueError:
        how = f"exit status {code}"
    lines = [line.strip() for line in worker.stderr.read_text(errors="replace").splitlines() if line.strip()]
    return f"CoACD worker {how}" + (f": {lines[-1][:200]}" if lines else "")


def _run_jobs(jobs: list[Hull], params: CoacdParams, workers: int, progress: bool, timeout: float = JOB_TIMEOUT_S
              ) -> tuple[list[tuple[list[Hull], float] | None], dict[int, str]]:
    """Run CoACD on ``jobs`` in ``workers`` worker processes (largest first, round-robin, so each
    worker gets a similar share). Returns per job its hulls and CPU seconds, or None when its worker
    crashed on it or it ran over ``timeout`` seconds; and for those jobs, why (job index -> line)."""
    if not jobs:
        return [], {}
    n_workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    script = str(Path(__file__).with_name("coacd_worker.py"))
    errors: dict[int, str] = {}
    with tempfile.TemporaryDirectory(prefix="spark_coacd_") as tmp:
        paths = []
        for index, (vertices, faces) in enumerate(jobs):
            path = Path(tmp) / f"job_{index:05d}.npz"
            np.savez(path, vertices=np.asarray(vertices, np.float64), faces=np.asarray(faces, np.int64))
            paths.append(path)
        queue = [paths[k::n_workers] for k in range(n_workers)]
        running: list[_Worker] = []
        bar = _progress(len(jobs), progress)
        done = launched = 0
        while queue or running:
            while queue and len(running) < n_workers:
                batch = queue.pop(0)
                command = [sys.executable, script, json.dumps(params.as_kwargs())] + [str(p) for p in batch]
                stderr = Path(tmp) / f"worker_{launched:05d}.err"
                launched += 1
                with open(stderr, "wb") as err:
                    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=err)
                running.append(_Worker(proc, batch, stderr, time.monotonic()))
            time.sleep(0.02)
            for worker in list(running):
                now, finished = time.monotonic(), worker.outputs()
                if finished > worker.finished:
                    worker.finished, worker.since = finished, now
                hung = worker.proc.poll() is None and now - worker.since > timeout
                if hung:
                    worker.proc.kill()
                    worker.proc.wait()
                elif worker.proc.poll() is None:
                    continue
                running.remove(worker)
                missing = [p for p in worker.batch if not p.with_suffix(".out.npz").is_file()]
                if missing:  # the first missing mesh crashed (or hung) the worker: skip it, redo the rest
                    errors[paths.index(missing[0])] = _why_failed(worker, timeout if hung else None)
                    if len(missing) > 1:
                        queue.append(missing[1:])
            finished = sum(1 for p in paths if p.with_suffix(".out.npz").is_file())
            if finished > done:
                bar.update(finished - done)
                done = finished
        bar.close()
        return [_read_result(p.with_suffix(".out.npz")) for p in paths], errors


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="CoACD", unit="part", disable=not enabled, leave=False)
