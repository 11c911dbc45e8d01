"""Names made unique within a set: one rule for the readers (MJCF, USD) and the USD export."""

from __future__ import annotations


def unique_name(name: str, used: set[str], first: int = 2) -> str:
    """``name``, or ``name_<first>``, ``name_<first + 1>``... where ``used`` already holds it; added to ``used``.

    :param first: the first number tried
    """
    out, k = name, first
    while out in used:
        out, k = f"{name}_{k}", k + 1
    used.add(out)
    return out
