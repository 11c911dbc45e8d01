"""Per-benchmark numbers from per-case result rows (shared by ``eval --json`` and the leaderboard).

- Shape metrics (CD, F-Scores): mean over the ``ok`` cases whose shape metrics are valid; None (shown
  as n/a) when no case has valid shape metrics (a method that reuses the ground-truth geometry).
- Articulation metrics: mean over the ``ok`` cases that have the value (DESIGN.md: mean over joints
  per object, then over objects).
- Rates (sim pass, scripted opening): over every case of the run where the stage ran, a failed case
  counting as not passed; None when the stage never ran.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from spark_bench.metrics.names import ARTICULATION_KEYS, METRIC_COLUMNS, SHAPE_KEYS

# The keys (SUMMARY_KEYS: SHAPE_KEYS, ARTICULATION_KEYS, RATE_KEYS) and which way each is better are
# listed in spark_bench.metrics.names.


def _mean(values: Iterable[float | None]) -> float | None:
    kept = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    return sum(kept) / len(kept) if kept else None


def _value(row: dict, key: str):
    column = METRIC_COLUMNS[key]
    value = row.get(column)
    return value if value is not None else row.get("metrics", {}).get(key)


def _rate(rows: Sequence[dict], column: str, stage_ran) -> float | None:
    counted = [r for r in rows if r["status"] == "failed" or stage_ran(r)]
    if not any(stage_ran(r) for r in rows):
        return None
    return sum(float(r.get(column) or 0.0) for r in counted if r["status"] == "ok") / len(counted)


def summarize(rows: Sequence[dict], sim: bool = True, extra: Sequence[str] = ()) -> dict:
    """The per-benchmark metrics of one run's rows (one variant), keys
    :data:`~spark_bench.metrics.names.SUMMARY_KEYS` (+ ``extra``).

    :param rows: result rows of one run and variant (ok and failed)
    :param sim: whether the sim stages were asked for (False: the rates are None)
    :param extra: further keys: ``cd_open``, ``rl_success_rate``
    """
    ok = [r for r in rows if r["status"] == "ok"]
    shape_ok = [r for r in ok if r.get("shape_metrics_valid", True)]
    out: dict = {}
    for key in SHAPE_KEYS:
        out[key] = _mean(_value(r, key) for r in shape_ok)
    for key in ARTICULATION_KEYS:
        out[key] = _mean(_value(r, key) for r in ok)
    out["sim_pass_rate"] = _rate(rows, "sim_pass", lambda r: r.get("sim_pass") is not None) if sim else None
    out["open_success_rate"] = (_rate(rows, "open_success", lambda r: r.get("open_success") is not None)
                                if sim else None)
    if "cd_open" in extra:
        out["cd_open"] = _mean(_value(r, "cd_open") for r in shape_ok)
    if "rl_success_rate" in extra:
        out["rl_success_rate"] = _rate(rows, "rl_success", lambda r: r.get("rl_success") is not None)
    return out
