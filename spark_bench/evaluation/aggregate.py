"""Per-benchmark numbers from per-case result rows (shared by ``eval --json`` and the leaderboard).

- Shape metrics (CD, F-Scores): mean over the ``ok`` cases whose shape metrics are valid; None (shown
  as n/a) when no case has valid shape metrics (a method that reuses the ground-truth geometry).
- Articulation metrics: mean over the ``ok`` cases that have the value (not a shape-only prediction's) (docs/conventions.md: mean over joints
  per object, then over objects); ``joint_mean`` beside them: ``axis_err``, ``pivot_err``, ``type_err``
  averaged over every joint of the ``ok`` cases (from each row's stored per-joint errors).
- Rates (the sim table, declared in :data:`spark_bench.metrics.names.RATES`: sim pass in MuJoCo and in PhysX,
  scripted opening and its ManiSkill rule, RL transfer): over every case of the run where the stage gave a
  value, a failed case counting as not passed; None when the stage never ran (:func:`run_rate`). Beside a rate
  with a coverage, its coverage: for the opening rates (``open_coverage``, ``rl_coverage``: :func:`joint_coverage`)
  the ground-truth drawer and door joints scored out of all of them, and what left the others out (an opening
  score's case value is itself over the case's scored joints, :mod:`spark_bench.opening.judge`: a case whose
  every drawer and door is left out gives none); for the PhysX sim pass (``physx_coverage``:
  :func:`case_coverage`) the cases with a PhysX verdict. Rows of runs without PhysX have neither.

Rows scored under different metric conventions (the ``convention`` column) are never averaged together.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence

from spark_bench.errors import SparkBenchError
from spark_bench.metrics.align import similarity_scale
from spark_bench.metrics.names import (
    ARTICULATION_KEYS,
    JOINT_MEAN,
    METRIC_COLUMNS,
    RATE_STAGES,
    RATES,
    SHAPE_KEYS,
    Headline,
    Rate,
)
from spark_bench.metrics.report import joint_errors, mean_by_part_class, mean_over_joints

# The keys (SUMMARY_KEYS: SHAPE_KEYS, ARTICULATION_KEYS, RATE_KEYS) and which way each is better are
# listed in spark_bench.metrics.names.


def _mean(values: Iterable[float | None]) -> float | None:
    kept = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    return sum(kept) / len(kept) if kept else None


def _value(row: dict, key: str):
    column = METRIC_COLUMNS[key]
    value = row.get(column)
    return value if value is not None else row.get("metrics", {}).get(key)


def run_rate(rows: Sequence[dict], rate: Rate) -> float | None:
    """A run's rate: the mean of the case values (:meth:`Rate.of_row <spark_bench.metrics.names.Rate.of_row>`)
    over the rows where its stage gave one, a failed case counting as 0; None when the stage gave one nowhere.

    :param rows: result rows of one run and variant
    :param rate: the rate's declaration
    """
    counted = [r for r in rows if r["status"] == "failed" or rate.of_row(r) is not None]
    if not any(rate.of_row(r) is not None for r in rows):
        return None
    return sum(float(rate.of_row(r)) for r in counted if r["status"] == "ok") / len(counted)


def joint_coverage(rows: Sequence[dict], check: str) -> dict | None:
    """How many ground-truth drawer and door joints an opening score covers over a run: ``{"joints_scored",
    "joints_total", "left_out_kinds": {kind: count}, "scored_by": {end-effector: count}, "cases"}`` summed over the ``ok`` rows where the stage
    ran (``cases``: how many); None when it ran nowhere. Read from each case's per-joint rows (a joint left
    out has ``success`` None; its kind is ``left_out_kind``, ``unknown`` in rows stored before kinds were
    recorded), so older rows count too.

    :param rows: result rows of one run and variant
    :param check: ``open`` (the scripted opening score) or ``rl`` (the RL transfer score)
    """
    results = [(r.get("checks") or {}).get(check) for r in rows if r["status"] == "ok"]
    results = [c for c in results if c and isinstance(c.get("joints"), dict)]
    if not results:
        return None
    scored = total = 0
    kinds: dict[str, int] = {}
    scored_by: dict[str, int] = {}
    for result in results:
        for joint in result["joints"].values():
            total += 1
            if joint.get("success") is None:
                kind = joint.get("left_out_kind") or "unknown"
                kinds[kind] = kinds.get(kind, 0) + 1
            else:
                scored += 1
                effector = joint.get("end_effector") or "gripper"  # rows from before the cup: the gripper
                scored_by[effector] = scored_by.get(effector, 0) + 1
    return {"joints_scored": scored, "joints_total": total, "left_out_kinds": dict(sorted(kinds.items())),
            "scored_by": dict(sorted(scored_by.items())), "cases": len(results)}


def case_coverage(rows: Sequence[dict], rate: Rate) -> dict | None:
    """How many cases of a run have a value of ``rate`` (the PhysX sim pass: a PhysX verdict):
    ``{"with_verdict", "cases"}``, ``cases`` every row of the run (a failed case has none; nor has a case whose
    worker could not run the stage, ``skipped``: no SAPIEN); None when no row has one (a run without the stage,
    ``--engine physx|all``, or rows stored before it).

    :param rows: result rows of one run and variant
    :param rate: the rate's declaration
    """
    counted = sum(r["status"] == "ok" and rate.of_row(r) is not None for r in rows)
    return {"with_verdict": counted, "cases": len(rows)} if counted else None


def rate_coverage(rows: Sequence[dict], rate: Rate) -> dict | None:
    """The coverage of ``rate`` over a run (its :class:`~spark_bench.metrics.names.Coverage`'s unit says which):
    :func:`joint_coverage` of its check or :func:`case_coverage`."""
    if rate.coverage.unit == "case":
        return case_coverage(rows, rate)
    return joint_coverage(rows, rate.check)


def alignment_scales(rows: Sequence[dict]) -> dict | None:
    """The scales ``--align icp`` applied to a run's predictions before scoring them (a foreign method's
    output comes in a unit box or its own units: the errors hold only at that scale): ``{"median", "min",
    "max", "cases"}`` over the ``ok`` rows that were aligned; None when none was. Read from each row's stored
    alignment matrix, so rows stored before the scale was recorded count too.

    :param rows: result rows of one run and variant
    """
    scales = sorted(similarity_scale(m["alignment"]) for m in ((r.get("metrics") or {}) for r in rows
                                                               if r["status"] == "ok")
                    if m.get("align", "none") != "none" and m.get("alignment") is not None)
    if not scales:
        return None
    return {"median": statistics.median(scales), "min": scales[0], "max": scales[-1], "cases": len(scales)}


def check_convention(rows: Sequence[dict]) -> str:
    """The one metric convention of ``rows`` (``""`` for rows that name none).

    :param rows: result rows

    :raises SparkBenchError: when the rows were scored under several conventions
    """
    found = sorted({str(r.get("convention") or "") for r in rows})
    if len(found) > 1:
        raise SparkBenchError(f"result rows scored under different metric conventions "
                              f"({', '.join(c or '(none)' for c in found)}) cannot be averaged together; "
                              "re-run `spark-bench eval` to score every case under the current one")
    return found[0] if found else ""


def joint_records(rows: Sequence[dict]) -> list[dict]:
    """The per-joint errors (:func:`~spark_bench.metrics.report.joint_errors`) of the ``ok`` rows.

    :param rows: result rows (their ``metrics`` JSON holds ``matching`` and ``missing_joints``)
    """
    return [record for r in rows if r["status"] == "ok" and articulation_valid(r)
            for record in joint_errors(r.get("metrics") or {})]


def articulation_valid(row: dict) -> bool:
    """Whether a row's articulation errors mean anything (not a shape-only prediction, which has no joints)."""
    return (row.get("metrics") or {}).get("articulation_metrics_valid", True) is not False


