"""A pinhole camera in the OpenCV convention (x right, y down, z forward), as in a case's ``camera.json``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError


@dataclass
class Camera:
    """Intrinsics and extrinsics of one view.

    :param intrinsics: 3x3 ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in pixels
    :param world_to_camera: 4x4 rigid transform, benchmark frame -> OpenCV camera frame
    :param width: image width in pixels
    :param height: image height in pixels
    """

    intrinsics: np.ndarray
    world_to_camera: np.ndarray
    width: int
    height: int

    def resized(self, width: int, height: int | None = None) -> Camera:
        """The same view for an image of another size (intrinsics scaled per axis)."""
        height = width if height is None else height
        scale = np.diag([width / self.width, height / self.height, 1.0])
        return Camera(scale @ self.intrinsics, self.world_to_camera.copy(), int(width), int(height))

    def cropped(self, x0: float, y0: float, width: float, height: float | None = None) -> Camera:
        """The same view restricted to the window ``[x0, x0 + width) x [y0, y0 + height)`` (pixels).

        The result is an image of ``width x height`` pixels (rounded) whose pixel ``(i, j)`` is the
        original pixel ``(x0 + i, y0 + j)``; resize it to render the window at another resolution.
        """
        height = width if height is None else height
        intrinsics = self.intrinsics.copy()
        intrinsics[0, 2] -= x0
        intrinsics[1, 2] -= y0
        return Camera(intrinsics, self.world_to_camera.copy(), int(round(width)), int(round(height)))

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates ``(u, v)`` and depths of world points (N, 3)."""
        cam = np.asarray(points, float) @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        z = cam[:, 2]
        uv = cam[:, :2] / z[:, None] * np.diag(self.intrinsics)[:2] + self.intrinsics[:2, 2]
        return uv, z


def look_at_camera(position, target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), size: int = 128,
                   fov_deg: float = 40.0) -> Camera:
    """A camera at ``position`` looking at ``target`` (OpenCV axes), with ``fx = fy = (size/2)/tan(fov/2)``."""
    from spark_bench.data.camera import intrinsics_matrix, look_at

    return Camera(intrinsics_matrix(size, size, fov_deg), look_at(position, target, up), size, size)


def load_camera(path: str | Path) -> Camera:
    """Read a case's ``camera.json`` (see docs/formats.md)."""
    from spark_bench.data.readers import read_json

    path = Path(path)
    data = read_json(path, missing="camera file not found")
    if not isinstance(data, dict):
        raise InputError(path, "malformed camera: expected a JSON object")
    try:
        intrinsics = np.asarray(data["intrinsics"], dtype=float)
        world_to_camera = np.asarray(data["world_to_camera"], dtype=float)
        width, height = int(data["width"]), int(data["height"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(path, f"malformed camera: {exc!r}") from None
    if intrinsics.shape != (3, 3) or world_to_camera.shape != (4, 4) or not (
            np.isfinite(intrinsics).all() and np.isfinite(world_to_camera).all()):
        raise InputError(path, "intrinsics must be 3x3 and world_to_camera 4x4, all finite")
    if width <= 0 or height <= 0:
        raise InputError(path, f"image size must be positive, got {width} x {height}")
    if data.get("convention", "opencv") != "opencv":
        raise InputError(path, f"unsupported camera convention {data.get('convention')!r}")
    return Camera(intrinsics, world_to_camera, width, height)


def load_camera_pose(path: str | Path) -> np.ndarray:
    """The 4x4 camera-to-world pose of a case's ``camera.json``.

    :param path: the file
    """
    return np.linalg.inv(load_camera(path).world_to_camera)
