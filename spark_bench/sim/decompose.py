"""CoACD convex decomposition with a content-hash cache and a process pool.

A decomposition is keyed by the SHA-256 of the mesh (vertices relative to their bounding-box center
and in units of its largest extent, rounded to 1e-9, and faces) and of every CoACD parameter, so the
same part decomposes once: on a second conversion, for identical parts at different places (the four
handles of a cabinet), and for the same part at another scale (a benchmark case's ground truth in the
benchmark frame, which the sim checks convert, and in metres, which the opener converts). CoACD runs
on the normalized mesh (:func:`normalized`), so a key's hulls, placed back by each mesh's own frame,
do not depend on which copy was decomposed first (``tests/sim/test_scale_cache.py``). Results
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
    line it printed, or the time limit), which got their convex hull instead."""

    calls: int = 0
    cache_hits: int = 0
    coacd_cpu_s: float = 0.0
    failed: dict[int, str] = field(default_factory=dict)


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


def decompose_many(meshes: Sequence[Hull], params: CoacdParams, cache: Path | None = None,
                   workers: int = 0, stats: DecomposeStats | None = None,
                   progress: bool = False, timeout: float = JOB_TIMEOUT_S) -> list[list[Hull]]:
    """Decompose each mesh into convex hulls with CoACD, reusing and filling the cache.

    :param meshes: ``(vertices, faces)`` per mesh, each a closed (watertight) or open triangle mesh
    :param params: CoACD parameters (part of the cache key)
    :param cache: cache folder; None disables caching
    :param workers: worker processes (0: one per CPU core)
    :param stats: filled with the number of calls, cache hits and CoACD CPU seconds
    :param progress: show a progress bar for the calls that run
    :param timeout: seconds one CoACD call may take before its worker is killed as hung
    :returns: per mesh, its hulls as ``(vertices, faces)`` in the mesh's own coordinates
    """
    stats = stats if stats is not None else DecomposeStats()
    results: list[list[Hull] | None] = [None] * len(meshes)
    frames = [_frame(np.asarray(v, dtype=np.float64)) for v, _ in meshes]

    def placed(index: int, hulls: list[Hull]) -> list[Hull]:  # normalized hulls -> the mesh's coordinates
        center, extent = frames[index]
        return [(v * extent + center, f) for v, f in hulls]

    todo: dict[str, list[int]] = {}
    for index, (vertices, faces) in enumerate(meshes):
        key = mesh_key(vertices, faces, params)
        cached = load_cached(key, cache) if cache is not None else None
        if cached is not None:
            stats.cache_hits += 1
            results[index] = placed(index, cached)
        else:
            todo.setdefault(key, []).append(index)  # identical parts decompose once
    jobs = sorted(todo.items(), key=lambda item: -len(meshes[item[1][0]][1]))
    outputs, errors = _run_jobs([(normalized(np.asarray(meshes[idx[0]][0], float))[0], meshes[idx[0]][1])
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
