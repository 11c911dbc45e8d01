"""What every foreign format's tests check of a refused run: one ``InputError``, one line, naming the file."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from spark_bench.errors import InputError


def refused(read_run: Callable[[Path], object], run: Path, *words: str, file: str | None = None) -> InputError:
    """The :class:`InputError` ``read_run(run)`` raises, after checking that its message is one line holding
    every one of ``words`` and, with ``file``, that it names a path ending so.

    :param read_run: the format's reader
    :param run: the run folder
    :param words: what the message must say
    :param file: the end of the path the error must name (None: not checked)
    """
    with pytest.raises(InputError) as info:
        read_run(run)
    message = str(info.value)
    assert "\n" not in message and all(w in message for w in words), message
    if file is not None:
        assert str(info.value.path).endswith(file), message
    return info.value
