"""The result of comparing one predicted asset with its ground truth, as data, JSON and a table.

:class:`MetricsResult` holds everything a results row needs: shape scores (rest, open, per part),
articulation errors with the joint matching that produced them, the alignment used, and the units and
convention version of the definitions. :func:`mean_over_objects` gives the per-benchmark numbers.

Two averages of the articulation errors are kept (docs/conventions.md, "Articulation metrics"): per object (mean
over its joints, then over objects: ``axis_err``, ``pivot_err``, ``type_err``, the leaderboard's
numbers) and over joints (every joint of every object weighs the same: ``joint_mean``).
:func:`joint_errors` reads the per-joint errors back from a stored metrics dict, so both averages, and
the breakdown by GAPartNet part class (:func:`mean_by_part_class`), come from the same records.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from spark_bench.convention import CONVENTION_VERSION
from spark_bench.metrics.align import similarity_scale, similarity_yaw_deg
from spark_bench.metrics.names import ARTICULATION_FAMILIES, JOINT_MEAN, SCALAR_PREFIXES, UNITS
from spark_bench.metrics.shape import ShapeScores


@dataclass
class JointMatch:
    """One ground-truth movable joint and the predicted joint it was matched with.

    :param gt_joint: ground-truth joint name
    :param pred_joint: predicted joint name
    :param gt_type: ground-truth joint type
    :param pred_type: predicted joint type
    :param gt_links: the ground-truth part (links)
    :param pred_links: the predicted part (links)
    :param match_cd: part Chamfer distance at rest used for the matching (matching samples)
    :param axis_err: AxisErr, radians
    :param pivot_err: PivotErr; None unless both joints rotate
    :param type_match: whether the types agree (continuous counts as revolute)
    :param part: shape scores of the two parts at rest (full sample count)
    :param gt_part_class: the ground-truth part's GAPartNet class (``hinge_door``...), None without
        annotations
    """

    gt_joint: str
    pred_joint: str
    gt_type: str
    pred_type: str
    gt_links: list[str]
    pred_links: list[str]
    match_cd: float
    axis_err: float
    pivot_err: float | None
    type_match: bool
    part: ShapeScores | None = None
    gt_part_class: str | None = None

    def to_dict(self) -> dict:
        out = {"gt_joint": self.gt_joint, "pred_joint": self.pred_joint, "gt_type": self.gt_type,
               "pred_type": self.pred_type, "gt_links": list(self.gt_links),
               "pred_links": list(self.pred_links), "match_cd": self.match_cd,
               "axis_err": self.axis_err, "pivot_err": self.pivot_err, "type_match": self.type_match,
               "gt_part_class": self.gt_part_class}
        if self.part is not None:
            out.update(self.part.to_dict(prefix="part_"))
        return out


def _mean(values: Iterable[float | None]) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


@dataclass
class MetricsResult:
    """Shape and articulation metrics of one prediction against its ground truth.

    :param rest: whole-object shape scores at rest
    :param open: whole-object shape scores with every movable joint at its upper limit
    :param matches: the matched joints, in ground-truth order
    :param missing_joints: ground-truth movable joints without a match
    :param extra_joints: predicted movable joints without a match
    :param thresholds: F-Score thresholds
    :param n_samples: surface samples per shape (rest, open, each part)
    :param n_match_samples: surface samples per part for the matching
    :param seed: sampling seed
    :param align: ``none`` or ``icp``
    :param alignment: 4x4 similarity applied to the prediction (identity for ``none``)
    :param pred_name: predicted asset name
    :param gt_name: ground-truth asset name
    :param convention: version of the metric definitions
    :param part_classes: GAPartNet part class of each ground-truth movable joint that has one
    """

    rest: ShapeScores
    open: ShapeScores
    matches: list[JointMatch] = field(default_factory=list)
    missing_joints: list[str] = field(default_factory=list)
    extra_joints: list[str] = field(default_factory=list)
    thresholds: tuple[float, ...] = (0.1, 0.5)
    n_samples: int = 0
    n_match_samples: int = 0
    seed: int = 0
    align: str = "none"
    alignment: np.ndarray = field(default_factory=lambda: np.eye(4))
    pred_name: str = ""
    gt_name: str = ""
    convention: str = CONVENTION_VERSION
    part_classes: dict[str, str] = field(default_factory=dict)

    # ----- per-object articulation numbers: means over joints ---------------------------------------
    @property
    def n_gt_joints(self) -> int:
        return len(self.matches) + len(self.missing_joints)

    @property
    def n_pred_joints(self) -> int:
        return len(self.matches) + len(self.extra_joints)

    @property
    def axis_err(self) -> float | None:
        """Mean AxisErr over matched joints; None when no joint is matched."""
        return _mean(m.axis_err for m in self.matches)

    @property
    def pivot_err(self) -> float | None:
        """Mean PivotErr over the matched rotating ground-truth joints (whatever the predicted type);
        None when there is none."""
        return _mean(m.pivot_err for m in self.matches)

    @property
    def type_err(self) -> float | None:
        """Fraction of ground-truth movable joints that are unmatched or matched with another type;
        None when the ground truth has no movable joint."""
        if self.n_gt_joints == 0:
            return None
        wrong = len(self.missing_joints) + sum(not m.type_match for m in self.matches)
        return wrong / self.n_gt_joints

    def part_scores(self) -> dict[str, float | None]:
        """Mean part Chamfer distance and F-Scores over matched parts (None when nothing matched)."""
        parts = [m.part for m in self.matches if m.part is not None]
        out: dict[str, float | None] = {"part_cd": _mean(p.cd for p in parts)}
        for t in self.thresholds:
            out[f"part_fscore@{t:g}"] = _mean(p.fscore[t] for p in parts)
        return out

    def to_dict(self) -> dict:
        """Plain JSON-ready dict (None for absent values)."""
        out: dict = {}
        out.update(self.rest.to_dict())
        out.update(self.open.to_dict(suffix="_open"))
        out.update(self.part_scores())
        out.update({
            "axis_err": self.axis_err, "pivot_err": self.pivot_err, "type_err": self.type_err,
            JOINT_MEAN: None, "n_gt_joints": self.n_gt_joints, "n_pred_joints": self.n_pred_joints,
            "n_missing_joints": len(self.missing_joints), "n_extra_joints": len(self.extra_joints),
            "matching": [m.to_dict() for m in self.matches],
            "missing_joints": list(self.missing_joints), "extra_joints": list(self.extra_joints),
            "gt_part_classes": dict(self.part_classes), "align": self.align, "alignment": np.asarray(self.alignment).tolist(),
            **alignment_found(self.align, self.alignment),
            "n_samples": self.n_samples, "n_match_samples": self.n_match_samples, "seed": self.seed,
            "thresholds": list(self.thresholds), "pred": self.pred_name, "gt": self.gt_name,
            "convention": self.convention, "units": dict(UNITS),
        })
        out[JOINT_MEAN] = mean_over_joints(joint_errors(out))
        return out


def alignment_found(align: str, matrix) -> dict:
    """What ``--align`` found, beside the errors it changes: ``alignment_scale`` (the uniform scale applied
    to the prediction) and ``alignment_yaw_deg`` (its turn about the up axis), both None for ``none``.

    :param align: ``none`` or ``icp``
    :param matrix: the 4x4 similarity applied to the prediction
    """
    if align == "none":
        return {"alignment_scale": None, "alignment_yaw_deg": None}
    return {"alignment_scale": similarity_scale(matrix), "alignment_yaw_deg": similarity_yaw_deg(matrix)}


# ----- per joint --------------------------------------------------------------------------------------
#: The articulation errors of one joint, in :func:`joint_errors` records and ``joint_mean``.
JOINT_ERROR_KEYS = ARTICULATION_FAMILIES


def joint_errors(metrics: Mapping | MetricsResult) -> list[dict]:
    """One record per ground-truth movable joint of one object: ``gt_joint``, ``part_class`` (None
    without GAPartNet annotations), ``axis_err`` (None when unmatched), ``pivot_err`` (None when
    unmatched or not rotating), ``type_err`` (0.0 or 1.0; an unmatched joint counts as wrong).

    :param metrics: a metrics result or its ``to_dict()`` (as stored in a results row)
    """
    d = metrics.to_dict() if isinstance(metrics, MetricsResult) else metrics
    classes = d.get("gt_part_classes") or {}
    out = []
    for m in d.get("matching") or []:
        name = m.get("gt_joint")
        out.append({"gt_joint": name, "part_class": m.get("gt_part_class") or classes.get(name),
                    "axis_err": m.get("axis_err"), "pivot_err": m.get("pivot_err"),
                    "type_err": 0.0 if m.get("type_match") else 1.0})
    for name in d.get("missing_joints") or []:
        out.append({"gt_joint": name, "part_class": classes.get(name), "axis_err": None, "pivot_err": None,
                    "type_err": 1.0})
    return out


def mean_over_joints(records: Iterable[Mapping]) -> dict[str, float | None]:
    """``{"axis_err", "pivot_err", "type_err"}``: each the mean over the joint records that have it
    (every joint weighs the same, whatever object it belongs to); None when none has it.

    :param records: :func:`joint_errors` records, of one object or of many
    """
    records = list(records)
    return {key: _mean(_number_or_none(r.get(key)) for r in records) for key in JOINT_ERROR_KEYS}


def mean_by_part_class(records: Iterable[Mapping]) -> dict[str, dict]:
    """Per GAPartNet part class: :func:`mean_over_joints` of its joints and ``n_joints`` (joints without a
    class are left out), classes sorted by name.

    :param records: :func:`joint_errors` records
    """
    groups: dict[str, list[Mapping]] = {}
    for record in records:
        if record.get("part_class"):
            groups.setdefault(str(record["part_class"]), []).append(record)
    return {name: {**mean_over_joints(group), "n_joints": len(group)} for name, group in sorted(groups.items())}


def _number_or_none(value) -> float | None:
    return float(value) if _is_number(value) else None


def mean_over_objects(rows: Iterable[Mapping | MetricsResult]) -> dict[str, float | int | None]:
    """Per-benchmark numbers: the mean over objects of each scalar metric (absent values skipped),
    with ``n_objects`` and, for each metric, ``n_<key>`` objects that had it; ``joint_mean``: the
    articulation errors averaged over every joint of every object (:func:`mean_over_joints`).

    :param rows: results (or their ``to_dict()``) of the objects of one benchmark
    """
    dicts = [r.to_dict() if isinstance(r, MetricsResult) else dict(r) for r in rows]
    keys: list[str] = []
    for row in dicts:
        for key, value in row.items():
            if key.startswith(SCALAR_PREFIXES) and key not in keys and _is_number(value):
                keys.append(key)
    out: dict[str, float | int | None] = {"n_objects": len(dicts)}
    for key in keys:
        values = [row[key] for row in dicts if _is_number(row.get(key))]
        out[key] = _mean(values)
        out[f"n_{key}"] = len(values)
    out[JOINT_MEAN] = mean_over_joints(record for row in dicts for record in joint_errors(row))
    return out


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _fmt(value, digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    return f"{value:.{digits}f}"


def format_table(result: MetricsResult) -> str:
    """A readable plain-text report: summary numbers, then one line per matched joint."""
    d = result.to_dict()
    lines = [f"metrics: {result.pred_name or 'pred'} vs {result.gt_name or 'gt'} "
             f"({result.convention}, align={result.align}, {result.n_samples} samples, seed {result.seed})"]
    summary = [("CD (rest)", d["cd"]), ("CD (open)", d["cd_open"]), ("CD (parts)", d["part_cd"])]
    for t in result.thresholds:
        summary += [(f"F-Score@{t:g} (rest)", d[f"fscore@{t:g}"]), (f"F-Score@{t:g} (open)", d[f"fscore_open@{t:g}"]),
                    (f"F-Score@{t:g} (parts)", d[f"part_fscore@{t:g}"])]
    summary += [("AxisErr (rad)", d["axis_err"]), ("PivotErr", d["pivot_err"]), ("TypeErr", d["type_err"]),
                ("joints gt / pred", f"{d['n_gt_joints']} / {d['n_pred_joints']}"),
                ("missing / extra joints", f"{d['n_missing_joints']} / {d['n_extra_joints']}")]
    width = max(len(name) for name, _ in summary)
    lines += [f"  {name:<{width}}  {value if isinstance(value, str) else _fmt(value)}" for name, value in summary]
    if result.matches:
        header = ("gt joint", "type", "pred joint", "type", "match CD", "part CD", "AxisErr", "PivotErr", "type ok")
        rows = [(m.gt_joint, m.gt_type, m.pred_joint, m.pred_type, _fmt(m.match_cd),
                 _fmt(m.part.cd if m.part else None), _fmt(m.axis_err), _fmt(m.pivot_err), _fmt(m.type_match))
                for m in result.matches]
        if any(m.gt_part_class for m in result.matches):  # GAPartNet-annotated ground truth
            header += ("part class",)
            rows = [(*row, m.gt_part_class or "-") for row, m in zip(rows, result.matches)]
        widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
        lines.append("matching:")
        for row in [header, *rows]:
            lines.append("  " + "  ".join(f"{str(c):<{w}}" for c, w in zip(row, widths)).rstrip())
    for name, joints in (("missing (gt, unmatched)", result.missing_joints),
                         ("extra (pred, unmatched)", result.extra_joints)):
        if joints:
            lines.append(f"{name}: {', '.join(joints)}")
    return "\n".join(lines)
