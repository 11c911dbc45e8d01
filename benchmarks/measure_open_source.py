"""The oracle's scripted opening score acting on the prepared ground truth (before issue 23, item 4) and on
the source object as the dataset gives it (after), on every drawer, door and lid of prepared benchmarks.

For each case of each ``--bench`` (``spark-bench data prepare --src ... --out BENCH --image-size 128``): the
ground truth is loaded once, brought to metres, and the case's source object (``case.json``'s ``source``)
is loaded and checked against it (:func:`spark_bench.opening.pairing.object_acted_on`: the same drawers and
doors, axes, pivots and ranges). Then, per seed, the oracle's scripted opening score on the joints whose
part is a drawer, door or lid (``semantics.txt``'s labels, ``benchmarks/openable.py``'s
``OPENABLE``), once acting on the prepared ground truth in metres and once on the source object. The
oracle's prediction is the ground truth, its joint carried into the frame acted on is the ground truth's
own (to ~1e-16) and its episode has the reference episode's seed: it is the reference episode again, so
the score's rule (:func:`spark_bench.opening.judge.judge_joint`: the planner, the scene, the reference
episode) is run once and a joint it keeps is *opened* by the oracle; ``--full`` runs the oracle's own
episode too (:func:`spark_bench.opening.judge.scripted_score`, twice the episodes). A joint-seed is
*opened*, *failed* (scored, not opened: only with ``--full``) or *left out* (with the rule's kind). The
planner's and the scene's verdicts do not depend on the seed (no episode runs before them): a joint they
left out at one seed is left out at the others without being built again; only the reference episode
depends on the seed.

The report (``--results``, default ``benchmarks/results/open_source.md``) lists per joint the episodes
opened under each, the joints opened on the source that fail on the prepared case (the issue's target:
none left once the score acts on the source) and the converse, and the coverage (joint-seeds scored / all)
under both. Results are cached per case, variant and seed in ``--cache`` (JSON): a run resumes, and
``--seeds 0`` first then ``--seeds 1 2 3 4`` gives a complete first pass early.

Run: ``nice -n 10 python -m benchmarks.measure_open_source --bench <bench_partnet>
--bench <bench_real> --seeds 0 1 2 3 4``.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import spark_bench  # noqa: F401  (registers the environments)
from benchmarks.openable import openable
from spark_bench.asset.transforms import unit
from spark_bench.data.case import Benchmark, BenchmarkCase, ground_truth_in_metres, prediction_to_gt_metres
from spark_bench.opening.judge import OPENING_STEPS, judge_joint, scripted_score
from spark_bench.opening.pairing import ACTS_ON_SOURCE, Pairing, object_acted_on, opening_joints

RESULTS = Path(__file__).resolve().parent / "results"
VARIANTS = ("prepared", "source")


def frame_deviation(source, gt_metres) -> dict:
    """The largest difference between the source's joint frames and the prepared ground truth's in metres:
    axis angle (rad) and pivot distance as a fraction of the object's diagonal, over every movable joint
    both have; and the joints only one of them has."""
    gt_frames, source_frames = gt_metres.joint_frames(), source.joint_frames()
    diagonal = float(np.linalg.norm(np.ptp(gt_metres.bounds(), axis=0)))
    angles, pivots = [0.0], [0.0]
    for name in set(gt_frames) & set(source_frames):
        (gt_point, gt_axis), (point, axis) = gt_frames[name], source_frames[name]
        angles.append(float(np.arccos(np.clip(np.dot(unit(gt_axis), unit(axis)), -1.0, 1.0))))
        pivots.append(float(np.linalg.norm(np.asarray(point) - gt_point)) / diagonal)
    return {"max_angle": max(angles), "max_pivot": max(pivots),
            "only_gt": sorted(set(gt_frames) - set(source_frames)),
            "only_source": sorted(set(source_frames) - set(gt_frames))}


def judged_rows(pairing: Pairing, seed: int, joints: set[str]) -> dict[str, dict]:
    """The oracle's rows without its own episode (module docstring): the rule's verdict per joint."""
    rows = {}
    for joint in opening_joints(pairing.gt_metres):
        if joint.name not in joints:
            continue
        judged = judge_joint(pairing.gt_metres, joint, seed, OPENING_STEPS)
        judged.close()
        rows[joint.name] = ({"success": True, "grasp": judged.grasp} if judged.reason is None else
                            {"success": None, "reason": judged.reason, "left_out_kind": judged.kind})
    return rows


def seedless_verdicts(rows: dict, variant: str) -> dict[str, dict]:
    """The joints that the planner or the scene left out under ``variant`` at a seed measured already (the
    same at every seed: module docstring), with their rows."""
    out = {}
    for key, measured in rows.items():
        if key.startswith(f"{variant}/"):
            out.update({name: row for name, row in measured["joints"].items()
                        if row.get("left_out_kind") in ("planner", "stuck")})
    return out


def measure_case(case: BenchmarkCase, seeds: list[int], done: dict, full: bool = False) -> dict:
    """One case's record: what the source check found, and the oracle's rows per variant and seed
    (``done``'s, when cached).

    :param full: run the oracle's own episode too (:func:`scripted_score`)
    """
    gt_bench = case.load_gt()
    joints = openable(gt_bench)
    record = {"case": case.id, "category": case.category, "joints": joints, "rows": dict(done.get("rows", {}))}
    if not joints:
        return record
    _, gt_metres, bench_to_metres = ground_truth_in_metres(case.gt_dir, gt_bench)
    t0 = time.perf_counter()
    source, acts_on = object_acted_on(case.gt_dir, gt_metres)
    record.update(acts_on=acts_on, source_load_s=round(time.perf_counter() - t0, 2))
    if acts_on == ACTS_ON_SOURCE:
        record["deviation"] = frame_deviation(source, gt_metres)
    matched = {j.name: j.name for j in gt_bench.movable_joints()}
    frame = prediction_to_gt_metres(gt_bench, gt_bench, None, bench_to_metres)
    pairing = Pairing(gt_bench, gt_metres, gt_bench, frame, matched, "prepared gt")
    objects = {"prepared": pairing, "source": replace(pairing, gt_metres=source, acts_on=acts_on)}
    for seed in seeds:
        for variant in VARIANTS:
            key = f"{variant}/{seed}"
            if key in record["rows"] or (variant == "source" and acts_on != ACTS_ON_SOURCE):
                continue
            t0 = time.perf_counter()
            rows = seedless_verdicts(record["rows"], variant)
            todo = set(joints) - set(rows)
            if todo:
                rows.update(scripted_score(objects[variant], seed=seed, only=todo)["joints"] if full
                            else judged_rows(objects[variant], seed, todo))
            record["rows"][key] = {"joints": rows, "wall_s": round(time.perf_counter() - t0, 2), "full": full}
    return record


def outcome(row: dict | None) -> str:
    """``opened``, ``failed``, ``left out (kind)`` or ``-`` (not measured) of one joint-seed row."""
    if row is None:
        return "-"
    if row.get("success") is None:
        return f"left out ({row.get('left_out_kind', '?')})"
    return "opened" if row["success"] else "failed"


def joint_table(records: list[dict], seeds: list[int]) -> tuple[list[dict], dict]:
    """Per joint: its outcome per variant and seed; and the totals over joint-seeds measured under both."""
    rows, totals = [], {"pairs": 0, **{f"{v}_{k}": 0 for v in VARIANTS for k in ("scored", "opened")},
                        "source_only": 0, "prepared_only": 0}
    for record in records:
        for joint, label in record["joints"].items():
            row = {"bench": record["bench"], "case": record["case"], "category": record["category"],
                   "joint": joint, "label": label, **{v: [] for v in VARIANTS}}
            for seed in seeds:
                got = {v: record["rows"].get(f"{v}/{seed}", {}).get("joints", {}).get(joint) for v in VARIANTS}
                for v in VARIANTS:
                    row[v].append(outcome(got[v]))
                if None in got.values():
                    continue
                totals["pairs"] += 1
                for v in VARIANTS:
                    totals[f"{v}_scored"] += got[v].get("success") is not None
                    totals[f"{v}_opened"] += bool(got[v].get("success"))
                totals["source_only"] += bool(got["source"].get("success")) and not got["prepared"].get("success")
                totals["prepared_only"] += bool(got["prepared"].get("success")) and not got["source"].get("success")
            rows.append(row)
    return rows, totals


def _cell(outcomes: list[str]) -> str:
    """``k/n opened`` and what the others were."""
    measured = [o for o in outcomes if o != "-"]
    if not measured:
        return "-"
    others = sorted({o for o in measured if o != "opened"})
    return f"{measured.count('opened')}/{len(measured)}" + (f" ({', '.join(others)})" if others else "")


def write_report(records: list[dict], seeds: list[int], path: Path, seconds: float) -> None:
    """The markdown report (module docstring)."""
    measured_seeds = sorted({int(key.split("/")[1]) for r in records for key in r["rows"]})
    seeds = [seed for seed in seeds if seed in measured_seeds]
    rows, totals = joint_table(records, seeds)
    pairs = totals["pairs"] or 1
    measured = [r for r in rows if any(o != "-" for o in r["prepared"] + r["source"])]
    lines = [
        "# The opening score on the source object and on the prepared ground truth (issue 23, item 4)", "",
        f"Written by `benchmarks/measure_open_source.py` ({time.strftime('%Y-%m-%d %H:%M')}, {seconds:.0f} s "
        f"this run): the oracle's scripted opening score (the prediction is the ground truth, each joint "
        f"matched with itself; its episode is the score's reference episode, run once: see the script), "
        f"seeds {seeds}, on the drawers, doors and lids (`semantics.txt`) of "
        f"{', '.join(sorted({r['bench'] for r in records}))}; *prepared*: acting on the case's ground truth "
        "(R=200 watertight remesh) in metres, as before; *source*: acting on the source object as the dataset "
        "gives it (what the scores act on now). A cell is `opened/episodes` and what the others were.", "",
        f"- joints: {len(rows)} in {sum(1 for r in records if r['joints'])} cases "
        f"({len(measured)} measured); joint-seeds measured under both: {totals['pairs']}",
        f"- **opened on the source, not on the prepared case: {totals['source_only']}** joint-seeds "
        f"(joints: {len({(r['case'], r['joint']) for r in rows if _source_only(r)})}); "
        f"the converse: {totals['prepared_only']}",
        f"- coverage (joint-seeds scored / all): prepared {totals['prepared_scored']}/{totals['pairs']} "
        f"({totals['prepared_scored'] / pairs:.0%}), source {totals['source_scored']}/{totals['pairs']} "
        f"({totals['source_scored'] / pairs:.0%})",
        f"- opened / all: prepared {totals['prepared_opened']}/{totals['pairs']}, source "
        f"{totals['source_opened']}/{totals['pairs']}",
        _source_checks(records), "", *_differences(records, seeds), "",
        "| bench | case | category | joint | part | prepared | source |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        mark = " **opened on the source only**" if _source_only(r) else ""
        lines.append(f"| {r['bench']} | {r['case']} | {r['category']} | {r['joint']} | {r['label']} | "
                     f"{_cell(r['prepared'])} | {_cell(r['source'])}{mark} |")
    notes = ""
    if path.is_file() and "<!-- notes" in path.read_text():
        notes = path.read_text().split("<!-- notes", 1)[1]
        notes = "\n<!-- notes" + notes
    path.write_text("\n".join(lines) + "\n" + (notes or "\n<!-- notes: kept when the script rewrites the file -->\n"))


def _differences(records: list[dict], seeds: list[int]) -> list[str]:
    """One line per joint whose outcome differs between the two at some seed: the outcomes and the
    reasons."""
    lines = ["Joints whose outcome differs (prepared -> source, at the first seed that differs):", ""]
    for record in records:
        for joint in record["joints"]:
            for seed in seeds:
                got = {v: record["rows"].get(f"{v}/{seed}", {}).get("joints", {}).get(joint) for v in VARIANTS}
                if None in got.values() or outcome(got["prepared"]) == outcome(got["source"]):
                    continue
                why = "; ".join(f"{v}: {got[v]['reason'][:160]}" for v in VARIANTS if got[v].get("reason"))
                lines.append(f"- {record['bench']} {record['case']} {joint} (seed {seed}): "
                             f"{outcome(got['prepared'])} -> {outcome(got['source'])}" + (f" ({why})" if why else ""))
                break
    return lines if len(lines) > 2 else ["No joint's outcome differs."]


def _source_only(row: dict) -> bool:
    """Whether some seed opened the joint on the source and not on the prepared case."""
    return any(s == "opened" and p != "opened" and "-" not in (s, p) for p, s in zip(row["prepared"], row["source"]))


def _source_checks(records: list[dict]) -> str:
    """One line: what the cases acted on, and the largest joint-frame difference source / prepared gt."""
    with_joints = [r for r in records if r["joints"]]
    acts = {}
    for r in with_joints:
        acts[r.get("acts_on", "?")] = acts.get(r.get("acts_on", "?"), 0) + 1
    deviations = [r["deviation"] for r in with_joints if "deviation" in r]
    extra = [f"{r['case']}: {r['deviation']['only_gt']} / {r['deviation']['only_source']}" for r in with_joints
             if "deviation" in r and (r["deviation"]["only_gt"] or r["deviation"]["only_source"])]
    line = f"- acts_on: {acts}"
    if deviations:
        line += (f"; source vs prepared gt in metres, every movable joint: axis angle at most "
                 f"{max(d['max_angle'] for d in deviations):.1e} rad, pivot at most "
                 f"{max(d['max_pivot'] for d in deviations):.1e} of the diagonal; joints in one only: "
                 f"{'; '.join(extra) or 'none'}")
    return line


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bench", type=Path, action="append", required=True, help="a prepared benchmark folder")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--ids", nargs="+", default=None, help="only these case ids")
    parser.add_argument("--cache", type=Path, default=Path("/tmp/i23_4/open_source.json"))
    parser.add_argument("--results", type=Path, default=RESULTS / "open_source.md")
    parser.add_argument("--full", action="store_true", help="run the oracle's own episode too")
    parser.add_argument("--report-seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4],
                        help="the seeds the report shows (cached ones)")
    args = parser.parse_args()
    cache = json.loads(args.cache.read_text()) if args.cache.is_file() else {}
    start = time.perf_counter()
    for bench_dir in args.bench:
        bench = Benchmark(bench_dir)
        for case in bench.cases():
            if args.ids and case.id not in args.ids:
                continue
            key = f"{bench_dir.name}/{case.id}"
            t0 = time.perf_counter()
            record = measure_case(case, args.seeds, cache.get(key, {}), args.full)
            cache[key] = {**record, "bench": bench_dir.name}
            args.cache.parent.mkdir(parents=True, exist_ok=True)
            args.cache.write_text(json.dumps(cache, indent=1, default=float))
            if record["joints"]:
                print(f"{key}: {record.get('acts_on')} {time.perf_counter() - t0:.0f} s", flush=True)
            write_report(list(cache.values()), args.report_seeds, args.results, time.perf_counter() - start)


if __name__ == "__main__":
    main()
