"""The leaderboard as data: its entries (one per method run), its tables with best / second-best ranks,
and how a value is shown. Built from the results store by :mod:`spark_bench.evaluation.leaderboard`, drawn
by it (Markdown, LaTeX, CSV) and by :mod:`spark_bench.evaluation.leaderboard_html`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from spark_bench.convention import CONVENTION_VERSION
from spark_bench.evaluation.aggregate import by_part_class
from spark_bench.metrics.names import (
    ARTICULATION_KEYS,
    BY_KEY,
    COVERAGES,
    HEADLINE_KEYS,
    HIGHER_IS_BETTER,
    RATE_STAGES,
    RATES,
    SHAPE_KEYS,
    Coverage,
    header,
)

#: Regimes listed but not ranked: they see the answer.
REFERENCE_REGIMES = ("ground truth",)
#: Table headers by metric key: the label and an arrow saying which way is better.
HEADERS = {key: header(key) for key in HEADLINE_KEYS}
LATEX_HEADERS = {key: header(key, r"$\uparrow$", r"$\downarrow$") for key in HEADLINE_KEYS}
#: The header of the scale ``--align icp`` applied (:func:`fmt_scale`), shown where any entry was aligned.
SCALE_HEADER = "ICP scale"
#: The paper's colours for best (Palette5) and second best (Palette4).
PALETTE = {"Palette5": (253, 207, 158), "Palette4": (231, 188, 198)}


@dataclass
class Entry:
    """One leaderboard row: a method run (label, variant, regime) and its per-benchmark numbers.

    :param label: the method's display label
    :param variant: ``""`` or the variant name (``w/o joint opt.``)
    :param regime: the input regime
    :param method: registry name
    :param version: method version
    :param config_hash: the run's configuration hash
    :param n_cases: cases in the run
    :param n_failed: failed cases
    :param metrics: per-benchmark numbers (None: n/a)
    :param rows: the run's rows
    :param other_versions: why it is not ranked although its regime is (its rows were made with other releases
        of the packages that can change a verdict than the board's, :func:`mark_version_mismatches`); empty
        when it is comparable
    """

    label: str
    variant: str
    regime: str
    method: str
    version: str
    config_hash: str
    n_cases: int
    n_failed: int
    metrics: dict
    rows: list[dict] = field(default_factory=list, repr=False)
    other_versions: str = ""

    @property
    def name(self) -> str:
        return f"{self.label} ({self.variant})" if self.variant else self.label

    @property
    def ranked(self) -> bool:
        return self.regime not in REFERENCE_REGIMES and not self.other_versions

    @property
    def versions(self) -> set[str]:
        """The package versions its rows recorded (:func:`row_versions`; rows stored before versions were
        recorded say none)."""
        return {v for v in (row_versions(r) for r in self.rows) if v}


@dataclass
class Table:
    """A titled table: its metric keys and one entry per row.

    :param joints: a per-part-class table: its count column is the class's joints (``n_joints`` of each
        entry's metrics), not the run's cases and failures
    """

    key: str
    title: str
    metrics: tuple[str, ...]
    entries: list[Entry]
    joints: bool = False

    @property
    def coverages(self) -> list[Coverage]:
        """The coverages of the table's rates (:attr:`spark_bench.metrics.names.Rate.coverage`), in column order."""
        return [BY_KEY[m].rate.coverage for m in self.metrics if BY_KEY[m].rate and BY_KEY[m].rate.coverage]

    def count_headers(self) -> list[str]:
        """Headers of the count columns after the metrics: the cases and failures (a per-part-class
        table: its joints), and the coverage of each rate that has one (the PhysX cases with a verdict, the
        joints each opening rate covers)."""
        if self.joints:
            return ["Joints"]
        scale = [SCALE_HEADER] if self.aligned else []
        return ["Cases", "Failed", *(c.header for c in self.coverages), *scale]

    def count_cells(self, entry: Entry) -> list[str]:
        """The count cells of ``entry``, see :meth:`count_headers`."""
        if self.joints:
            return [str(entry.metrics.get("n_joints", 0))]
        covered = [fmt_coverage_cell(c, entry.metrics.get(c.key)) for c in self.coverages]
        scale = [fmt_scale(entry.metrics.get("alignment_scale"))] if self.aligned else []
        return [str(entry.n_cases), str(entry.n_failed), *covered, *scale]

    @property
    def aligned(self) -> bool:
        """Whether any entry's predictions were scaled by ``--align icp`` (then a column says by how much)."""
        return any(e.metrics.get("alignment_scale") for e in self.entries)

    def ranks(self) -> dict[tuple[int, str], int]:
        """``{(entry index, metric): 1 or 2}`` for the best and second best ranked values."""
        out = {}
        for metric in self.metrics:
            values = sorted({e.metrics.get(metric) for e in self.entries if e.ranked
                             and is_number(e.metrics.get(metric))}, reverse=HIGHER_IS_BETTER.get(metric, False))
            for rank, value in enumerate(values[:2], 1):
                for i, e in enumerate(self.entries):
                    if e.ranked and e.metrics.get(metric) == value:
                        out[(i, metric)] = rank
        return out


@dataclass
class Leaderboard:
    """Everything the renderers need: the benchmark, its entries, per-category entries.

    :param convention: the metric convention of every row shown
    :param left_out: rows of the benchmark not shown, by the (other) convention they were scored under
    :param versions_note: which entries are not ranked because their package versions differ
        (:func:`mark_version_mismatches`), None when all are comparable
    :param kernels_note: which entries have rows made on other CPU kernels than the pinned ones
        (:func:`unpinned_kernels_note`), None when none has
    """

    bench: str
    entries: list[Entry]
    categories: dict[str, list[Entry]] = field(default_factory=dict)
    convention: str = CONVENTION_VERSION
    left_out: dict[str, int] = field(default_factory=dict)
    versions_note: str | None = None
    kernels_note: str | None = None

    def tables(self, entries: list[Entry] | None = None) -> list[Table]:
        entries = self.entries if entries is None else entries
        return [Table("shape", "Shape reconstruction", SHAPE_KEYS, entries),
                Table("articulation", "URDF parameter estimation", ARTICULATION_KEYS, entries),
                Table("sim", "Sim-readiness", self.rates(entries), entries)]

    def rates(self, entries: list[Entry] | None = None) -> tuple[str, ...]:
        """The sim table's rates for ``entries`` (default: the board's), in :data:`~spark_bench.metrics.names.HEADLINE`
        order: those of every run's summary, and each other one where some entry has it or another rate of its
        stage listed the same way (the RL columns go together; a board of runs without PhysX has no PhysX column)."""
        entries = self.entries if entries is None else entries
        measured = {(h.rate.stage, h.rate.appended) for h in RATES
                    if not h.summary and any(e.metrics.get(h.key) is not None for e in entries)}
        return tuple(h.key for h in RATES if h.summary or (h.rate.stage, h.rate.appended) in measured)

    def has_stage(self, stage: str, entries: list[Entry] | None = None) -> bool:
        """Whether any entry has a rate of ``stage`` (:data:`~spark_bench.metrics.names.RATE_STAGES`) beyond
        those of every run's summary."""
        return any(e.metrics.get(h.key) is not None for e in (self.entries if entries is None else entries)
                   for h in RATES if h.rate.stage == stage and not h.summary)

    def has_rl(self, entries: list[Entry] | None = None) -> bool:
        """Whether any entry has an RL transfer score (``eval --rl``)."""
        return self.has_stage("rl", entries)

    def part_class_tables(self) -> list[Table]:
        """One articulation table per GAPartNet part class found in the rows (``hinge_door``,
        ``slider_drawer``, ...): each entry's AxisErr, PivotErr and TypeErr over the joints of that class
        (:func:`~spark_bench.evaluation.aggregate.by_part_class`); an entry without such joints is left out
        of that class's table. Empty when no ground truth carries GAPartNet annotations."""
        per_entry = [by_part_class(e.rows) for e in self.entries]
        classes = sorted({name for found in per_entry for name in found})
        out = []
        for name in classes:
            entries = [replace(e, metrics=found[name]) for e, found in zip(self.entries, per_entry) if name in found]
            out.append(Table(f"part-{name}", f"URDF parameter estimation: {part_class_title(name)}",
                             ARTICULATION_KEYS, entries, joints=True))
        return out

    def notes(self) -> list[str]:
        """What every rendering says under its tables: how the articulation errors are averaged, what the
        open-success column measures, the metric convention and the rows of other conventions left out."""
        shown = {BY_KEY[key].rate.stage for key in self.rates()}
        notes = [ARTICULATION_NOTE, *(STAGE_NOTES[s] for s in RATE_STAGES if s in shown and s in STAGE_NOTES),
                 f"Metric convention: {self.convention}."]
        if self.left_out:
            scored = ", ".join(f"{n} under {c or 'no convention'}" for c, n in sorted(self.left_out.items()))
            notes.append(f"Not shown: {sum(self.left_out.values())} result rows scored under older metric "
                         f"definitions ({scored}); re-run `spark-bench eval` to score them under {self.convention}.")
        if self.versions_note:
            notes.append(self.versions_note)
        if self.kernels_note:
            notes.append(self.kernels_note)
        return notes


def row_versions(row: dict) -> str:
    """The versions of the packages that can change a verdict a row was made with
    (:data:`spark_bench.versions.VERDICT_PACKAGES`), as one comparable text (``""``: not recorded)."""
    versions = (row.get("info") or {}).get("versions") or {}
    return ", ".join(f"{name} {version}" for name, version in sorted(versions.items()))


def mark_version_mismatches(entries: list[Entry]) -> str | None:
    """Leave unranked the entries made with other package versions than the board's, and say why.

    The board's versions are those of the most entries (ties: the first in order); an entry whose rows
    recorded other versions, or several sets of them, gets ``other_versions`` (it is listed, never marked
    best); entries whose rows recorded none (stored before versions were) are compared with anything.

    :param entries: the board's entries (modified)
    :returns: the note the board prints, or None when every entry is comparable
    """
    counts: dict[str, int] = {}
    for entry in entries:
        if len(entry.versions) == 1:
            key = next(iter(entry.versions))
            counts[key] = counts.get(key, 0) + 1
    if not counts:
        return None
    board = max(counts, key=lambda k: counts[k])
    odd = []
    for entry in entries:
        found = entry.versions
        if found and found != {board}:
            entry.other_versions = "; ".join(sorted(found))
            odd.append(f"{entry.name}: {entry.other_versions}")
    if not odd:
        return None
    return ("Not ranked, made with other releases of the packages that can change a verdict than the rest "
            f"({board}): " + " | ".join(odd) + ". Re-run them with the same install to compare.")


#: What a row's ``cpu kernels`` record starts with when its process ran other kernels than the pinned ones
#: (:data:`spark_bench.kernels.NOT_PINNED`).
NOT_PINNED = "not pinned"


def unpinned_kernels_note(entries: list[Entry]) -> str | None:
    """The note naming the entries with rows made on other CPU kernels than the pinned ones (a process whose
    NumPy loaded before ``spark_bench``), and how many rows: their verdicts may differ on another machine.
    None when every row was pinned (or recorded none).

    :param entries: the board's entries
    """
    found = []
    for entry in entries:
        records = [((r.get("info") or {}).get("versions") or {}).get("cpu kernels", "") for r in entry.rows]
        unpinned = sorted({k for k in records if k.startswith(NOT_PINNED)})
        if unpinned:
            count = sum(k.startswith(NOT_PINNED) for k in records)
            found.append(f"{entry.name}: {count} of {len(records)} rows, {'; '.join(unpinned)}")
    if not found:
        return None
    return ("WARNING: made on other CPU kernels than the pinned ones, so their verdicts may differ on another "
            "machine: " + " | ".join(found) + ". Run them again with `spark-bench eval` (or import spark_bench "
            "before NumPy).")


def part_class_title(name: str) -> str:
    """A GAPartNet part class as a title: ``hinge_door`` -> ``hinge door``."""
    return name.replace("_", " ")


def is_number(value) -> bool:
    """Whether ``value`` is a finite number (not a bool): a value a table shows and ranks."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def fmt_value(value, digits: int = 4) -> str:
    """A metric for a table: ``n/a`` for None, else ``digits`` decimals; a dict of metrics (``joint_mean``)
    as ``key value`` pairs."""
    if isinstance(value, dict):
        return ", ".join(f"{key} {fmt_value(v, digits)}" for key, v in value.items())
    if not is_number(value):
        return "n/a"
    return f"{value:.{digits}f}"


def fmt_coverage(coverage: dict | None) -> str:
    """An opening rate's coverage for a table: ``scored/total`` ground-truth joints, with how many of the scored
    ones the suction cup opened (``69/79 (10 by cup)``), ``n/a`` when the score never ran.

    :param coverage: :func:`spark_bench.evaluation.aggregate.joint_coverage`'s result
    """
    if not coverage:
        return "n/a"
    cup = (coverage.get("scored_by") or {}).get("suction", 0)
    return f"{coverage['joints_scored']}/{coverage['joints_total']}" + (f" ({cup} by cup)" if cup else "")


def fmt_case_coverage(coverage: dict | None) -> str:
    """A rate's coverage in cases for a table (the PhysX sim pass's): ``with_verdict/cases`` (``48/50``), ``n/a``
    for a run without its stage.

    :param coverage: :func:`spark_bench.evaluation.aggregate.case_coverage`'s result
    """
    return f"{coverage['with_verdict']}/{coverage['cases']}" if coverage else "n/a"


def fmt_coverage_cell(declared: Coverage, coverage: dict | None) -> str:
    """A rate's coverage for a table, as its unit shows it (:func:`fmt_coverage`, :func:`fmt_case_coverage`).

    :param declared: the coverage's declaration
    :param coverage: its value in a leaderboard entry's metrics
    """
    return fmt_case_coverage(coverage) if declared.unit == "case" else fmt_coverage(coverage)


def coverage_text(key: str, coverage: dict | None) -> str:
    """A rate's coverage in words, by its key (:data:`~spark_bench.metrics.names.COVERAGES`): the joints an opening
    rate covers (:func:`coverage_line`) or the cases with a value (``48/50 cases with a PhysX verdict``)."""
    declared = COVERAGES[key].rate.coverage
    if declared.unit != "case":
        return coverage_line(coverage)
    return f"{fmt_case_coverage(coverage)} cases with {declared.what}" if coverage else "n/a"


def fmt_scale(scales: dict | None) -> str:
    """The scales ``--align icp`` applied to a run's predictions: ``1.00 (0.90-1.10)``, the median and the
    range over its aligned cases; ``none`` for a run scored without alignment.

    :param scales: :func:`spark_bench.evaluation.aggregate.alignment_scales`'s result
    """
    if not scales:
        return "none"
    if abs(scales["max"] - scales["min"]) < 5e-3:
        return f"{scales['median']:.2f}"
    return f"{scales['median']:.2f} ({scales['min']:.2f}-{scales['max']:.2f})"


def coverage_line(coverage: dict | None) -> str:
    """An opening rate's coverage in words: ``75/79 ground-truth drawer and door joints scored in 50 cases;
    left out: planner 3, stuck 1``.

    :param coverage: :func:`spark_bench.evaluation.aggregate.joint_coverage`'s result
    """
    if not coverage:
        return "n/a"
    text = (f"{coverage['joints_scored']}/{coverage['joints_total']} ground-truth drawer and door joints "
            f"scored in {coverage['cases']} cases")
    cup = (coverage.get("scored_by") or {}).get("suction", 0)
    if cup:
        text += f" ({cup} with the suction cup)"
    kinds = coverage.get("left_out_kinds") or {}
    if kinds:
        text += "; left out: " + ", ".join(f"{kind} {n}" for kind, n in kinds.items())
    return text


#: How the articulation errors are averaged, under every rendering of the tables.
ARTICULATION_NOTE = ("AxisErr, PivotErr and TypeErr are per object (the mean over its joints), then averaged over "
                     "objects; `eval --json` also gives the mean over all joints (`joint_mean`). PivotErr "
                     "(FreeArt3D's rule) scores every matched ground-truth revolute joint, whatever the "
                     "predicted type.")
#: Under the per-part-class tables.
PART_CLASS_NOTE = ("Per GAPartNet part class: AxisErr, PivotErr and TypeErr averaged over the joints of that "
                   "class (every joint weighs the same), for ground truths with GAPartNet annotations "
                   "(link_annotation_gapartnet.json).")
#: What the open-success column measures, under every rendering of the tables.
OPEN_SUCCESS_NOTE = ("Open success: the scripted opener, planned from the predicted joints, opening each "
                     "ground-truth drawer and door at its real size; the joints it cannot open even with the "
                     "ground truth's own are left out, and Open joints says how many were scored of all "
                     "(RL joints likewise for the RL columns). Open success (ManiSkill rule): the same episodes "
                     "judged as ManiSkill3's OpenCabinetDrawer-v1 judges success (75 % of the range and the part "
                     "nearly still, |v| <= 0.1 m/s and |w| <= 1 rad/s), shown where the rows record it.")
#: What the PhysX column measures, under every rendering of tables that show it.
PHYSX_NOTE = ("Sim pass (PhysX): the same sim-readiness checks on the same collision hulls and masses, run in PhysX "
              "(SAPIEN 3 on the CPU) by `eval --engine physx|all`; a failed case counts as not passed, and PhysX "
              "cases says how many of the run's cases have a PhysX verdict. Sim pass is MuJoCo's.")
#: What the RL columns measure, under every rendering of tables that show them.
RL_NOTE = ("RL success: the shipped generalist opening policy (spark_bench.rl.generalist), fine-tuned for a few "
           "thousand steps on the predicted object and told the predicted joint, opening each ground-truth drawer "
           "and door at its real size; the joints the scripted opener cannot open even with the ground truth's own "
           "are left out, as for open success. RL zero-shot: the same without fine-tuning. The oracle's row (the "
           "ground truth as the prediction) is the policy's ceiling.")
#: The note under the tables of a board that shows a rate of the stage (:data:`~spark_bench.metrics.names.RATE_STAGES`),
#: in stage order.
STAGE_NOTES = {"sim": OPEN_SUCCESS_NOTE, "physx": PHYSX_NOTE, "rl": RL_NOTE}
