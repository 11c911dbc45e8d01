"""Small software renders of assets for the leaderboard page: no OpenGL, only NumPy and Pillow.

Triangles are projected with the case's camera (``camera.json``, OpenCV convention), sorted back to
front (painter's algorithm) and filled with a Lambert-shaded link colour. Good enough to see at a glance
whether a door swings the right way; not a substitute for the MuJoCo renders of the dataset.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from spark_bench.asset.model import ArticulatedAsset

#: Triangles drawn per render at most (larger meshes are subsampled by face, area-weighted order kept).
MAX_TRIANGLES = 30_000
LIGHT = np.array([-0.4, -0.3, 0.85])


def default_camera(size: int = 256) -> dict:
    """A camera in front of the object (front towards -X), a little to the side and above."""
    position = np.array([-3.2, -1.6, 1.6])
    forward = -position / np.linalg.norm(position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    world_to_camera = np.eye(4)
    world_to_camera[:3, :3] = np.stack([right, down, forward])
    world_to_camera[:3, 3] = -world_to_camera[:3, :3] @ position
    f = (size / 2) / np.tan(np.radians(40.0) / 2)
    return {"width": size, "height": size, "intrinsics": [[f, 0, size / 2], [0, f, size / 2], [0, 0, 1]],
            "world_to_camera": world_to_camera.tolist()}


def read_camera(path: Path) -> dict:
    """``camera.json``, or :func:`default_camera` when it is absent or unreadable."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError):
        return default_camera()


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


def render_folder(folder: Path, camera: dict, state: str = "rest", size: int = 256) -> Image.Image:
    """Render an object folder in its own benchmark frame (normalized by its own box, as the metrics
    compare it), at ``rest`` or ``open``."""
    from spark_bench.asset.ops import normalize_asset
    from spark_bench.data import load_object

    asset, _, _ = normalize_asset(load_object(folder))
    q = asset.open_configuration() if state == "open" else None
    return render_asset(asset, camera, q, size)
