"""Every paper's yardstick: the same prediction scored as each paper of the field scores it.

One module per protocol (like :mod:`spark_bench.formats`), each with ``INFO`` and ``score`` as
:mod:`spark_bench.metrics.protocols.base` describes; a new protocol is one module and one line of
:data:`PROTOCOLS`. :func:`protocol_names` resolves command-line names (``all``), :func:`score` and
:func:`score_all` score one prediction; :mod:`spark_bench.metrics.protocols.tables` makes each paper's table.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from spark_bench.errors import SparkBenchError

#: ``{command-line name: module}``.
PROTOCOLS: dict[str, str] = {
    "spark": "spark_bench.metrics.protocols.spark",
    "articulate-anything": "spark_bench.metrics.protocols.articulate_anything",
    "urdf-anything": "spark_bench.metrics.protocols.urdf_anything",
    "real2code": "spark_bench.metrics.protocols.real2code",
    "freeart3d": "spark_bench.metrics.protocols.freeart3d",
    "partcrafter": "spark_bench.metrics.protocols.partcrafter",
    "singapo": "spark_bench.metrics.protocols.singapo",
    "cage": "spark_bench.metrics.protocols.cage",
}


def protocol_module(name: str) -> ModuleType:
    """The module of protocol ``name``.

    :param name: a key of :data:`PROTOCOLS`
    :raises SparkBenchError: an unknown name (the message lists the known ones)
    """
    if name not in PROTOCOLS:
        raise SparkBenchError(f"unknown protocol {name!r}; known: all, {', '.join(sorted(PROTOCOLS))}")
    try:
        return importlib.import_module(PROTOCOLS[name])
    except ModuleNotFoundError as exc:
        if exc.name != PROTOCOLS[name]:
            raise
        raise SparkBenchError(f"protocol {name!r} is not part of this build ({PROTOCOLS[name]} is missing)") from None


def protocol_names(requested: list[str] | tuple[str, ...]) -> list[str]:
    """The protocols ``requested`` names, in the order given, ``all`` meaning every protocol of
    :data:`PROTOCOLS` (in its order), each once.

    :param requested: command-line names and/or ``all``
    :raises SparkBenchError: an unknown name (the message lists the known ones)
    """
    out: list[str] = []
    for name in requested:
        for one in (PROTOCOLS if name == "all" else [name]):
            if one not in PROTOCOLS:
                raise SparkBenchError(f"unknown protocol {one!r}; known: all, {', '.join(sorted(PROTOCOLS))}")
            if one not in out:
                out.append(one)
    return out


def score(name: str, pred, gt, seed: int = 0):
    """``pred`` scored against ``gt`` under protocol ``name``: a
    :class:`~spark_bench.metrics.protocols.base.ProtocolResult`.

    :param name: a key of :data:`PROTOCOLS`
    :param pred: the prediction, an :class:`~spark_bench.asset.model.ArticulatedAsset` as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed
    """
    result = protocol_module(name).score(pred, gt, seed=seed)
    if result.protocol != name:
        raise SparkBenchError(f"protocol module {PROTOCOLS[name]} reported {result.protocol!r}, not {name!r}")
    return result


def score_all(names: list[str] | tuple[str, ...], pred, gt, seed: int = 0) -> list:
    """``pred`` against ``gt`` under each protocol of ``names`` (``all`` allowed), in that order.

    :param names: protocol names (see :func:`protocol_names`)
    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed
    """
    return [score(name, pred, gt, seed) for name in protocol_names(names)]
