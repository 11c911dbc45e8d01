"""The names of the benchmark's numbers, listed once: the results store's columns, the summary keys of
``eval --json``, the leaderboard's tables and headers, and the units of the metric definitions are all
derived from :data:`HEADLINE` and :data:`UNITS` here.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Units of every number in a metrics result, by metric family (benchmark frame: rest-pose box centered,
#: max extent 2). A family covers its variants: ``cd`` also ``cd_open`` and ``part_cd``, ``fscore`` every
#: ``fscore@t``, ``fscore_open@t`` and ``part_fscore@t``.
UNITS = {
    "cd": "benchmark-frame length (object max extent = 2)",
    "fscore": "fraction in [0, 1]; thresholds in benchmark-frame length",
    "axis_err": "radians in [0, pi/2], sign-free",
    "pivot_err": "benchmark-frame length (object max extent = 2)",
    "type_err": "fraction of ground-truth movable joints in [0, 1]",
}
#: The shape families, scored for the whole object and per matched part (``part_`` prefix).
SHAPE_FAMILIES = ("cd", "fscore")
#: The articulation families, per object: means over its joints.
ARTICULATION_FAMILIES = ("axis_err", "pivot_err", "type_err")
#: The key of the articulation errors averaged over all joints (every joint weighs the same), beside the
#: per-object means: in ``spark-bench metrics --json`` and in ``eval --json``'s ``metrics``.
JOINT_MEAN = "joint_mean"
#: Per-object joint counts that are averaged over objects too.
JOINT_COUNTS = ("n_missing_joints", "n_extra_joints")
#: Prefixes of the per-object scalar keys averaged over objects
#: (:func:`spark_bench.metrics.report.mean_over_objects`).
SCALAR_PREFIXES = (*SHAPE_FAMILIES, *(f"part_{f}" for f in SHAPE_FAMILIES), *ARTICULATION_FAMILIES, *JOINT_COUNTS)


@dataclass(frozen=True)
class Headline:
    """One per-benchmark number of the leaderboard.

    :param key: its key in a metrics result (``MetricsResult.to_dict()``), ``eval --json`` and the leaderboard
    :param label: its table header, without the arrow
    :param higher_is_better: which way is better (the header's arrow, the best / second-best marks)
    :param table: the leaderboard table it belongs to: ``shape``, ``articulation`` or ``sim``
    :param column: its column in the results store (None: a rate, aggregated from the check columns)
    :param summary: part of every run's summary (False: ``cd_open``, the PhysX sim pass and the RL transfer
        rates, added on request)
    """

    key: str
    label: str
    higher_is_better: bool
    table: str
    column: str | None = None
    summary: bool = True


#: Every per-benchmark number, in the leaderboard's CSV order.
HEADLINE = (
    Headline("cd", "CD", False, "shape", "cd"),
    Headline("fscore@0.1", "F-Score@0.1", True, "shape", "fscore_01"),
    Headline("fscore@0.5", "F-Score@0.5", True, "shape", "fscore_05"),
    Headline("cd_open", "CD open", False, "shape", "cd_open", summary=False),
    Headline("axis_err", "AxisErr", False, "articulation", "axis_err"),
    Headline("pivot_err", "PivotErr", False, "articulation", "pivot_err"),
    Headline("type_err", "TypeErr", False, "articulation", "type_err"),
    Headline("sim_pass_rate", "Sim pass", True, "sim"),
    Headline("sim_pass_rate_physx", "Sim pass (PhysX)", True, "sim", summary=False),
    Headline("open_success_rate", "Open success", True, "sim"),
    Headline("open_success_rate_maniskill", "Open success (ManiSkill rule)", True, "sim", summary=False),
    Headline("rl_success_rate", "RL success", True, "sim", summary=False),
    Headline("rl_zero_shot_success_rate", "RL zero-shot", True, "sim", summary=False),
)
BY_KEY = {h.key: h for h in HEADLINE}
#: Every headline key, in :data:`HEADLINE` order.
HEADLINE_KEYS = tuple(h.key for h in HEADLINE)
#: Headline metrics stored as results-store columns of their own: key -> column.
METRIC_COLUMNS = {h.key: h.column for h in HEADLINE if h.column is not None}
#: Whether a larger value is better, per key.
HIGHER_IS_BETTER = {h.key: h.higher_is_better for h in HEADLINE}


def summary_keys(table: str) -> tuple[str, ...]:
    """The keys of ``table`` in every run's summary, in order."""
    return tuple(h.key for h in HEADLINE if h.table == table and h.summary)


SHAPE_KEYS = summary_keys("shape")
ARTICULATION_KEYS = summary_keys("articulation")
RATE_KEYS = summary_keys("sim")
#: The keys of ``eval --json``'s ``metrics``, in order.
SUMMARY_KEYS = (*SHAPE_KEYS, *ARTICULATION_KEYS, *RATE_KEYS)


def header(key: str, up: str = "↑", down: str = "↓") -> str:
    """The table header of ``key``: its label and an arrow saying which way is better."""
    h = BY_KEY[key]
    return h.label + (up if h.higher_is_better else down)


__all__ = ["ARTICULATION_FAMILIES", "ARTICULATION_KEYS", "BY_KEY", "HEADLINE", "HEADLINE_KEYS", "HIGHER_IS_BETTER",
           "JOINT_COUNTS", "JOINT_MEAN", "METRIC_COLUMNS", "RATE_KEYS", "SCALAR_PREFIXES", "SHAPE_FAMILIES", "SHAPE_KEYS",
           "SUMMARY_KEYS", "UNITS", "Headline", "header", "summary_keys"]