def by_part_class(rows: Sequence[dict]) -> dict[str, dict]:
    """AxisErr, PivotErr, TypeErr and ``n_joints`` per GAPartNet part class over the joints of the ``ok``
    rows (joints of ground truths without GAPartNet annotations are left out).

    :param rows: result rows of one run and variant, all of one metric convention
    """
    check_convention(rows)
    return mean_by_part_class(joint_records(rows))


def summarize(rows: Sequence[dict], sim: bool = True, extra: Sequence[str] = (), rl: bool = False,
              physx: bool = False) -> dict:
    """The per-benchmark metrics of one run's rows (one variant), keys
    :data:`~spark_bench.metrics.names.SUMMARY_KEYS` (+ ``extra``, + the rates of the stages asked for), then
    :data:`JOINT_MEAN`. The rates (:data:`~spark_bench.metrics.names.RATES`, :func:`rates`) and their coverages
    are those of the stages asked for: ``sim`` (the ManiSkill rule, None for rows stored before it was recorded,
    and ``open_coverage``), ``physx`` (the PhysX sim pass and ``physx_coverage``) and ``rl`` (the RL transfer
    rates and ``rl_coverage``); where the predictions were aligned (``--align icp``), ``alignment_scale``
    (:func:`alignment_scales`).

    :param rows: result rows of one run and variant (ok and failed), all of one metric convention
    :param sim: whether the sim stages were asked for (False: the rates of every summary are None)
    :param extra: further keys: ``cd_open``
    :param rl: add the RL transfer rates (each None when no case was scored: no ``--rl``, or no drawer or
        door anywhere; a failed case counts as not opened)
    :param physx: add the PhysX sim pass after ``sim_pass_rate`` and its coverage, each None where no row has a
        PhysX verdict; without it the summary is the one runs without PhysX have
    :raises SparkBenchError: for rows of several metric conventions
    """
    check_convention(rows)
    ok = [r for r in rows if r["status"] == "ok"]
    shape_ok = [r for r in ok if r.get("shape_metrics_valid", True)]
    out: dict = {}
    for key in SHAPE_KEYS:
        out[key] = _mean(_value(r, key) for r in shape_ok)
    for key in ARTICULATION_KEYS:
        out[key] = _mean(_value(r, key) for r in ok if articulation_valid(r))
    asked = {"sim": sim, "physx": physx, "rl": rl}
    ran = {"sim": sim, "physx": sim and physx, "rl": rl}  # the PhysX checks run within the sim stage
    first, later = rates(rows, asked, ran)
    out.update(first)
    if "cd_open" in extra:
        out["cd_open"] = _mean(_value(r, "cd_open") for r in shape_ok)
    aligned = alignment_scales(rows)
    if aligned:
        out["alignment_scale"] = aligned
    out.update(later)
    out[JOINT_MEAN] = mean_over_joints(joint_records(rows))
    return out


