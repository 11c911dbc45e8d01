"""Edits of files a test wrote, to make them wrong in one known way: a piece of text replaced (a URDF, an
MJCF model), or a JSON document changed in place (a run's joint file)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def edit_text(path: Path, old: str, new: str, count: int = 1) -> Path:
    """Replace ``old`` by ``new`` in the text file ``path``, after checking that ``old`` is there (an edit
    that changes nothing would leave the test testing the unedited file).

    :param path: the file
    :param old: the text to replace
    :param new: what replaces it
    :param count: how many occurrences to replace, first first (-1: every one)
    :returns: ``path``
    """
    text = path.read_text()
    assert old in text, (path, old)
    path.write_text(text.replace(old, new, count))
    return path


def edit_json(path: Path, change: Callable[[object], object], part: str | None = None,
              indent: int | None = None) -> Path:
    """Read the JSON document ``path``, let ``change`` edit it (or its member ``part``) in place, write it
    back.

    :param path: the JSON file
    :param change: called with the document (or ``document[part]``); its return value is ignored
    :param part: the top-level member ``change`` is given (None: the whole document)
    :param indent: the indentation the file is written back with (None: one line, as ``json.dumps``)
    :returns: ``path``
    """
    document = json.loads(path.read_text())
    change(document if part is None else document[part])
    path.write_text(json.dumps(document, indent=indent))
    return path
