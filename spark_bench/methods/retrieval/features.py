"""Image features of one view of an object, the same for a gallery render and for the input image.

Both go through :func:`view_features` at the *index scale*: an object in the benchmark frame seen from
the index camera distance with the index field of view (:class:`FeatureOptions`). A gallery render is
made at that scale; the input image is first resampled to it (:func:`query_frame`), using its camera.

The object mask is never a label image: it is :func:`~spark_bench.data.images.mask_from_image` of
the RGB image (the benchmark renders have a flat background), for the input image and the gallery
renders alike, so both lose the same pixels (a part as grey as the background).

Features of a view (the mask's bounding box, made square and cropped, is the *canonical crop*: it
takes out the object's position and size in the image, which the search compares separately):

- ``bits``: the silhouette in the canonical crop, ``canvas x canvas``, packed into uint64 words;
- ``edges``: the gradient magnitude of the luminance inside the object (the outline itself left out),
  area-averaged to ``edge_canvas x edge_canvas`` in the canonical crop and L2-normalized: the internal
  structure (doors, drawers, windows, knobs) that tells boxes apart;
- ``size``: the bounding box's larger side in pixels (at the index scale), for the scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image

from spark_bench.errors import InputError


@dataclass(frozen=True)
class FeatureOptions:
    """How a view is turned into features; part of the index's cache key.

    :param render_size: width and height of a gallery render (the index scale) in pixels
    :param fov_deg: vertical field of view of the index camera
    :param distance: distance of the index camera from the origin (benchmark frame)
    :param canvas: side of the canonical silhouette in pixels
    :param edge_canvas: side of the canonical edge map
    :param margin: border added around the bounding box of the canonical crop (fraction of its side)
    """

    render_size: int = 96
    fov_deg: float = 40.0
    distance: float = 4.0
    canvas: int = 40
    edge_canvas: int = 16
    margin: float = 0.04

    @property
    def focal(self) -> float:
        """Focal length of the index camera in pixels."""
        return (self.render_size / 2.0) / np.tan(np.radians(self.fov_deg) / 2.0)

    @property
    def words(self) -> int:
        """uint64 words of a packed silhouette."""
        return -(-self.canvas * self.canvas // 64)


@dataclass
class ViewFeatures:
    """Features of one view (see the module docstring); ``size`` 0 for an empty mask."""

    bits: np.ndarray
    edges: np.ndarray
    size: float
    center: np.ndarray


#: :func:`~spark_bench.data.images.mask_from_image`'s threshold (max channel difference from the
#: background, in [0, 1]).
MASK_THRESHOLD = 0.08


def object_mask(rgb: np.ndarray, render: bool = False) -> np.ndarray:
    """Boolean object mask of an RGB image with a flat background.

    :param rgb: ``(H, W, 3)`` uint8
    :param render: the image is a gallery render, whose background is known
        (:data:`~spark_bench.data.render.BACKGROUND`): the same test against that colour, without
        estimating it from the border (the renders are many; this is their hot loop)
    """
    if render:
        from spark_bench.data.render import BACKGROUND

        diff = np.abs(rgb[..., :3].astype(np.float32) / 255.0 - np.asarray(BACKGROUND, dtype=np.float32))
        return diff.max(axis=2) > MASK_THRESHOLD
    from spark_bench.data.images import mask_from_image

    image = Image.fromarray(np.ascontiguousarray(rgb[..., :3], dtype=np.uint8))
    return mask_from_image(image, MASK_THRESHOLD) > 0.5


def _resize(array: np.ndarray, box: tuple[float, float, float, float], size: int) -> np.ndarray:
    """Area-average of ``array`` (H, W) over ``box`` (x0, y0, x1, y1; may leave the image: zeros there)
    into ``size x size``."""
    height, width = array.shape
    x0, y0, x1, y1 = box
    pad = int(np.ceil(max(0.0, -x0, -y0, x1 - width, y1 - height))) + 1
    padded = np.pad(array.astype(np.float32), pad)
    image = Image.fromarray(padded, mode="F")
    out = image.resize((size, size), Image.Resampling.BOX, box=(x0 + pad, y0 + pad, x1 + pad, y1 + pad))
    return np.asarray(out, dtype=np.float32)


def _edge_map(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Gradient magnitude of the luminance on the object's interior (one pixel in from its outline)."""
    lum = (rgb[..., :3].astype(np.float32) / 255.0) @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    gx = np.zeros_like(lum)
    gy = np.zeros_like(lum)
    gx[:, 1:-1] = lum[:, 2:] - lum[:, :-2]
    gy[1:-1, :] = lum[2:, :] - lum[:-2, :]
    inner = mask.copy()
    inner[1:, :] &= mask[:-1, :]
    inner[:-1, :] &= mask[1:, :]
    inner[:, 1:] &= mask[:, :-1]
    inner[:, :-1] &= mask[:, 1:]
    return np.hypot(gx, gy) * inner


