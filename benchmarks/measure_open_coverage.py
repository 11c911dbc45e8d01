"""Coverage of the opening score on real objects: of every drawer, door and lid (``semantics.txt``) of prepared
benchmarks, how many the opening score opens with the ground truth's own joint, the object acted on and the
end-effector chosen as inside ``eval`` (:func:`spark_bench.opening.judge.judge_joint`), at several seeds.

The oracle's score of a joint is its reference episode (the same joint, the same seed: the oracle's own episode
repeats it), so a joint counts as opened at a seed when the rule scores it, and as left out with the rule's
kind otherwise. The planner's and the scene's verdicts do not depend on the seed and are judged once. Reported
per half of ``partnet_dev`` (``benchmarks/partnet_dev_split.py``: tune / holdout) and for any other benchmark, with
the end-effector of each joint opened.

    python -m benchmarks.measure_open_coverage --bench <bench_partnet> --bench <bench_real> \\
        --seeds 0 1 2 3 4 --workers 2 --out benchmarks/results/open_coverage.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from benchmarks.openable import openable
from benchmarks.partnet_dev_split import read_halves

RESULTS = Path(__file__).resolve().parent / "results"


def measure_case(case_dir: str, seeds: list[int]) -> list[dict]:
    """One case's drawer, door and lid joints: per joint, the verdict at each seed."""
    import spark_bench  # noqa: F401  (registers the environments)
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.manipulation.suction import cup_mm
    from spark_bench.opening.judge import OPENING_STEPS, judge_joint
    from spark_bench.opening.pairing import load_pairing, opening_joints

    case = BenchmarkCase(Path(case_dir))
    gt_bench = case.load_gt()
    labels = openable(gt_bench)
    if not labels:
        return []
    metrics = {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in gt_bench.movable_joints()]}
    pairing = load_pairing(case.gt_dir, case.gt_dir, metrics, gt_bench=gt_bench)
    out = []
    for joint in opening_joints(pairing.gt_metres):
        if joint.name not in labels:
            continue
        verdicts = []
        for seed in seeds:
            judged = judge_joint(pairing.gt_metres, joint, seed, OPENING_STEPS)
            judged.close()
            verdicts.append({"seed": seed, "opened": judged.reason is None, "kind": judged.kind,
                             "end_effector": judged.end_effector, "cup_mm": cup_mm(judged.cup_radius),
                             "reason": judged.reason})
            if judged.kind in ("planner", "stuck", "no_task"):  # seed-independent: the same at every seed
                verdicts += [{**verdicts[-1], "seed": s} for s in seeds[len(verdicts):]]
                break
        out.append({"case": case.id, "joint": joint.name, "part": labels[joint.name],
                    "acts_on": pairing.acts_on, "verdicts": verdicts})
    return out


def _effector(verdict: dict) -> str:
    """``gripper``, or ``suction`` with its cup's size (``suction 40 mm``)."""
    cup = verdict.get("cup_mm")
    return verdict["end_effector"] if cup is None else f"{verdict['end_effector']} {cup:g} mm"


def summary(records: list[dict], n_seeds: int) -> dict:
    """Joints opened at every seed, joint-seeds opened, what left the others out, and the end-effectors."""
    kinds: dict[str, int] = {}
    effectors: dict[str, int] = {}
    always = 0
    for record in records:
        opened = [v for v in record["verdicts"] if v["opened"]]
        if len(opened) == n_seeds:
            always += 1
            effectors[_effector(opened[0])] = effectors.get(_effector(opened[0]), 0) + 1
        for v in record["verdicts"]:
            if not v["opened"]:
                kinds[v["kind"]] = kinds.get(v["kind"], 0) + 1
    seeds_opened = sum(v["opened"] for r in records for v in r["verdicts"])
    return {"joints": len(records), "opened_every_seed": always, "joint_seeds": len(records) * n_seeds,
            "joint_seeds_opened": seeds_opened, "left_out_kinds": dict(sorted(kinds.items())),
            "end_effectors": dict(sorted(effectors.items()))}


def _line(name: str, s: dict) -> str:
    pct = 100.0 * s["opened_every_seed"] / max(s["joints"], 1)
    return (f"| {name} | {s['joints']} | {s['opened_every_seed']} ({pct:.0f} %) | "
            f"{s['joint_seeds_opened']}/{s['joint_seeds']} | {s['end_effectors']} | {s['left_out_kinds']} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", type=Path, action="append", required=True, help="a prepared benchmark folder")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=RESULTS / "open_coverage.md")
    args = parser.parse_args()
    from tqdm import tqdm

    from spark_bench.data.case import Benchmark

    start = time.perf_counter()
    jobs = [(bench, case.folder) for bench in args.bench for case in Benchmark(bench).cases()]
    records: dict[str, list[dict]] = {str(b): [] for b in args.bench}
    with ProcessPoolExecutor(args.workers) as pool:
        futures = {pool.submit(measure_case, str(case_dir), args.seeds): bench for bench, case_dir in jobs}
        for future in tqdm(futures, desc="cases", unit="case"):
            try:
                records[str(futures[future])] += future.result()
            except Exception as exc:  # one bad case never stops the run: it is listed
                print(f"{futures[future]}: {' '.join(str(exc).split())[:200]}", file=sys.stderr)
    halves = read_halves()
    lines = ["# Coverage of the opening score on real objects (issue 23, item 5)", "",
             f"Written by `benchmarks/measure_open_coverage.py` ({time.strftime('%Y-%m-%d %H:%M')}, "
             f"{time.perf_counter() - start:.0f} s): every drawer, door and lid (`semantics.txt`) of each benchmark, "
             f"the opening score's rule with the ground truth's own joint (`judge_joint`: the object acted on, the "
             f"end-effector chosen as inside `eval`), seeds {args.seeds}. *Opened* counts a joint opened at every "
             "seed; a joint-seed left out says by which rule.", "",
             "| set | joints | opened at every seed | joint-seeds opened | opened with | left out (joint-seeds) |",
             "|---|---|---|---|---|---|"]
    n = len(args.seeds)
    for bench, found in records.items():
        name = Path(bench).name
        lines.append(_line(name, summary(found, n)))
        ids = {r["case"] for r in found}
        if ids & set(halves["tune"]) or ids & set(halves["holdout"]):
            for half in ("tune", "holdout"):
                part = [r for r in found if r["case"] in set(halves[half])]
                lines.append(_line(f"{name}, {half} half", summary(part, n)))
    lines += ["", "## Joints not opened at every seed", "", "| set | case | joint | part | verdicts |", "|---|---|---|---|---|"]
    for bench, found in records.items():
        for r in sorted(found, key=lambda r: (r["case"], r["joint"])):
            if not all(v["opened"] for v in r["verdicts"]):
                cells = "; ".join(f"{v['seed']}: {'opened' if v['opened'] else v['kind']}" for v in r["verdicts"])
                why = next((v["reason"] for v in r["verdicts"] if v["reason"]), "")
                lines.append(f"| {Path(bench).name} | {r['case']} | {r['joint']} | {r['part']} | {cells} ({why[:140]}) |")
    args.out.write_text("\n".join(lines) + "\n")
    # keyed by the benchmark folder's name as a placeholder (benchmarks/README.md), not by one machine's path
    keyed = {f"<{Path(bench).name}>": found for bench, found in records.items()}
    args.out.with_suffix(".json").write_text(json.dumps(keyed, indent=1) + "\n")
    print("\n".join(lines[:12]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
