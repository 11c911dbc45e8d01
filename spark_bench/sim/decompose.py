"""CoACD convex decomposition with a content-hash cache and a process pool.

A decomposition is keyed by the SHA-256 of the mesh (vertices relative to their bounding-box center,
rounded to a nanometre, and faces) and of every CoACD parameter, so the same part decomposes once:
on a second conversion, and for identical parts at different places (the four handles of a cabinet).
Results are stored as ``<cache>/coacd/<key[:2]>/<key>.npz`` and written atomically, so concurrent
conversions share one cache safely.

CoACD is single-threaded per call; independent calls run in worker processes
(:mod:`spark_bench.sim.coacd_worker`, started as scripts), largest mesh first, dealt round-robin. A
worker crash (CoACD segfaults on some degenerate inputs) costs only its own meshes, which then fall
back to their convex hull (``DecomposeStats.failed``).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from spark_bench.sim.options import CoacdParams

#: Bumped whenever the stored result of the same input would change.
CACHE_VERSION = "coacd-cache-1"

Hull = tuple[np.ndarray, np.ndarray]  # (vertices (V, 3) float64, faces (F, 3) int64)


@dataclass
class DecomposeStats:
    """What :func:`decompose_many` did: calls run, cache hits, CPU seconds spent in CoACD."""

    calls: int = 0
    cache_hits: int = 0
    coacd_cpu_s: float = 0.0
    failed: list[int] = field(default_factory=list)


def mesh_key(vertices: np.ndarray, faces: np.ndarray, params: CoacdParams) -> str:
    """The cache key of decomposing ``(vertices, faces)`` with ``params`` (translation invariant)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    center = 0.5 * (vertices.min(0) + vertices.max(0)) if len(vertices) else np.zeros(3)
    rounded = np.round((vertices - center) * 1e9).astype(np.int64)
    digest = hashlib.sha256()
    digest.update(CACHE_VERSION.encode())
    digest.update(json.dumps(asdict(params), sort_keys=True).encode())
    digest.update(rounded.tobytes())
    digest.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    return digest.hexdigest()


def _cache_path(key: str, cache: Path) -> Path:
    return cache / key[:2] / f"{key}.npz"


def load_cached(key: str, cache: Path) -> list[Hull] | None:
    """Hulls stored under ``key`` (centered), or None when absent or unreadable."""
    path = _cache_path(key, cache)
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            vertices, faces = data["vertices"], data["faces"]
            nv, nf = data["n_vertices"], data["n_faces"]
    except (OSError, ValueError, KeyError):
        return None  # a torn or foreign file: recompute and overwrite
    hulls, v0, f0 = [], 0, 0
    for a, b in zip(nv, nf):
        hulls.append((vertices[v0:v0 + a].copy(), faces[f0:f0 + b].copy()))
        v0, f0 = v0 + a, f0 + b
    return hulls


