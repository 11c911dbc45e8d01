"""Render-and-compare retrieval: the gallery object whose renders best explain one image.

:func:`retrieve` is the whole method for one image and its camera:

1. **The input's silhouette** comes from the image itself (flat background,
   :func:`~spark_bench.data.images.mask_from_image`), never from a label image. The image is
   resampled to the index scale with its camera (:func:`~spark_bench.methods.retrieval.features.query_frame`).
2. **Coarse search** over objects x views: the index rows nearest the camera's elevation, every azimuth.
   A candidate (object, view) scores

   ``IoU(canonical silhouettes) + edge_weight * cos(edge maps) - size_weight * |log(size ratio)|
   - yaw_weight * (1 - cos(yaw)) / 2``.

   The canonical crop compares silhouettes at every scale at once (each is cropped to its own box);
   the size term keeps the scale that this implies near the one of an object normalized into the
   benchmark frame, as every gallery object and every case is. ``yaw`` is how far the object must
   turn about the up axis (world Z) so that the camera sees it from the matched view: the benchmark
   convention (front towards -X) makes 0 the expected value, the penalty a weak prior.
3. **Pose refinement** of the best ``refine_objects`` objects: each is rendered from the input's own
   camera (exact elevation, perspective and field of view; the lights turned with the object, as the
   index views are not) at yaws around two hypotheses (its best view's, and its best view at least
   :data:`ALT_YAW_DEG` away: a box's front and back look alike) and at the quarter turns nearest to
   them, scored the same way; the best (object, yaw) wins (ties go to the smaller turn). The scale is
   the ratio of the silhouettes' sizes.
4. **The result**: the gallery object (its parts, joints, limits and semantics), in the benchmark frame,
   turned by the found yaw about world Z and normalized again into the benchmark frame
   (:func:`~spark_bench.data.case.to_benchmark_frame`), and a record of what was retrieved.

There is always a result: the nearest thing the gallery has, also for a category it lacks.
"""

from __future__ import annotations

import os
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError
from spark_bench.methods.retrieval.features import (
    camera_angles,
    object_mask,
    popcount_iou,
    query_frame,
    view_features,
)
from spark_bench.methods.retrieval.gallery import Gallery, open_gallery
from spark_bench.methods.retrieval.index import GalleryIndex, IndexOptions, gallery_index, render_ready

#: The record written beside a retrieved object folder.
RECORD_FILE = "retrieval.json"
#: How far (degrees) an object's second yaw hypothesis is from its best view's.
ALT_YAW_DEG = 45.0


@dataclass(frozen=True)
class SearchOptions:
    """How the search scores and refines (the defaults' speed and accuracy: ``benchmarks/measure_retrieval.py``,
    ``benchmarks/results/retrieval.md``).

    :param index: the index grid and features
    :param edge_weight: weight of the edge-map similarity
    :param size_weight: penalty per unit of ``|log(size ratio)|``
    :param yaw_weight: penalty of a half turn (prior towards the benchmark's front convention)
    :param rows: index elevation rows compared (the nearest to the camera's elevation)
    :param refine_objects: objects whose pose is refined with renders from the input camera
    :param refine_yaws: yaw offsets (degrees) tried around each refined object's best view (the quarter
        turn nearest to that view's yaw is always tried too)
    """

    index: IndexOptions = field(default_factory=IndexOptions)
    edge_weight: float = 0.5
    size_weight: float = 0.5
    yaw_weight: float = 1.0
    rows: int = 2
    refine_objects: int = 4
    refine_yaws: tuple[float, ...] = (-10.0, -5.0, 0.0, 5.0, 10.0)

    def to_json(self) -> dict:
        return asdict(self)


@dataclass
class Retrieval:
    """What :func:`retrieve` found.

    :param asset: the retrieved object, in the benchmark frame, turned to match the image
    :param record: the JSON record: gallery, object id, category, content hash, view, yaw, scale, score,
        pose, runners-up, timings
    """

    asset: object
    record: dict

    @property
    def object_id(self) -> str:
        return self.record["object_id"]

    @property
    def category(self) -> str:
        return self.record["category"]


