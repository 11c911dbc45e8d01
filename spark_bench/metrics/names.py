"""The names of the benchmark's numbers, listed once: the results store's columns, the summary keys of
``eval --json``, the leaderboard's tables and headers, and the units of the metric definitions are all
derived from :data:`HEADLINE` and :data:`UNITS` here. So are the sim table's rates: where each reads its value
for one case (a row's column or its ``checks``), which stage makes it, its coverage and where it appears
(:class:`Rate`); a new rate is one entry of :data:`HEADLINE`, beside the code that records its case value.
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


#: The stages that make the sim table's rates (:attr:`Rate.stage`), in the order a run's summary lists their later
#: numbers and the leaderboard its notes: ``sim`` (eval's sim stage: MuJoCo's checks and the scripted opener),
#: ``physx`` (the PhysX checks, ``eval --engine physx|all``, within the sim stage) and ``rl`` (``eval --rl``).
RATE_STAGES = ("sim", "physx", "rl")


@dataclass(frozen=True)
class Coverage:
    """How much of a run a sim-table rate covers: a key of the run's summary beside the rate, and the leaderboard's
    count column beside its column.

    :param key: its key in the summary (``eval --json``) and in a leaderboard entry's metrics
    :param header: its count column's header on the leaderboard
    :param unit: what it counts: ``joint``, the ground-truth drawer and door joints the rate's stage scored of all
        (:func:`spark_bench.evaluation.aggregate.joint_coverage` of the rate's ``check``; ``74/79 (14 by cup)``), or
        ``case``, the run's cases with a value of the rate (:func:`spark_bench.evaluation.aggregate.case_coverage`;
        ``48/50``, and said in the LaTeX caption: its tables have no count columns)
    :param what: a ``case`` coverage: what each case it counts has, in words (``a PhysX verdict``)
    """

    key: str
    header: str
    unit: str = "joint"
    what: str = ""


@dataclass(frozen=True)
class Rate:
    """Where a sim-table rate's value for one case comes from, and how the run's rate is made of them.

    The run's rate is the mean of its case values over the cases where its stage gave one, a failed case counting
    as not passed (0); None where the stage never ran (:func:`spark_bench.evaluation.aggregate.run_rate`). Where it
    appears: a rate of every run's summary (:attr:`Headline.summary`) is in every summary (None where its stage
    did not run), leaderboard and CSV; any other only where its stage was asked or measured (``appended`` says
    where).

    :param stage: the stage that makes it, one of :data:`RATE_STAGES`
    :param check: the key of a result row's ``checks`` under which the stage records its result
    :param result: the key of the case's value in that result
    :param kind: ``pass`` (a verdict on the prediction, True or False: an exception in its stage is a fail) or
        ``fraction`` (over the case's scored joints, None where it has none: an exception in its stage, which acts
        on the ground truth, gives none)
    :param column: the results-store column that holds a copy of the case's value (``eval`` copies it there) and
        that the rate is read from; None: read from ``checks`` (a new rate: the store's columns stay as they are)
    :param coverage: the count shown beside it (None: none of its own)
    :param appended: listed in the summary after the other numbers (``cd_open``, ``alignment_scale``), written in
        the leaderboard's CSV always (n/a where not measured): the layout of the ManiSkill and RL rates. False (a
        new rate): in the summary at its place among the rates, and in the CSV only where some entry has it, so the
        outputs of runs without it stay as they were
    """

    stage: str
    check: str
    result: str
    kind: str = "fraction"
    column: str | None = None
    coverage: Coverage | None = None
    appended: bool = False

    def from_checks(self, checks: dict | None):
        """The case's value in a result row's ``checks`` (None where the stage did not run or recorded none)."""
        return ((checks or {}).get(self.check) or {}).get(self.result)

    def of_row(self, row: dict):
        """The case's value of a result row: its ``column`` where the rate has one, else from its ``checks``."""
        return row.get(self.column) if self.column else self.from_checks(row.get("checks"))


@dataclass(frozen=True)
class Headline:
    """One per-benchmark number of the leaderboard.

    :param key: its key in a metrics result (``MetricsResult.to_dict()``), ``eval --json`` and the leaderboard
    :param label: its table header, without the arrow
    :param higher_is_better: which way is better (the header's arrow, the best / second-best marks)
    :param table: the leaderboard table it belongs to: ``shape``, ``articulation`` or ``sim``
    :param column: its column in the results store (None: a rate, whose case values ``rate`` says where to find)
    :param summary: part of every run's summary (False: ``cd_open``, the PhysX sim pass, the ManiSkill rule and
        the RL transfer rates, there where asked for or measured)
    :param rate: a rate of the sim table: where its case values come from, how they aggregate, its coverage
    """

    key: str
    label: str
    higher_is_better: bool
    table: str
    column: str | None = None
    summary: bool = True
    rate: Rate | None = None


