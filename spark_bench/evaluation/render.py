"""Small software renders of assets for the leaderboard page: no OpenGL, only NumPy and Pillow.

Triangles are projected with the case's camera (``camera.json``, OpenCV convention), sorted back to
front (painter's algorithm) and filled with a Lambert-shaded link colour. Good enough to see at a glance
whether a door swings the right way; not a substitute for the MuJoCo renders of the dataset.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from spark_bench.asset.model import ArticulatedAsset

#: Triangles drawn per render at most (larger meshes are subsampled: a seeded uniform choice of faces).
MAX_TRIANGLES = 30_000
LIGHT = np.array([-0.4, -0.3, 0.85])
#: Where :func:`default_camera` stands: in front of the object (front towards -X), a little to the side
#: and above, looking at the origin.
DEFAULT_POSITION = (-3.2, -1.6, 1.6)
DEFAULT_FOV_DEG = 40.0


def default_camera(size: int = 256) -> dict:
    """The ``camera.json`` object of a square view from :data:`DEFAULT_POSITION`."""
    from spark_bench.data.camera import CameraView, look_at

    return CameraView(int(size), int(size), DEFAULT_FOV_DEG, look_at(DEFAULT_POSITION)).to_json()


def read_camera(path: Path) -> dict:
    """``camera.json``, or :func:`default_camera` when there is none.

    :raises InputError: naming the file when it is malformed (checked as
        :meth:`~spark_bench.data.camera.CameraView.from_json` checks it)
    """
    from spark_bench.data.camera import CameraView
    from spark_bench.data.readers import read_json

    camera = read_json(path, default=None)
    if camera is None:
        return default_camera()
    CameraView.from_json(camera, source=path)
    return camera


def _scaled_camera(camera: dict, size: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    width, height = int(camera.get("width", size)), int(camera.get("height", size))
    scale = size / max(width, height)
    k = np.asarray(camera["intrinsics"], dtype=float).copy()
    k[:2] *= scale
    return k, np.asarray(camera["world_to_camera"], dtype=float), round(width * scale), round(height * scale)


def render_asset(asset: ArticulatedAsset, camera: dict, q=None, size: int = 256,
                 background=(255, 255, 255)) -> Image.Image:
    """An RGB image of ``asset`` at configuration ``q`` seen by ``camera``.

    :param asset: the asset (benchmark frame)
    :param camera: a ``camera.json`` dict (intrinsics and world_to_camera)
    :param q: joint values (default: rest)
    :param size: the longer side of the image, in pixels
    :param background: background colour
    """
    k, w2c, width, height = _scaled_camera(camera, size)
    image = Image.new("RGB", (width, height), background)
    meshes = asset.link_meshes(q)
    tris, colors = [], []
    for name, mesh in meshes.items():
        if len(mesh.faces) == 0:
            continue
        tris.append(np.asarray(mesh.vertices)[np.asarray(mesh.faces)])
        rgba = asset.links[name].visuals[0].rgba if asset.links[name].visuals else (0.7, 0.7, 0.7, 1.0)
        colors.append(np.tile(np.asarray(rgba[:3], dtype=float), (len(mesh.faces), 1)))
    if not tris:
        return image
    triangles, rgb = np.concatenate(tris), np.concatenate(colors)
    if len(triangles) > MAX_TRIANGLES:
        keep = np.random.default_rng(0).choice(len(triangles), MAX_TRIANGLES, replace=False)
        triangles, rgb = triangles[keep], rgb[keep]
    cam = triangles @ w2c[:3, :3].T + w2c[:3, 3]
    in_front = (cam[:, :, 2] > 1e-3).all(axis=1)
    cam, world, rgb = cam[in_front], triangles[in_front], rgb[in_front]
    normals = np.cross(world[:, 1] - world[:, 0], world[:, 2] - world[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    shade = 0.35 + 0.65 * np.abs(normals @ (LIGHT / np.linalg.norm(LIGHT)))  # two-sided
    pixels = (cam[:, :, :2] / cam[:, :, 2:3]) * k[[0, 1], [0, 1]] + k[:2, 2]
    order = np.argsort(-cam[:, :, 2].mean(axis=1))  # far to near
    draw = ImageDraw.Draw(image)
    fill = np.clip(rgb * shade[:, None] * 255.0, 0, 255).astype(int)
    for i in order:
        draw.polygon([tuple(p) for p in pixels[i]], fill=tuple(fill[i]))
    return image


def load_for_render(folder: Path) -> ArticulatedAsset:
    """An object folder in its own benchmark frame (normalized by its own box, as the metrics compare it)."""
    from spark_bench.data.case import to_benchmark_frame
    from spark_bench.data.readers import load_object

    return to_benchmark_frame(load_object(folder))[0]


def render_state(asset: ArticulatedAsset, camera: dict, state: str = "rest", size: int = 256) -> Image.Image:
    """:func:`render_asset` at ``rest`` or ``open`` (every movable joint at its upper limit)."""
    return render_asset(asset, camera, asset.open_configuration() if state == "open" else None, size)


def render_folder(folder: Path, camera: dict, state: str = "rest", size: int = 256) -> Image.Image:
    """Render an object folder in its own benchmark frame at ``rest`` or ``open``; to render several
    states, load once with :func:`load_for_render` and call :func:`render_state` for each."""
    return render_state(load_for_render(folder), camera, state, size)
