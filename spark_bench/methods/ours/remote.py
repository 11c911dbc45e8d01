"""JSON over HTTP for the remote backends (the VLM, the image generator): one POST, and retries.

Standard library only (``urllib``). HTTP 429 and 5xx answers, network errors and timeouts are worth
another attempt (:class:`Retryable`); any other HTTP error is the request's fault and ends at once.
"""

from __future__ import annotations

import base64
import json
import os
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from typing import TypeVar

from spark_bench.errors import InputError

T = TypeVar("T")


class Retryable(Exception):
    """A failure worth another attempt; its text says what went wrong."""


def image_data_url(png: bytes) -> str:
    """A PNG as a ``data:image/png;base64,...`` URL, as OpenAI-style APIs take images."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def post_json(url: str, body: dict, api_key_env: str | None, timeout_s: float) -> bytes:
    """POST ``body`` as JSON (Bearer token from the ``api_key_env`` variable when it is set); the raw
    answer.

    :raises Retryable: on HTTP 429/5xx, a network error or no answer within ``timeout_s``
    :raises InputError: naming ``url`` on any other HTTP error
    """
    headers = {"Content-Type": "application/json"}
    key = os.environ.get(api_key_env) if api_key_env else None
    if key:
        headers["Authorization"] = f"Bearer {key}"
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers=headers, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=timeout_s) as response:
            return response.read()
    except urllib.error.HTTPError as exc:
        detail = " ".join(exc.read()[:200].decode(errors="replace").split())
        message = f"HTTP {exc.code}" + (f": {detail}" if detail else "")
        if exc.code == 429 or exc.code >= 500:
            raise Retryable(message) from None
        raise InputError(url, message) from None
    except (urllib.error.URLError, TimeoutError, ConnectionError) as exc:
        reason = getattr(exc, "reason", exc)
        if isinstance(reason, TimeoutError) or isinstance(exc, TimeoutError):
            reason = f"no answer within {timeout_s:g} s"
        raise Retryable(f"network error: {reason}") from None


def with_retries(attempt: Callable[[], T], url: str, max_retries: int, backoff_s: float, what: str,
                 sleep: Callable[[float], None] = time.sleep) -> T:
    """``attempt()``, tried again after each :class:`Retryable` with exponential backoff.

    :param attempt: one try; raises :class:`Retryable` when another is worth it
    :param url: the endpoint, named in the error
    :param max_retries: attempts after the first
    :param backoff_s: first delay, doubled each time
    :param what: what was asked for, for the error (e.g. ``"image generation"``)
    :raises InputError: naming ``url`` after ``1 + max_retries`` failed attempts, with the last reason
    """
    attempts = 1 + max(0, int(max_retries))
    problem = ""
    for k in range(attempts):
        if k:
            sleep(backoff_s * 2 ** (k - 1))
        try:
            return attempt()
        except Retryable as exc:
            problem = str(exc)
    tries = "" if attempts == 1 else f" after {attempts} attempts"
    raise InputError(url, f"{what} failed{tries}: {problem}")
