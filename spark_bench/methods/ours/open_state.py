"""Open-state image backends (stage 3): the supervision of the joint optimization.

- ``dataset``: the case's rendered open state: with the ``open_masks`` input, its object mask (link
  labels > 0) and its per-link masks (label k + 1 for the case's link k); without, the object mask of
  the open image (:func:`mask_from_image` with :data:`RENDER_TOLERANCE`: the benchmark renders on a
  flat backdrop);
- ``http``: an image-generation endpoint that turns the input image into its open state. It receives
  ``POST {url}`` with JSON ``{"model", "prompt", "image": <PNG data URL>, "response_format": "b64_json"}``
  and answers OpenAI's images shape ``{"data": [{"b64_json": "<PNG>"}]}``. The mask is the PNG's alpha
  channel when it has one, otherwise every pixel that differs from the border colour.
"""

from __future__ import annotations

import base64
import io
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from spark_bench.data.images import GENERATED_TOLERANCE, RENDER_TOLERANCE, image_rgb, mask_from_image
from spark_bench.errors import InputError
from spark_bench.methods.ours.remote import image_data_url, post_json, with_retries

if TYPE_CHECKING:
    from spark_bench.methods.base import CaseInput

OPEN_PROMPT = ("The same object, same camera, same lighting, with every movable part (doors, drawers, "
               "lids...) fully open. Plain background.")


@dataclass
class OpenState:
    """The open-state supervision: ``mask`` (H, W) in [0, 1], where it came from, when the source has a
    segmentation, ``part_masks``: the visible mask of each of the case's links (by link name), and when
    it is an image, ``rgb``: (H, W, 3) in [0, 1] (SPARK's recipe takes its own mask of it,
    :func:`spark_bench.methods.ours.spark_fit.spark_mask`) with ``tolerance``, the colour tolerance of its
    backdrop (:func:`mask_from_image`)."""

    mask: np.ndarray
    source: str
    part_masks: dict[str, np.ndarray] = field(default_factory=dict)
    rgb: np.ndarray | None = None
    tolerance: float = GENERATED_TOLERANCE


def dataset_open_state(case: CaseInput, part_masks: bool) -> OpenState:
    """The ``dataset`` backend: the case's rendered open state.

    With ``part_masks``, the open state's link labels (the ``open_masks`` input) give the object mask
    (every labelled pixel) and each link's mask (when the case has no labels: as without). Without, the
    labels are never read: the mask is the open image's object (:func:`mask_from_image`, with the
    tolerance of the benchmark's flat backdrop, :data:`RENDER_TOLERANCE`).

    :param case: the case (:class:`~spark_bench.methods.base.CaseInput`)
    :param part_masks: read the per-link masks (:meth:`SparkConfig.uses_part_masks`)
    :raises PermissionError: when ``case`` lacks an input this needs (``open_masks``, ``open_image``)
    :raises InputError: naming the file when an image is missing or unreadable, or the case's link
        names are malformed
    """
    if part_masks and case.path("open_masks").is_file():
        labels = case.open_labels()
        return OpenState((labels > 0).astype(np.float64), str(case.path("open_masks")), case.open_part_masks())
    image_path = case.open_image
    if not image_path.is_file():
        raise InputError(image_path, "open-state image not found")
    try:
        with Image.open(image_path) as image:
            return OpenState(mask_from_image(image, RENDER_TOLERANCE), str(image_path), rgb=image_rgb(image),
                             tolerance=RENDER_TOLERANCE)
    except OSError as exc:
        raise InputError(image_path, f"unreadable image: {exc}") from None


def http_open_state(config, input_png: bytes) -> OpenState:
    """The ``http`` backend (see the module docstring); ``config`` is an ``OpenStateConfig``.

    The generated image is brought to the input image's size (the camera's) before its mask is taken,
    since the optimization compares it pixel for pixel with renders from the case's camera.

    :raises InputError: naming the endpoint on an HTTP error (HTTP 429/5xx, network errors and timeouts
        after ``config.max_retries`` more attempts), an answer that is not the images JSON, a payload that is not an image, or an image without an object in it
    """
    body = {"model": config.model, "prompt": OPEN_PROMPT, "image": image_data_url(input_png),
            "response_format": "b64_json"}
    raw = with_retries(lambda: post_json(config.url, body, config.api_key_env, config.timeout_s), config.url,
                       config.max_retries, config.backoff_s, "image generation")
    image = decode_image_answer(raw, config.url)
    image = _to_input_size(image, input_png)
    mask = mask_from_image(image)
    if mask.max() <= 0:
        raise InputError(config.url, "the generated open-state image shows no object (empty mask)")
    return OpenState(mask, config.url, rgb=image_rgb(image))


def decode_image_answer(raw: bytes, source) -> Image.Image:
    """The image of an OpenAI images answer ``{"data": [{"b64_json": ...}]}``.

    :raises InputError: naming ``source`` when the answer is not that JSON or the payload is no image
    """
    try:
        payload = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(source, f"image generation answer is not JSON: {exc}") from None
    try:
        encoded = payload["data"][0]["b64_json"]
    except (KeyError, IndexError, TypeError):
        raise InputError(source, 'image generation answer has no data[0].b64_json') from None
    try:
        png = base64.b64decode(encoded, validate=True)
    except (ValueError, TypeError):
        raise InputError(source, "image generation answer's b64_json is not base64") from None
    try:
        image = Image.open(io.BytesIO(png))
        image.load()
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        raise InputError(source, f"image generation answer's payload is not an image ({len(png)} bytes): "
                                 f"{type(exc).__name__}") from None
    return image


def _to_input_size(image: Image.Image, input_png: bytes) -> Image.Image:
    """``image`` resized to the input image's size (a no-op when they agree or the input is unreadable)."""
    try:
        with Image.open(io.BytesIO(input_png)) as source:
            size = source.size
    except OSError:
        return image
    if image.size == size:
        return image
    mode = "RGBA" if image.mode in ("RGBA", "LA", "P") else "RGB"
    return image.convert(mode).resize(size, Image.Resampling.BILINEAR)