def _wrap(degrees):
    """Angles in (-180, 180]."""
    return -((-np.asarray(degrees, dtype=float) + 180.0) % 360.0 - 180.0)


def _yaw_matrix(yaw_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


class ObjectCache:
    """The last few gallery objects read: ``(asset as read, renderer of its render-ready copy)``."""

    def __init__(self, size: int = 16):
        self.size = size
        self.items: OrderedDict[tuple, tuple] = OrderedDict()
        self.pid = os.getpid()

    def get(self, folder: Path, content_hash: str, render_size: int) -> tuple:
        from spark_bench.data.readers import load_object
        from spark_bench.methods.retrieval.render import GalleryRenderer

        if self.pid != os.getpid():  # forked: the parent's OpenGL buffers are not ours
            self.items.clear()
            self.pid = os.getpid()
        key = (content_hash, render_size)
        if key in self.items:
            self.items.move_to_end(key)
            return self.items[key]
        asset = load_object(folder)
        ready, _, _ = render_ready(asset)
        self.items[key] = (asset, GalleryRenderer(ready, render_size))
        while len(self.items) > self.size:
            _, (_, old) = self.items.popitem(last=False)
            old.close()
        return self.items[key]


_OBJECTS = ObjectCache()


def _score(iou, edge, size_ratio, yaw_deg, options: SearchOptions):
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.abs(np.log(size_ratio))
    log_ratio = np.where(np.isfinite(log_ratio), log_ratio, 10.0)
    return (iou + options.edge_weight * edge - options.size_weight * log_ratio
            - options.yaw_weight * (1.0 - np.cos(np.radians(yaw_deg))) / 2.0)


def coarse_search(index: GalleryIndex, query, azimuth: float, elevation: float,
                  options: SearchOptions) -> list[dict]:
    """The best view of every indexed object, best object first.

    :param query: the input's :class:`~spark_bench.methods.retrieval.features.ViewFeatures`
    :param azimuth: the camera's azimuth (degrees)
    :param elevation: the camera's elevation (degrees)
    """
    elevations = np.asarray(index.options.elevations, dtype=float)
    rows = np.sort(np.argsort(np.abs(elevations - elevation), kind="stable")[:max(1, options.rows)])
    n_obj, n_az = len(index), index.options.azimuths
    bits = index.bits[:, rows].reshape(-1, index.bits.shape[-1])
    iou = popcount_iou(bits, query.bits)
    edges = index.edges[:, rows].reshape(-1, index.edges.shape[-1]).astype(np.float32) @ query.edges
    sizes = index.sizes[:, rows].reshape(-1).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = query.size / sizes
    yaws = _wrap(azimuth - index.options.azimuth_grid)  # object turn that shows view `a` to the camera
    yaw = np.broadcast_to(yaws, (n_obj, len(rows), n_az)).reshape(-1)
    score = _score(iou, edges, ratio, yaw, options).reshape(n_obj, -1)
    best = score.argmax(axis=1)
    # a second yaw hypothesis per object: its best view at least `ALT_YAW_DEG` away from the best one
    # (front and back of a box look alike in silhouette)
    by_azimuth = score.reshape(n_obj, len(rows), n_az).max(axis=1)
    apart = np.abs(_wrap(yaws[:, None] - yaws[None, :])) >= ALT_YAW_DEG
    alternative = np.where(apart[best % n_az], by_azimuth, -np.inf).argmax(axis=1)
    order = np.argsort(-score[np.arange(n_obj), best], kind="stable")
    out = []
    for o in order:
        flat = o * score.shape[1] + best[o]
        r, a = divmod(int(best[o]), n_az)
        out.append({"object": int(o), "score": float(score[o, best[o]]), "iou": float(iou[flat]),
                    "edge": float(edges[flat]), "scale": float(ratio[flat]), "yaw_deg": float(yaw[flat]),
                    "alt_yaw_deg": float(yaws[alternative[o]]),
                    "view": {"azimuth_deg": float(index.options.azimuth_grid[a]),
                             "elevation_deg": float(elevations[rows[r]])}})
    return out


def _refine(gallery: Gallery, index: GalleryIndex, candidate: dict, query, frame_view,
            options: SearchOptions) -> dict:
    """The best yaw of one candidate object, rendered from the input's own camera."""
    from spark_bench.data.camera import CameraView

    feats = index.options.features
    obj = gallery.object(index.object_ids[candidate["object"]])
    _, renderer = _OBJECTS.get(obj.folder, obj.content_hash, feats.render_size)
    best = None
    yaws = set()
    for coarse in (candidate["yaw_deg"], candidate["alt_yaw_deg"]):
        # around each coarse yaw, and the quarter turn nearest to it (the object frames' conventions)
        yaws |= {round(float(_wrap(coarse + offset)), 6) for offset in options.refine_yaws}
        yaws.add(round(float(_wrap(90.0 * np.round(coarse / 90.0))), 6))
    for yaw in sorted(yaws, key=abs):
        # turning the object by `yaw` about world Z = turning the camera by -yaw
        view = CameraView(frame_view.width, frame_view.height, frame_view.fov_deg,
                          frame_view.world_to_camera @ _yaw_matrix(yaw))
        rgb = renderer.render(view, light_turn_deg=-yaw)  # lit as the turned object is
        f = view_features(rgb, object_mask(rgb, render=True), feats)
        iou = float(popcount_iou(f.bits[None], query.bits)[0])
        edge = float(f.edges @ query.edges)
        ratio = query.size / f.size if f.size > 0 else np.inf
        score = float(_score(iou, edge, ratio, yaw, options))
        if best is None or score > best["score"] + 1e-12:
            offset_px = query.center - f.center
            best = {**candidate, "score": score, "iou": iou, "edge": edge, "scale": float(ratio),
                    "yaw_deg": yaw, "offset_px": offset_px.tolist()}
    return best


def _pose(best: dict, frame_view, focal: float) -> np.ndarray:
    """The 4x4 similarity that places the gallery object (benchmark frame) where it explains the image:
    turned by the yaw, scaled by the scale, moved by the silhouettes' offset at the origin's depth."""
    depth = float(frame_view.world_to_camera[2, 3])
    shift_cam = np.array([best["offset_px"][0], best["offset_px"][1], 0.0]) * depth / focal
    pose = _yaw_matrix(best["yaw_deg"])
    pose[:3, :3] *= best["scale"]
    pose[:3, 3] = frame_view.world_to_camera[:3, :3].T @ shift_cam
    return pose


def _as_rgb(image) -> np.ndarray:
    from PIL import Image

    if isinstance(image, np.ndarray):
        return np.asarray(image)[..., :3].astype(np.uint8)
    if isinstance(image, Image.Image):
        return np.asarray(image.convert("RGB"))
    path = Path(image)
    if not path.is_file():
        raise InputError(path, "input image not found")
    try:
        with Image.open(path) as opened:
            return np.asarray(opened.convert("RGB"))
    except OSError as exc:
        raise InputError(path, f"unreadable image: {exc}") from None


def _as_view(camera):
    from spark_bench.data.camera import CameraView

    if isinstance(camera, CameraView):
        return camera
    if isinstance(camera, dict):
        return CameraView.from_json(camera)
    return CameraView.load(camera)


def placed_asset(asset, yaw_deg: float):
    """A gallery object (as read), in the benchmark frame, turned by ``yaw_deg`` about world Z and
    normalized again into the benchmark frame (a turn changes the axis-aligned box)."""
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.data.case import to_benchmark_frame

    asset, _, _ = to_benchmark_frame(asset)
    if abs(yaw_deg) > 1e-9:
        asset, _, _ = to_benchmark_frame(similarity_asset(asset, _yaw_matrix(yaw_deg)))
    return asset


def retrieve(image, camera, gallery: Gallery | str | Path | None = None, options: SearchOptions | None = None,
             workers: int = 1) -> Retrieval:
    """The gallery object that best explains ``image`` seen by ``camera``, placed in the benchmark frame.

    :param image: the input image (path, PIL image or ``(H, W, 3)`` uint8 array), flat background
    :param camera: its camera (:class:`~spark_bench.data.camera.CameraView`, a ``camera.json`` dict or path)
    :param gallery: a :class:`Gallery`, a gallery folder, or None for the default ``synth-gallery-v1``
    :param options: search options
    :param workers: processes for a first build of the gallery or its index
    :raises InputError: for an unreadable image or camera, an empty or broken gallery folder, or an
        image in which no object stands out from the background
    """
    options = options or SearchOptions()
    timings: dict[str, float] = {}
    start = time.perf_counter()
    if not isinstance(gallery, Gallery):
        gallery = open_gallery(gallery, workers=workers)
    index = gallery_index(gallery, options.index, workers=workers)
    timings["gallery_and_index"] = time.perf_counter() - start

    start = time.perf_counter()
    view = _as_view(camera)
    rgb_q, mask_q, frame_view = query_frame(_as_rgb(image), view, options.index.features)
    query = view_features(rgb_q, mask_q, options.index.features)
    if query.size <= 0:
        raise InputError(image if isinstance(image, str | Path) else None,
                         "no object stands out from the background of the input image")
    azimuth, elevation = camera_angles(view)
    ranked = coarse_search(index, query, azimuth, elevation, options)
    timings["coarse"] = time.perf_counter() - start

    start = time.perf_counter()
    refined = [_refine(gallery, index, c, query, frame_view, options) for c in ranked[:max(1, options.refine_objects)]]
    refined.sort(key=lambda c: -c["score"])
    best = refined[0]
    timings["refine"] = time.perf_counter() - start

    start = time.perf_counter()
    obj = gallery.object(index.object_ids[best["object"]])
    asset = placed_asset(_OBJECTS.get(obj.folder, obj.content_hash, options.index.features.render_size)[0],
                         best["yaw_deg"])
    timings["place"] = time.perf_counter() - start
    focal = (frame_view.height / 2.0) / np.tan(np.radians(frame_view.fov_deg) / 2.0)
    runners_up = [{"object_id": index.object_ids[c["object"]], "category": index.categories[c["object"]],
                   "score": round(c["score"], 6), "yaw_deg": round(c["yaw_deg"], 3)} for c in refined[1:]]
    record = {
        "gallery": gallery.name, "gallery_folder": str(gallery.folder), "gallery_hash": gallery.content_hash,
        "object_id": obj.id, "category": obj.category, "object_hash": obj.content_hash,
        "object_folder": str(obj.folder),
        "score": best["score"], "iou": best["iou"], "edge": best["edge"],
        "view": best["view"], "camera": {"azimuth_deg": azimuth, "elevation_deg": elevation},
        "yaw_deg": best["yaw_deg"], "scale": best["scale"], "pose": _pose(best, frame_view, focal).tolist(),
        "runners_up": runners_up, "options": options.to_json(), "timings": timings,
    }
    return Retrieval(asset, record)


def write_retrieval(retrieval: Retrieval, out_dir: str | Path) -> Path:
    """Write the retrieved object folder (``mobility.urdf`` + meshes) and ``retrieval.json`` into
    ``out_dir``; returns ``out_dir``."""
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.jsonio import to_json_text

    out_dir = Path(out_dir)
    write_object_folder(retrieval.asset, out_dir)
    (out_dir / RECORD_FILE).write_text(to_json_text(retrieval.record, indent=1) + "\n")
    return out_dir


__all__ = ["RECORD_FILE", "Retrieval", "SearchOptions", "coarse_search", "placed_asset", "retrieve",
           "write_retrieval"]
