"""The ``v``/``f`` lines of an OBJ file as bytes, fast for remeshed parts.

The text is exactly that of ``"v %.9g %.9g %.9g\\n"`` per vertex and ``"f %d %d %d\\n"`` per face (1-based).
An R=200 watertight remesh has 10^5-10^6 vertices whose coordinates take a few hundred distinct values per
axis (grid points, normalized), so each distinct number is formatted once and the lines are assembled by
array operations: about half the CPU of formatting every number (``benchmarks/measure_prepare_speed.py``
counts it in ``normalize_write``). Where most numbers are distinct, the plain formatting is used.
"""

from __future__ import annotations

import numpy as np

#: The table path is taken when the distinct numbers are at most this share of all numbers; above it,
#: formatting each distinct number costs about what formatting every number does, and the gather is extra.
DISTINCT_SHARE = 0.25


def _token_table(values, fmt: str) -> np.ndarray:
    """Each value formatted once, as a fixed-width byte-string array (numpy pads with NUL)."""
    return np.array([fmt % x for x in values], dtype="S")


def _rows(prefix: bytes, tables: list[np.ndarray], indices: np.ndarray) -> bytes:
    """Lines ``prefix t0 t1 t2\\n`` with ``tc = tables[c][indices[:, c]]``.

    Every token is written at its column's full width into one (N, width) byte array, the NUL padding
    is dropped at the end: the tokens themselves never contain NUL.
    """
    n = len(indices)
    widths = [table.dtype.itemsize for table in tables]
    buffer = np.zeros((n, len(prefix) + sum(w + 1 for w in widths)), dtype=np.uint8)
    buffer[:, :len(prefix)] = np.frombuffer(prefix, np.uint8)
    at = len(prefix)
    for column, (table, width) in enumerate(zip(tables, widths)):
        buffer[:, at:at + width] = table[indices[:, column]].view(np.uint8).reshape(n, width)
        buffer[:, at + width] = ord("\n") if column == len(tables) - 1 else ord(" ")
        at += width + 1
    return buffer[buffer != 0].tobytes()


def vertex_lines(vertices: np.ndarray) -> bytes:
    """``v x y z`` lines (``%.9g``) of (N, 3) ``vertices``.

    :param vertices: (N, 3) float coordinates
    """
    vertices = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(vertices) == 0:
        return b""
    # distinct by bit pattern, so -0.0 and 0.0 (equal as floats, "-0" and "0" as text) stay apart
    distinct = [np.unique(np.ascontiguousarray(vertices[:, c]).view(np.uint64), return_inverse=True)
                for c in range(3)]
    if sum(len(values) for values, _ in distinct) > DISTINCT_SHARE * vertices.size:
        return (("v %.9g %.9g %.9g\n" * len(vertices)) % tuple(vertices.ravel().tolist())).encode()
    tables = [_token_table(values.view(np.float64).tolist(), "%.9g") for values, _ in distinct]
    return _rows(b"v ", tables, np.stack([inverse.reshape(-1) for _, inverse in distinct], axis=1))


def face_lines(faces: np.ndarray) -> bytes:
    """``f a b c`` lines of (F, 3) 0-based ``faces``, written 1-based.

    :param faces: (F, 3) non-negative integer vertex indices
    """
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0:
        return b""
    if faces.min() < 0:
        raise ValueError("faces: a negative vertex index")
    largest = int(faces.max()) + 1
    if largest > DISTINCT_SHARE * faces.size:  # a table as long as the text itself saves nothing
        return (("f %d %d %d\n" * len(faces)) % tuple((faces + 1).ravel().tolist())).encode()
    return _rows(b"f ", [_token_table(range(1, largest + 1), "%d")] * 3, faces)
