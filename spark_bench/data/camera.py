"""The benchmark camera: a pinhole in the OpenCV convention, placed on a sphere looking at the origin.

Conventions (docs/formats.md, ``camera.json``): camera axes x right, y down, z forward; the world
(benchmark frame) is Z-up with the object's front facing -X. Continuous pixel coordinates put pixel
``(i, j)`` (column ``i``, row ``j``) over ``[i, i+1) x [j, j+1)``, so the principal point of a
centered frustum is ``(width / 2, height / 2)``: the same projection OpenGL (MuJoCo) rasterizes.
"""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError

#: Defaults of the benchmark view (SPARK's rendering setup): radius 4, 40 degree vertical field of view.
DEFAULT_DISTANCE = 4.0
DEFAULT_FOV_DEG = 40.0
#: SPARK's own view of its test objects (``datasets/preprocess/render.py`` and ``data_augmentation.py`` in
#: SPARK's code call ``render_single_view`` with azimuth 0 and elevation 0: a camera at ``(0, 0, 4)`` of the
#: Y-up, front +Z mesh frame, looking at the origin): straight at the object's front, level. In this
#: frame (Z up, front towards -X) that is azimuth 180, elevation 0.
SPARK_AZIMUTH_DEG = 180.0
SPARK_ELEVATION_DEG = 0.0
#: The front hemisphere: azimuth within this many degrees of -X, elevation in this range (degrees).
FRONT_AZIMUTH_SPAN_DEG = 60.0
FRONT_ELEVATION_RANGE_DEG = (10.0, 40.0)
WORLD_UP = (0.0, 0.0, 1.0)


def intrinsics_matrix(width: int, height: int, fov_deg: float) -> np.ndarray:
    """``[[f, 0, w/2], [0, f, h/2], [0, 0, 1]]`` with ``f = (h / 2) / tan(fovy / 2)`` (square pixels).

    :param width: image width in pixels
    :param height: image height in pixels
    :param fov_deg: vertical field of view in degrees
    """
    focal = (height / 2.0) / np.tan(np.radians(fov_deg) / 2.0)
    return np.array([[focal, 0.0, width / 2.0], [0.0, focal, height / 2.0], [0.0, 0.0, 1.0]])


def look_at(position, target=(0.0, 0.0, 0.0), up=WORLD_UP) -> np.ndarray:
    """4x4 world-to-camera transform (OpenCV axes) of a camera at ``position`` looking at ``target``.

    When the view direction is parallel to ``up`` the image's "up" falls back to world +Y.

    :param position: camera center in the world frame
    :param target: the point the optical axis goes through
    :param up: world direction that appears upwards in the image
    """
    position, target, up = (np.asarray(v, dtype=float) for v in (position, target, up))
    forward = target - position
    norm = np.linalg.norm(forward)
    if not np.isfinite(norm) or norm <= 0:
        raise ValueError("camera position and target coincide")
    forward /= norm
    right = np.cross(forward, up)
    if np.linalg.norm(right) < 1e-9:
        right = np.cross(forward, (0.0, 1.0, 0.0))
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rotation = np.stack([right, down, forward])  # rows: camera axes in world coordinates
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = -rotation @ position
    return out


def spherical_position(azimuth_deg: float, elevation_deg: float, distance: float) -> np.ndarray:
    """World point at ``distance`` from the origin; azimuth from +X towards +Y, elevation above XY."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def view_seed(case_id: str, seed: int = 0) -> int:
    """A stable per-case seed (the same id and seed give the same view on every machine)."""
    return (zlib.crc32(str(case_id).encode()) + 1_000_003 * int(seed)) % (2**31 - 1)


def front_view_angles(seed: int) -> tuple[float, float]:
    """Seeded ``(azimuth, elevation)`` in degrees from the object's front hemisphere (around -X)."""
    rng = np.random.default_rng(seed)
    azimuth = 180.0 + rng.uniform(-FRONT_AZIMUTH_SPAN_DEG, FRONT_AZIMUTH_SPAN_DEG)
    elevation = rng.uniform(*FRONT_ELEVATION_RANGE_DEG)
    return float(azimuth), float(elevation)


