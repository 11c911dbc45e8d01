"""The one JSON writer of the package: NumPy values, paths and dataclasses made plain.

Reading JSON files (with errors that name the file) is :func:`spark_bench.data.readers.read_json`.
"""

from __future__ import annotations

import json
from pathlib import PurePath

import numpy as np


def json_default(value):
    """``json.dumps`` fallback: NumPy scalars and arrays, paths; anything else as ``str``."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, PurePath):
        return str(value)
    return str(value)


def to_json_text(value, indent: int | None = None, sort_keys: bool = False) -> str:
    """``json.dumps(value)`` with :func:`json_default`."""
    return json.dumps(value, indent=indent, sort_keys=sort_keys, default=json_default)


def plain(value):
    """``value`` as plain JSON data (dicts, lists, numbers, strings), through :func:`json_default`."""
    return json.loads(to_json_text(value))
