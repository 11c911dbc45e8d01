"""The gallery index: features of renders of every gallery object over a grid of views, cached.

Every gallery object is read, put into the benchmark frame (:func:`~spark_bench.data.case.to_benchmark_frame`),
given one colour per link (the area-weighted mean, as the benchmark cases are prepared), and rendered
with MuJoCo (:class:`~spark_bench.methods.retrieval.render.GalleryRenderer`: the dataset's scenes, without
multisampling, on one OpenGL context per process) from ``azimuths`` evenly spaced azimuths
at each of ``elevations``, at the index scale (:class:`~spark_bench.methods.retrieval.features.FeatureOptions`).
Each render becomes :func:`~spark_bench.methods.retrieval.features.view_features`.

The index is cached in ``$SPARK_BENCH_HOME/retrieval/index/<gallery hash>-<options hash>.npz``: keyed by
the gallery's content (:attr:`~spark_bench.methods.retrieval.gallery.Gallery.content_hash`) and by what the
features are, so a changed object, another gallery or other options never reuse a stale index. An
object that cannot be read or rendered is left out and listed (``skipped``).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError
from spark_bench.methods.retrieval.features import FeatureOptions, object_mask, view_features
from spark_bench.methods.retrieval.gallery import Gallery

#: Bumped whenever the same gallery and options would give other features.
INDEX_VERSION = "1"


@dataclass(frozen=True)
class IndexOptions:
    """The grid of views of the index and its features.

    :param features: the feature options (render size, camera, canvases)
    :param azimuths: views per turn (evenly spaced from azimuth 0)
    :param elevations: camera elevations in degrees
    """

    features: FeatureOptions = field(default_factory=FeatureOptions)
    azimuths: int = 24
    elevations: tuple[float, ...] = (0.0, 15.0, 30.0, 45.0, 60.0)

    def key(self) -> str:
        text = json.dumps({"version": INDEX_VERSION, **asdict(self)}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def azimuth_grid(self) -> np.ndarray:
        return np.arange(self.azimuths) * (360.0 / self.azimuths)


@dataclass
class GalleryIndex:
    """Features of every view of every indexed gallery object.

    Arrays are indexed ``[object, elevation, azimuth, ...]``.

    :param object_ids: indexed objects, in gallery order
    :param categories: their categories
    :param hashes: their content hashes
    :param bits: packed canonical silhouettes ``(O, E, A, words)`` uint64
    :param edges: canonical edge maps ``(O, E, A, edge_canvas**2)`` float16
    :param sizes: bounding-box sides in pixels ``(O, E, A)``
    :param options: the grid and features
    :param gallery_hash: the gallery's content hash
    :param skipped: objects left out, with the reason
    :param seconds: time the build took (0 when read from the cache)
    """

    object_ids: list[str]
    categories: list[str]
    hashes: list[str]
    bits: np.ndarray
    edges: np.ndarray
    sizes: np.ndarray
    options: IndexOptions
    gallery_hash: str
    skipped: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    def __len__(self) -> int:
        return len(self.object_ids)

    def save(self, path: Path) -> None:
        meta = {"object_ids": self.object_ids, "categories": self.categories, "hashes": self.hashes,
                "gallery_hash": self.gallery_hash, "skipped": self.skipped, "options_key": self.options.key(),
                "build_seconds": self.seconds}
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(tmp, "wb") as handle:
            np.savez(handle, bits=self.bits, edges=self.edges, sizes=self.sizes, meta=np.array(json.dumps(meta)))
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: Path, options: IndexOptions, gallery_hash: str) -> GalleryIndex | None:
        """The index cached at ``path``; None when absent, unreadable or of another gallery/options."""
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                if meta.get("options_key") != options.key() or meta.get("gallery_hash") != gallery_hash:
                    return None
                return cls(list(meta["object_ids"]), list(meta["categories"]), list(meta["hashes"]),
                           data["bits"], data["edges"], data["sizes"], options, gallery_hash,
                           dict(meta.get("skipped", {})), 0.0)
        except (OSError, ValueError, KeyError, TypeError):
            return None


def render_ready(asset):
    """``asset`` in the benchmark frame with one colour per link (the area-weighted mean of its visuals),
    as the cases are rendered; returns ``(asset, center, scale)``."""
    from spark_bench.data.case import to_benchmark_frame
    from spark_bench.data.prepare import link_color

    normalized, center, scale = to_benchmark_frame(asset)
    for link in normalized.links.values():
        if link.visuals:
            color = link_color(link)
            for visual in link.visuals:
                visual.rgba = color
    return normalized, center, scale


def _object_views(folder: Path, options: IndexOptions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(bits, edges, sizes)`` of one object over the grid."""
    from spark_bench.data.camera import CameraView
    from spark_bench.data.readers import load_object
    from spark_bench.methods.retrieval.render import GalleryRenderer

    feats = options.features
    asset, _, _ = render_ready(load_object(folder))
    n_el, n_az = len(options.elevations), options.azimuths
    bits = np.zeros((n_el, n_az, feats.words), dtype=np.uint64)
    edges = np.zeros((n_el, n_az, feats.edge_canvas ** 2), dtype=np.float16)
    sizes = np.zeros((n_el, n_az), dtype=np.float32)
    with GalleryRenderer(asset, feats.render_size) as renderer:
        for e, elevation in enumerate(options.elevations):
            for a, azimuth in enumerate(options.azimuth_grid):
                view = CameraView.on_sphere(float(azimuth), float(elevation), feats.distance,
                                            feats.render_size, feats.fov_deg)
                rgb = renderer.render(view)
                f = view_features(rgb, object_mask(rgb, render=True), feats)
                bits[e, a], edges[e, a], sizes[e, a] = f.bits, f.edges, f.size
    if not sizes.any():
        raise ValueError("nothing of the object is visible in any view")
    return bits, edges, sizes