def view_features(rgb: np.ndarray, mask: np.ndarray, options: FeatureOptions) -> ViewFeatures:
    """The features of one view at the index scale.

    :param rgb: ``(H, W, 3)`` uint8 image
    :param mask: ``(H, W)`` boolean object mask
    """
    words = options.words
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return ViewFeatures(np.zeros(words, dtype=np.uint64),
                            np.zeros(options.edge_canvas ** 2, dtype=np.float32), 0.0, np.zeros(2))
    y0, y1, x0, x1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    side = float(max(y1 - y0, x1 - x0))
    center = np.array([(x0 + x1) / 2.0, (y0 + y1) / 2.0])
    half = side * (0.5 + options.margin)
    box = (center[0] - half, center[1] - half, center[0] + half, center[1] + half)
    silhouette = _resize(mask.astype(np.float32), box, options.canvas) >= 0.5
    bits = np.packbits(silhouette.reshape(-1), bitorder="little")
    bits = np.pad(bits, (0, words * 8 - bits.size)).view(np.uint64)
    edges = _resize(_edge_map(rgb, mask), box, options.edge_canvas).reshape(-1)
    norm = float(np.linalg.norm(edges))
    edges = edges / norm if norm > 1e-9 else edges
    return ViewFeatures(bits, edges.astype(np.float32), side, center)


def query_frame(rgb: np.ndarray, camera, options: FeatureOptions):
    """The input image resampled to the index scale: ``(rgb, mask, camera)``, square, of side
    ``render_size``, centred on the input camera's principal point, and the pinhole camera of that image
    (the input camera's pose, a field of view such that the object in the benchmark frame appears as
    large as in a gallery render from the index distance).

    :param rgb: the input image, ``(H, W, 3)`` uint8 with a flat background
    :param camera: its :class:`~spark_bench.data.camera.CameraView`
    :raises InputError: when the camera does not look towards the benchmark frame's origin
    """
    from spark_bench.data.camera import CameraView

    rgb = np.asarray(rgb)[..., :3]
    depth = float(camera.world_to_camera[2, 3])  # depth of the world origin in the camera
    if not np.isfinite(depth) or depth <= 0:
        raise InputError(None, "the camera does not face the object (the origin is behind it)")
    focal_in = float(camera.intrinsics[1, 1])
    size = options.render_size
    zoom = options.focal * depth / (focal_in * options.distance)  # output pixels per input pixel
    cx, cy = float(camera.intrinsics[0, 2]), float(camera.intrinsics[1, 2])
    half = (size / 2.0) / zoom
    box = (cx - half, cy - half, cx + half, cy + half)
    mask = object_mask(rgb)
    border = np.concatenate([rgb[0], rgb[-1], rgb[:, 0], rgb[:, -1]]).astype(np.float32)
    background = np.median(border, axis=0)
    channels = [_resize(rgb[..., c].astype(np.float32) - background[c], box, size) + background[c]
                for c in range(3)]
    out_rgb = np.clip(np.rint(np.stack(channels, axis=-1)), 0, 255).astype(np.uint8)
    out_mask = _resize(mask.astype(np.float32), box, size) >= 0.5
    fov = float(np.degrees(2.0 * np.arctan((size / 2.0) / (focal_in * zoom))))
    view = CameraView(size, size, fov, np.asarray(camera.world_to_camera, dtype=float))
    return out_rgb, out_mask, view


def camera_angles(camera) -> tuple[float, float]:
    """``(azimuth, elevation)`` in degrees of a camera's centre about the origin (azimuth from +X
    towards +Y, elevation above the XY plane)."""
    position = camera.position
    distance = float(np.linalg.norm(position))
    if distance <= 0:
        raise InputError(None, "the camera is at the origin")
    azimuth = float(np.degrees(np.arctan2(position[1], position[0])))
    elevation = float(np.degrees(np.arcsin(np.clip(position[2] / distance, -1.0, 1.0))))
    return azimuth % 360.0, elevation


def popcount_iou(bits: np.ndarray, query: np.ndarray) -> np.ndarray:
    """IoU of packed silhouettes ``bits`` (N, W) with one packed ``query`` (W,)."""
    inter = np.bitwise_count(bits & query).sum(axis=-1, dtype=np.int64)
    area = np.bitwise_count(bits).sum(axis=-1, dtype=np.int64)
    union = area + int(np.bitwise_count(query).sum()) - inter
    return np.where(union > 0, inter / np.maximum(union, 1), 0.0)


__all__ = ["FeatureOptions", "ViewFeatures", "camera_angles", "object_mask", "popcount_iou", "query_frame",
           "view_features"]