@dataclass
class CameraView:
    """One pinhole view of the benchmark frame.

    :param width: image width in pixels
    :param height: image height in pixels
    :param fov_deg: vertical field of view in degrees
    :param world_to_camera: 4x4 rigid transform, world (benchmark frame) -> OpenCV camera frame
    :param azimuth_deg: azimuth of the camera center (degrees from +X towards +Y), when on a sphere
    :param elevation_deg: elevation of the camera center (degrees above the XY plane), when on a sphere
    """

    width: int
    height: int
    fov_deg: float
    world_to_camera: np.ndarray
    azimuth_deg: float | None = None
    elevation_deg: float | None = None

    @classmethod
    def on_sphere(cls, azimuth_deg: float, elevation_deg: float, distance: float = DEFAULT_DISTANCE,
                  size: int = 512, fov_deg: float = DEFAULT_FOV_DEG, height: int | None = None) -> CameraView:
        """A camera on the sphere of radius ``distance`` looking at the origin, world up +Z.

        :param size: image width (and height unless ``height`` is given) in pixels
        """
        position = spherical_position(azimuth_deg, elevation_deg, distance)
        return cls(int(size), int(height or size), float(fov_deg), look_at(position),
                   float(azimuth_deg), float(elevation_deg))

    @classmethod
    def front(cls, seed: int, distance: float = DEFAULT_DISTANCE, size: int = 512,
              fov_deg: float = DEFAULT_FOV_DEG) -> CameraView:
        """The seeded benchmark view from the front hemisphere (see :func:`front_view_angles`)."""
        azimuth, elevation = front_view_angles(seed)
        return cls.on_sphere(azimuth, elevation, distance, size, fov_deg)

    # ----- derived quantities ------------------------------------------------------------------
    @property
    def intrinsics(self) -> np.ndarray:
        return intrinsics_matrix(self.width, self.height, self.fov_deg)

    @property
    def camera_to_world(self) -> np.ndarray:
        rot, trans = self.world_to_camera[:3, :3], self.world_to_camera[:3, 3]
        out = np.eye(4)
        out[:3, :3] = rot.T
        out[:3, 3] = -rot.T @ trans
        return out

    @property
    def position(self) -> np.ndarray:
        """Camera center in the world frame."""
        return self.camera_to_world[:3, 3].copy()

    @property
    def distance(self) -> float:
        """Distance from the camera center to the world origin."""
        return float(np.linalg.norm(self.position))

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates ``(N, 2)`` and camera depths ``(N,)`` of world points ``(N, 3)``."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        cam = points @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        depth = cam[:, 2]
        k = self.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = cam[:, :2] / depth[:, None] * np.array([k[0, 0], k[1, 1]]) + k[:2, 2]
        return uv, depth

    def pixel_of(self, points) -> np.ndarray:
        """Integer ``(column, row)`` of the pixel each world point falls in (may be outside the image)."""
        uv, _ = self.project(points)
        return np.floor(uv).astype(int)

    # ----- files ---------------------------------------------------------------------------------
    def to_json(self) -> dict:
        """The ``camera.json`` object (docs/formats.md)."""
        out = {"width": self.width, "height": self.height, "fov_deg": self.fov_deg,
               "distance": round(self.distance, 12),
               "intrinsics": self.intrinsics.tolist(),
               "world_to_camera": self.world_to_camera.tolist(),
               "camera_to_world": self.camera_to_world.tolist(),
               "position": self.position.tolist(), "convention": "opencv"}
        if self.azimuth_deg is not None:
            out["azimuth_deg"], out["elevation_deg"] = self.azimuth_deg, self.elevation_deg
        return out

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_json(), indent=1) + "\n")
        return path

    @classmethod
    def from_json(cls, data: dict, source: str | Path | None = None) -> CameraView:
        """Parse a ``camera.json`` object; the stored intrinsics must agree with the field of view."""
        try:
            width, height = int(data["width"]), int(data["height"])
            world_to_camera = np.asarray(data["world_to_camera"], dtype=float)
            intrinsics = np.asarray(data["intrinsics"], dtype=float)
            fov = float(data.get("fov_deg") or np.degrees(2 * np.arctan((height / 2) / intrinsics[1, 1])))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise InputError(source, f"malformed camera: {exc!r}") from None
        if data.get("convention", "opencv") != "opencv":
            raise InputError(source, f"unsupported camera convention {data.get('convention')!r}")
        if world_to_camera.shape != (4, 4) or not np.isfinite(world_to_camera).all():
            raise InputError(source, "world_to_camera must be a finite 4x4 matrix")
        view = cls(width, height, fov, world_to_camera, data.get("azimuth_deg"), data.get("elevation_deg"))
        if intrinsics.shape != (3, 3) or not np.allclose(intrinsics, view.intrinsics, rtol=1e-6, atol=1e-6):
            raise InputError(source, "intrinsics disagree with width, height and fov_deg")
        return view

    @classmethod
    def load(cls, path: str | Path) -> CameraView:
        from spark_bench.data.readers import read_json

        path = Path(path)
        return cls.from_json(read_json(path, missing="camera file not found"), source=path)