#: Every per-benchmark number, in the leaderboard's CSV order.
HEADLINE = (
    Headline("cd", "CD", False, "shape", "cd"),
    Headline("fscore@0.1", "F-Score@0.1", True, "shape", "fscore_01"),
    Headline("fscore@0.5", "F-Score@0.5", True, "shape", "fscore_05"),
    Headline("cd_open", "CD open", False, "shape", "cd_open", summary=False),
    Headline("axis_err", "AxisErr", False, "articulation", "axis_err"),
    Headline("pivot_err", "PivotErr", False, "articulation", "pivot_err"),
    Headline("type_err", "TypeErr", False, "articulation", "type_err"),
    # MuJoCo's checks (spark_bench.sim), checks["sim"]
    Headline("sim_pass_rate", "Sim pass", True, "sim",
             rate=Rate("sim", "sim", "passed", "pass", column="sim_pass")),
    # the same checks in PhysX (spark_bench.sim.physx), checks["sim_physx"]; where no SAPIEN, no verdict
    Headline("sim_pass_rate_physx", "Sim pass (PhysX)", True, "sim", summary=False,
             rate=Rate("physx", "sim_physx", "passed", "pass",
                       coverage=Coverage("physx_coverage", "PhysX cases", "case", "a PhysX verdict"))),
    # the scripted opener (spark_bench.opening.judge), checks["open"]
    Headline("open_success_rate", "Open success", True, "sim",
             rate=Rate("sim", "open", "success_rate", column="open_success",
                       coverage=Coverage("open_coverage", "Open joints"))),
    # the same episodes under ManiSkill3's success rule (docs/protocols.md), over the same joints
    Headline("open_success_rate_maniskill", "Open success (ManiSkill rule)", True, "sim", summary=False,
             rate=Rate("sim", "open", "success_rate_maniskill", appended=True)),
    # the RL transfer score (spark_bench.rl.transfer), checks["rl"]: fine-tuned, then zero-shot
    Headline("rl_success_rate", "RL success", True, "sim", summary=False,
             rate=Rate("rl", "rl", "success_rate", column="rl_success", coverage=Coverage("rl_coverage", "RL joints"),
                       appended=True)),
    Headline("rl_zero_shot_success_rate", "RL zero-shot", True, "sim", summary=False,
             rate=Rate("rl", "rl", "zero_shot_success_rate", appended=True)),
)
BY_KEY = {h.key: h for h in HEADLINE}
#: Every headline key, in :data:`HEADLINE` order.
HEADLINE_KEYS = tuple(h.key for h in HEADLINE)
#: Headline metrics stored as results-store columns of their own: key -> column.
METRIC_COLUMNS = {h.key: h.column for h in HEADLINE if h.column is not None}
#: Whether a larger value is better, per key.
HIGHER_IS_BETTER = {h.key: h.higher_is_better for h in HEADLINE}
#: The sim table's rates (the headline numbers with a :class:`Rate`), in :data:`HEADLINE` order.
RATES = tuple(h for h in HEADLINE if h.rate is not None)
#: The results-store columns that hold a copy of a rate's case value: column -> the rate's key.
RATE_COLUMNS = {h.rate.column: h.key for h in RATES if h.rate.column}
#: The rate beside each coverage: coverage key -> the rate's headline.
COVERAGES = {h.rate.coverage.key: h for h in RATES if h.rate.coverage}


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


__all__ = ["ARTICULATION_FAMILIES", "ARTICULATION_KEYS", "BY_KEY", "COVERAGES", "HEADLINE", "HEADLINE_KEYS",
           "HIGHER_IS_BETTER", "JOINT_COUNTS", "JOINT_MEAN", "METRIC_COLUMNS", "RATES", "RATE_COLUMNS", "RATE_KEYS",
           "RATE_STAGES", "SCALAR_PREFIXES", "SHAPE_FAMILIES", "SHAPE_KEYS", "SUMMARY_KEYS", "UNITS", "Coverage",
           "Headline", "Rate", "header", "summary_keys"]