def atomic_savez(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez`` to a temporary file beside ``path``, then rename: readers never see half a file."""
    fd, tmp = tempfile.mkstemp(dir=Path(path).parent, suffix=".tmp.npz")
    os.close(fd)
    try:
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def store_cached(key: str, cache: Path, hulls: Sequence[Hull]) -> None:
    """Write ``hulls`` under ``key``, atomically (write a temporary file, then rename)."""
    path = _cache_path(key, cache)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(
        vertices=np.concatenate([h[0] for h in hulls]) if hulls else np.zeros((0, 3)),
        faces=np.concatenate([h[1] for h in hulls]).astype(np.int64) if hulls else np.zeros((0, 3), np.int64),
        n_vertices=np.array([len(h[0]) for h in hulls], dtype=np.int64),
        n_faces=np.array([len(h[1]) for h in hulls], dtype=np.int64),
    )
    atomic_savez(path, arrays)


def _hull_of(points: np.ndarray) -> Hull:
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points, qhull_options="QJ")
    return points[hull.vertices], np.zeros((0, 3), np.int64)


def _center(vertices: np.ndarray) -> np.ndarray:
    return 0.5 * (vertices.min(0) + vertices.max(0))


def decompose_many(meshes: Sequence[Hull], params: CoacdParams, cache: Path | None = None,
                   workers: int = 0, stats: DecomposeStats | None = None,
                   progress: bool = False) -> list[list[Hull]]:
    """Decompose each mesh into convex hulls with CoACD, reusing and filling the cache.

    :param meshes: ``(vertices, faces)`` per mesh, each a closed (watertight) or open triangle mesh
    :param params: CoACD parameters (part of the cache key)
    :param cache: cache folder; None disables caching
    :param workers: worker processes (0: one per CPU core)
    :param stats: filled with the number of calls, cache hits and CoACD CPU seconds
    :param progress: show a progress bar for the calls that run
    :returns: per mesh, its hulls as ``(vertices, faces)`` in the mesh's own coordinates
    """
    stats = stats if stats is not None else DecomposeStats()
    results: list[list[Hull] | None] = [None] * len(meshes)
    centers = [_center(np.asarray(v, dtype=np.float64)) for v, _ in meshes]
    todo: dict[str, list[int]] = {}
    for index, (vertices, faces) in enumerate(meshes):
        key = mesh_key(vertices, faces, params)
        cached = load_cached(key, cache) if cache is not None else None
        if cached is not None:
            stats.cache_hits += 1
            results[index] = [(v + centers[index], f) for v, f in cached]
        else:
            todo.setdefault(key, []).append(index)  # identical parts decompose once
    jobs = sorted(todo.items(), key=lambda item: -len(meshes[item[1][0]][1]))
    outputs = _run_jobs([(np.asarray(meshes[idx[0]][0], float) - centers[idx[0]], meshes[idx[0]][1])
                         for _, idx in jobs], params, workers, progress)
    for (key, indices), output in zip(jobs, outputs):
        stats.calls += 1
        if output is None:  # the worker died on this mesh: its convex hull stands in, uncached
            stats.failed += indices
            hulls = [_hull_of(np.asarray(meshes[indices[0]][0], float) - centers[indices[0]])]
        else:
            hulls, cpu = output
            stats.coacd_cpu_s += cpu
            if cache is not None:
                store_cached(key, cache, hulls)
        for index in indices:
            results[index] = [(v + centers[index], f) for v, f in hulls]
    return [r if r is not None else [] for r in results]


def _read_result(path: Path) -> tuple[list[Hull], float] | None:
    if not path.is_file():
        return None
    with np.load(path) as data:
        vertices, faces, cpu = data["vertices"], data["faces"], float(data["cpu"])
        nv, nf = data["n_vertices"], data["n_faces"]
    hulls, v0, f0 = [], 0, 0
    for a, b in zip(nv, nf):
        hulls.append((vertices[v0:v0 + a].copy(), faces[f0:f0 + b].copy()))
        v0, f0 = v0 + a, f0 + b
    return hulls, cpu


def _run_jobs(jobs: list[Hull], params: CoacdParams, workers: int, progress: bool
              ) -> list[tuple[list[Hull], float] | None]:
    """Run CoACD on ``jobs`` in ``workers`` worker processes (largest first, round-robin, so each
    worker gets a similar share); a job whose worker crashed gives None."""
    if not jobs:
        return []
    n_workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    script = str(Path(__file__).with_name("coacd_worker.py"))
    with tempfile.TemporaryDirectory(prefix="spark_coacd_") as tmp:
        paths = []
        for index, (vertices, faces) in enumerate(jobs):
            path = Path(tmp) / f"job_{index:05d}.npz"
            np.savez(path, vertices=np.asarray(vertices, np.float64), faces=np.asarray(faces, np.int64))
            paths.append(path)
        queue = [paths[k::n_workers] for k in range(n_workers)]
        running: list[tuple[subprocess.Popen, list[Path]]] = []
        bar = _progress(len(jobs), progress)
        done = 0
        while queue or running:
            while queue and len(running) < n_workers:
                batch = queue.pop(0)
                command = [sys.executable, script, json.dumps(params.as_kwargs())] + [str(p) for p in batch]
                running.append((subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL),
                                batch))
            time.sleep(0.02)
            for proc, batch in list(running):
                if proc.poll() is None:
                    continue
                running.remove((proc, batch))
                missing = [p for p in batch if not p.with_suffix(".out.npz").is_file()]
                if len(missing) > 1:  # the first missing mesh crashed the worker: skip it, redo the rest
                    queue.append(missing[1:])
            finished = sum(1 for p in paths if p.with_suffix(".out.npz").is_file())
            if finished > done:
                bar.update(finished - done)
                done = finished
        bar.close()
        return [_read_result(p.with_suffix(".out.npz")) for p in paths]


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="CoACD", unit="part", disable=not enabled, leave=False)