def rates(rows: Sequence[dict], asked: dict[str, bool], ran: dict[str, bool]) -> tuple[dict, dict]:
    """The rates of a run's summary and their coverages, as the declaration (:data:`~spark_bench.metrics.names.RATES`)
    lists them: first the rates listed among the summary's numbers (every summary's, None where their stage did
    not run, and the others' whose stage was asked for), then, stage by stage (:data:`RATE_STAGES`), the
    appended rates and the coverages of each stage asked for.

    :param rows: result rows of one run and variant
    :param asked: per stage, whether it was asked for (its rates and coverages are keys of the summary)
    :param ran: per stage, whether it ran (else its rates and coverages are None)
    :returns: ``(first, later)``: the summary lists ``first`` after the articulation errors, ``later`` after
        ``cd_open`` and the alignment scale
    """
    def value(h: Headline, fn) -> float | dict | None:
        return fn(rows, h.rate) if ran[h.rate.stage] else None

    first = {h.key: value(h, run_rate) for h in RATES if not h.rate.appended and (h.summary or asked[h.rate.stage])}
    later: dict = {}
    for stage in (s for s in RATE_STAGES if asked[s]):
        of_stage = [h for h in RATES if h.rate.stage == stage]
        later.update({h.key: value(h, run_rate) for h in of_stage if h.rate.appended})
        later.update({h.rate.coverage.key: value(h, rate_coverage) for h in of_stage if h.rate.coverage})
    return first, later
