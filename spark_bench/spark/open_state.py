"""Open-state image backends (stage 3): the supervision of the joint optimization.

- ``dataset``: the case's rendered ``open.png``, its object mask (``open_seg.png > 0``) and its
  per-link masks (``open_seg.png == k + 1`` for ``case.json`` link k);
- ``http``: an image-generation endpoint that turns the input image into its open state. It receives
  ``POST {url}`` with JSON ``{"model", "prompt", "image": <PNG data URL>, "response_format": "b64_json"}``
  and answers OpenAI's images shape ``{"data": [{"b64_json": "<PNG>"}]}``. The mask is the PNG's alpha
  channel when it has one, otherwise every pixel that differs from the border colour.
"""

from __future__ import annotations

import base64
import io
import json
import os
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from spark_bench.errors import InputError
from spark_bench.spark.vlm import image_data_url

OPEN_PROMPT = ("The same object, same camera, same lighting, with every movable part (doors, drawers, "
               "lids...) fully open. Plain background.")


@dataclass
class OpenState:
    """The open-state supervision: ``mask`` (H, W) in [0, 1], where it came from, and, when the source
    has a segmentation, ``part_masks``: the visible mask of each of the case's links (by link name)."""

    mask: np.ndarray
    source: str
    part_masks: dict[str, np.ndarray] = field(default_factory=dict)


def mask_from_image(image: Image.Image, threshold: float = 0.08) -> np.ndarray:
    """Object mask of a generated image: its alpha channel, or the pixels unlike the border colour."""
    if image.mode in ("RGBA", "LA"):
        alpha = np.asarray(image.getchannel("A"), dtype=np.float64) / 255.0
        if alpha.min() < 0.5:
            return (alpha >= 0.5).astype(np.float64)
    rgb = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0
    border = np.concatenate([rgb[0], rgb[-1], rgb[:, 0], rgb[:, -1]])
    background = np.median(border, axis=0)
    return (np.abs(rgb - background).max(axis=2) > threshold).astype(np.float64)


def dataset_open_state(case_dir: Path) -> OpenState:
    """The ``dataset`` backend: ``open_seg.png`` (16-bit labels, 0 = background) as the mask."""
    seg_path = Path(case_dir) / "open_seg.png"
    if seg_path.is_file():
        try:
            seg = np.asarray(Image.open(seg_path))
        except OSError as exc:
            raise InputError(seg_path, f"unreadable image: {exc}") from None
        if seg.ndim == 3:
            seg = seg[..., 0]
        return OpenState((seg > 0).astype(np.float64), str(seg_path), _link_masks(seg, case_dir))
    image_path = Path(case_dir) / "open.png"
    if not image_path.is_file():
        raise InputError(case_dir, "no open_seg.png or open.png for the open-state supervision")
    with Image.open(image_path) as image:
        return OpenState(mask_from_image(image), str(image_path))


def _link_masks(seg: np.ndarray, case_dir: Path) -> dict[str, np.ndarray]:
    """Per-link masks of a segmentation (value k + 1 = ``case.json`` link k); none without case.json."""
    case_path = Path(case_dir) / "case.json"
    try:
        links = json.loads(case_path.read_text())["links"]
    except (OSError, json.JSONDecodeError, KeyError, TypeError):
        return {}
    present = set(np.unique(seg).tolist()) - {0}
    return {str(links[k - 1]): (seg == k).astype(np.float64) for k in sorted(present) if 0 < k <= len(links)}


def http_open_state(config, input_png: bytes) -> OpenState:
    """The ``http`` backend (see the module docstring); ``config`` is an ``OpenStateConfig``."""
    body = {"model": config.model, "prompt": OPEN_PROMPT, "image": image_data_url(input_png),
            "response_format": "b64_json"}
    headers = {"Content-Type": "application/json"}
    key = os.environ.get(config.api_key_env) if config.api_key_env else None
    if key:
        headers["Authorization"] = f"Bearer {key}"
    request = urllib.request.Request(config.url, data=json.dumps(body).encode(), headers=headers, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=config.timeout_s) as response:
            payload = json.loads(response.read())
        png = base64.b64decode(payload["data"][0]["b64_json"])
        image = Image.open(io.BytesIO(png))
        image.load()
    except urllib.error.HTTPError as exc:
        raise InputError(config.url, f"image generation failed: HTTP {exc.code}") from None
    except (urllib.error.URLError, TimeoutError, ConnectionError) as exc:
        raise InputError(config.url, f"image generation failed: {getattr(exc, 'reason', exc)}") from None
    except (json.JSONDecodeError, KeyError, IndexError, TypeError, ValueError, OSError) as exc:
        raise InputError(config.url, f"image generation answer unusable: {exc!r}") from None
    return OpenState(mask_from_image(image), config.url)
