"""The content-hash file caches of the conversion (CoACD hulls, link shapes, contact resolution).

An entry is ``<root>/<key[:2]>/<key><suffix>``. It is written atomically (a temporary file beside it,
then a rename), so concurrent conversions share one cache and a reader never sees half a file. An
entry that cannot be read (torn by a full disk or an interrupted copy, foreign, of an older layout)
reads as absent: the caller recomputes it and overwrites it.
"""

from __future__ import annotations

import os
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

T = TypeVar("T")

#: What reading a damaged or foreign ``.npz`` raises (a truncated zip is ``BadZipFile``, a truncated
#: member ``EOFError``, a missing array ``KeyError``, a pickled one ``ValueError``).
UNREADABLE = (OSError, ValueError, KeyError, IndexError, TypeError, EOFError, zipfile.BadZipFile)


def entry_path(root: Path | str, key: str, suffix: str = ".npz") -> Path:
    """Where the entry ``key`` of the cache at ``root`` lives."""
    return Path(root) / key[:2] / f"{key}{suffix}"


def _atomic_write(path: Path | str, suffix: str, write: Callable[[str], None]) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=suffix)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_savez(path: Path | str, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez`` to a temporary file beside ``path`` (folders created), then rename."""
    _atomic_write(path, ".tmp.npz", lambda tmp: np.savez(tmp, **arrays))


def atomic_write_text(path: Path | str, text: str) -> None:
    """Write ``text`` to a temporary file beside ``path`` (folders created), then rename."""
    _atomic_write(path, ".tmp", lambda tmp: Path(tmp).write_text(text))


def load_npz(path: Path | str, parse: Callable[[np.lib.npyio.NpzFile], T]) -> T | None:
    """``parse`` applied to the open ``.npz`` at ``path`` (it must copy what it keeps), or None when
    the file is absent or unreadable (see :data:`UNREADABLE`)."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            return parse(data)
    except UNREADABLE:
        return None
