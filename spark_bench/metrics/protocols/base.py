"""What a metric protocol is: one paper's way of scoring a prediction against its ground truth.

A protocol module (one per paper, :data:`spark_bench.metrics.protocols.PROTOCOLS`) defines

- ``INFO``: a :class:`ProtocolInfo` (the paper, the files of its code each fact comes from, the metrics it
  reports with their units, its table's columns in the paper's order, what differs from spark-bench's own
  convention);
- ``score(pred, gt, seed=0) -> ProtocolResult``: that paper's metrics computed as its code computes them
  (its frame, normalization, alignment, sample counts, thresholds, matching, aggregation).

``pred`` and ``gt`` are :class:`~spark_bench.asset.model.ArticulatedAsset` objects as loaded
(:func:`spark_bench.data.load_object`), each in its own world frame: a protocol applies its paper's own
normalization to both and never relies on spark-bench's benchmark frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class ProtocolInfo:
    """A paper's metric protocol, described.

    :param name: the protocol's command-line name (``freeart3d``, ``articulate-anything``...)
    :param paper: the paper's short citation
    :param source: where the facts come from: repository, commit and files of the paper's evaluation code
    :param units: ``{metric: unit}`` for every metric :func:`score` reports (``rad``, ``deg``, ``unit cube``,
        ``fraction``...)
    :param columns: ``((metric, column header), ...)`` in the order and with the headers of the paper's table
    :param differs: one paragraph: what differs from spark-bench's own convention (the leaderboard's footnote)
    :param deterministic: whether the paper's code gives the same numbers on every CPU run (no random
        sampling left unseeded, no ICP on random starts, no CUDA-only code)
    """

    name: str
    paper: str
    source: str
    units: dict[str, str]
    columns: tuple[tuple[str, str], ...]
    differs: str
    deterministic: bool = True


@dataclass
class ProtocolResult:
    """One prediction scored under one protocol.

    :param protocol: the protocol's name
    :param metrics: ``{metric: value}`` under the paper's own metric names, plus ``joint_success_rate``
        wherever the paper defines a joint success and ``axis_err`` / ``pivot_err`` where it defines them (in
        its units, :attr:`units`); None where the paper's code gives no number (NaN in its code)
    :param units: ``{metric: unit}`` of every entry of ``metrics``
    :param notes: what a reader must know about this score (joints left unmatched, a fallback taken)
    """

    protocol: str
    metrics: dict[str, float | None]
    units: dict[str, str]
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """``{"protocol", "metrics", "units", "notes"}``, JSON-ready."""
        return {"protocol": self.protocol, "metrics": dict(self.metrics), "units": dict(self.units),
                "notes": list(self.notes)}