def _index_chunk(jobs: list[tuple[str, str]], options: IndexOptions) -> list[tuple[str, object]]:
    """Worker body: ``(id, (bits, edges, sizes))`` per object, or ``(id, reason)`` when it fails."""
    out = []
    for object_id, folder in jobs:
        try:
            out.append((object_id, _object_views(Path(folder), options)))
        except Exception as exc:  # one unreadable or unrenderable object is skipped, and said
            text = getattr(exc, "problem", None) or f"{type(exc).__name__}: {exc}"
            out.append((object_id, " ".join(str(text).split())[:300]))
    return out


def build_index(gallery: Gallery, options: IndexOptions | None = None, workers: int = 1,
                isolate: bool = False) -> GalleryIndex:
    """Render and featurize every object of ``gallery`` (no cache).

    :param workers: processes (each opens its own OpenGL context)
    :param isolate: render in spawned processes even with one worker, so that this process opens no
        OpenGL context (a process that will fork workers must not: EGL does not survive a fork)
    :raises InputError: naming the gallery folder when no object can be rendered
    """
    options = options or IndexOptions()
    start = time.perf_counter()
    jobs = [(o.id, str(o.folder)) for o in gallery.objects]
    results: dict[str, object] = {}
    if isolate or (workers > 1 and len(jobs) > 1):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        workers = max(1, workers)
        n_chunks = min(len(jobs), 4 * workers)
        chunks = [jobs[k::n_chunks] for k in range(n_chunks)]
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            for part in pool.map(_index_chunk, chunks, [options] * len(chunks)):
                results.update(part)
    else:
        results.update(_index_chunk(jobs, options))
    kept = [o for o in gallery.objects if not isinstance(results[o.id], str)]
    skipped = {**gallery.skipped, **{o.id: results[o.id] for o in gallery.objects if isinstance(results[o.id], str)}}
    if not kept:
        examples = "; ".join(f"{k}: {v}" for k, v in list(skipped.items())[:3])
        raise InputError(gallery.folder, f"broken gallery: no object could be read and rendered ({examples})")
    stack = [results[o.id] for o in kept]
    return GalleryIndex([o.id for o in kept], [o.category for o in kept], [o.content_hash for o in kept],
                        np.stack([s[0] for s in stack]), np.stack([s[1] for s in stack]),
                        np.stack([s[2] for s in stack]), options, gallery.content_hash, skipped,
                        time.perf_counter() - start)


def index_path(gallery: Gallery, options: IndexOptions) -> Path:
    """Where the index of ``gallery`` with ``options`` is cached."""
    from spark_bench.paths import cache_dir

    return cache_dir("retrieval") / "index" / f"{gallery.content_hash[:24]}-{options.key()[:12]}.npz"


_LOADED: dict[tuple[str, str], GalleryIndex] = {}


def gallery_index(gallery: Gallery, options: IndexOptions | None = None, workers: int = 1,
                  use_cache: bool = True, isolate: bool = False) -> GalleryIndex:
    """The index of ``gallery``: from this process's memory, the cache, or built now (and cached).

    :param workers: processes for a build
    :param use_cache: read and write the cache (False: always build, keep nothing)
    :param isolate: a build renders in spawned processes only (see :func:`build_index`)
    """
    from spark_bench.data.prepare import bench_lock

    options = options or IndexOptions()
    key = (gallery.content_hash, options.key())
    if use_cache and key in _LOADED:
        return _LOADED[key]
    if not use_cache:
        return build_index(gallery, options, workers, isolate)
    path = index_path(gallery, options)
    path.parent.mkdir(parents=True, exist_ok=True)
    index = GalleryIndex.load(path, options, gallery.content_hash)
    if index is None:
        with bench_lock(path.parent / f".{path.stem}.build", wait=True):
            index = GalleryIndex.load(path, options, gallery.content_hash)
            if index is None:
                index = build_index(gallery, options, workers, isolate)
                index.save(path)
    _LOADED[key] = index
    return index


__all__ = ["INDEX_VERSION", "GalleryIndex", "IndexOptions", "build_index", "gallery_index", "index_path",
           "render_ready"]
