"""Time the whole eval of a benchmark (default ``synth-v1``, no RL) on 2 cores, per stage, with 1 and 2
workers, and report the 2-worker speed-up against the 1-worker run measured here.

Each configuration starts from an empty results store and an empty generation cache, so nothing is
reused between them. Run: ``python -m benchmarks.measure_eval [--bench synth-v1] [--methods oracle,geometry]``
(``--cases 10`` for a quick look; ``--no-sim`` to time the metrics alone).

``--rl N`` instead times the RL transfer score of ``eval --rl`` (the ``rl`` stage: the shipped generalist
policies fine-tuned on the prediction, then run on the ground truth, with the case's episode video) on the
first N cases, once per ``--finetune-steps`` (0 is the zero-shot score alone), with the oracle's
prediction: its score is the policy's ceiling. Budget (issue 15): <= 20 s per case fine-tuned, <= 3 s
zero-shot, on 2 cores. Writes ``benchmarks/results/generalist_transfer.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path


def _pin_to_cores(n: int) -> list[int]:
    """Restrict this process (and the pool it forks) to ``n`` cores, where the OS allows it."""
    if not hasattr(os, "sched_setaffinity"):
        return []
    cores = sorted(os.sched_getaffinity(0))[:n]
    os.sched_setaffinity(0, cores)
    return cores


def _one_run(method: str, bench: str, workers: int, sim: bool, n_samples: int, cases, root: Path) -> dict:
    from spark_bench.evaluation.runner import EvalOptions, run_eval
    from spark_bench.evaluation.store import ResultsStore
    from spark_bench.methods.base import MethodSpec

    db = root / f"{method}-{workers}.sqlite"
    start = time.perf_counter()
    summary = run_eval(MethodSpec.create(method), bench, EvalOptions(sim=sim, n_samples=n_samples), db=db,
                       workers=workers, runs_root=root / f"runs-{method}-{workers}", progress=False, cases=cases)
    wall = time.perf_counter() - start
    stages: dict[str, float] = defaultdict(float)
    with ResultsStore(db) as store:
        for row in store.rows(label=summary.run.label):
            if row["variant"] == "":
                for stage, seconds in row["timings"].items():
                    stages[stage] += seconds
    return {"method": summary.run.label, "workers": workers, "wall_s": wall, "n_cases": summary.n_cases,
            "n_failed": summary.n_failed, "stages_cpu_s": dict(stages), "metrics": summary.metrics}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", default="synth-v1")
    parser.add_argument("--methods", default="oracle,geometry")
    parser.add_argument("--cases", type=int, default=0, help="only the first N cases (0: all)")
    parser.add_argument("--n-samples", type=int, default=100_000)
    parser.add_argument("--no-sim", action="store_true")
    parser.add_argument("--json", help="also write the results here")
    parser.add_argument("--rl", type=int, default=0, metavar="N", help="time eval --rl's stage on N cases")
    parser.add_argument("--rl-cases", help="with --rl: these case ids too (comma-separated)")
    parser.add_argument("--rl-method", default="oracle",
                        help="with --rl: the method whose prediction is fine-tuned on (default: the oracle, the ceiling)")
    parser.add_argument("--finetune-steps", type=int, nargs="+", default=None,
                        help="with --rl: fine-tuning steps to time (default: 0 and eval's default)")
    args = parser.parse_args(argv)

    cores = _pin_to_cores(2)
    if args.rl:
        return measure_rl(args, cores)
    from spark_bench.data.case import Benchmark
    from spark_bench.evaluation.runner import resolve_bench

    t0 = time.perf_counter()
    name, folder = resolve_bench(args.bench)  # builds synth-v1 on first use
    print(f"benchmark {name} at {folder} ready in {time.perf_counter() - t0:.1f} s; cores {cores}", flush=True)
    cases = Benchmark(folder).case_ids()
    if args.cases:
        cases = cases[:args.cases]
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_eval_") as tmp:
        for method in [m for m in args.methods.split(",") if m]:
            for workers in (1, 2):
                result = _one_run(method, str(folder), workers, not args.no_sim, args.n_samples, cases, Path(tmp))
                results.append(result)
                stages = ", ".join(f"{k} {v:.1f}" for k, v in sorted(result["stages_cpu_s"].items(),
                                                                       key=lambda kv: -kv[1]))
                print(f"{result['method']:>28}  workers={workers}  wall {result['wall_s']:7.1f} s  "
                      f"({result['wall_s'] / max(1, len(cases)):.2f} s/case, {result['n_failed']} failed)  "
                      f"stage seconds: {stages}", flush=True)
            one, two = results[-2], results[-1]
            print(f"{one['method']:>28}  speed-up of 2 workers over 1: {one['wall_s'] / two['wall_s']:.2f}x",
                  flush=True)
            print(f"{'':>28}  metrics: " + json.dumps({k: (round(v, 4) if isinstance(v, float) else v)
                                                      for k, v in one["metrics"].items()}), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


def measure_rl(args, cores: list[int]) -> int:
    """Time the ``rl`` stage of ``eval --rl`` with ``--rl-method``'s prediction (see the module docstring)."""
    import numpy as np

    from spark_bench.data import load_object
    from spark_bench.data.case import Benchmark
    from spark_bench.evaluation.runner import EvalOptions, resolve_bench, run_eval
    from spark_bench.evaluation.store import ResultsStore
    from spark_bench.methods.base import MethodSpec
    from spark_bench.opening.pairing import opening_joints
    from spark_bench.rl import FINETUNE_STEPS

    name, folder = resolve_bench(args.bench)

    bench = Benchmark(folder)
    every = [c for c in bench.case_ids()  # cases with a drawer or door, spread over the categories
             if opening_joints(load_object(bench.case(c).gt_dir, load_meshes=False))]
    cases = every[:: max(1, len(every) // args.rl)][: args.rl]
    cases += [c for c in args.rl_cases.split(",") if c and c not in cases] if args.rl_cases else []
    settings = args.finetune_steps if args.finetune_steps else [0, FINETUNE_STEPS]
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_rl_") as tmp:
        for steps in settings:
            db = Path(tmp) / f"rl-{steps}.sqlite"
            options = EvalOptions(sim=False, rl=True, rl_finetune_steps=steps, n_samples=5_000)
            cpu = time.process_time()
            summary = run_eval(MethodSpec.create(args.rl_method), str(folder), options, db=db, workers=0,
                               runs_root=Path(tmp) / "runs", progress=False, cases=cases)
            cpu = time.process_time() - cpu
            with ResultsStore(db) as store:
                for row in store.rows(label=summary.run.label, where=[("variant", "")]):  # the case rows, not a variant's
                    rl = row["checks"].get("rl", {})
                    rows.append({"case": row["case_id"], "finetune_steps": steps, "rl_stage_s": row["timings"].get("rl"),
                                 "rl_cpu_s": rl.get("cpu_s"),
                                 "joints": rl.get("joints_scored", 0), "joints_total": rl.get("joints_total", 0),
                                 "zero_shot": rl.get("zero_shot_success_rate"),
                                 "finetuned": rl.get("success_rate"), "holdable": rl.get("holdable_joints"),
                                 "holdable_finetuned": rl.get("holdable_success_rate"),
                                 "error": rl.get("error")})
                    print(json.dumps(rows[-1]), flush=True)
            print(f"finetune {steps}: process CPU {cpu:.1f} s for {len(cases)} cases (metrics stage included)",
                  flush=True)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    oracle = args.rl_method == "oracle"
    lines = ["# eval --rl: seconds per case and the oracle's ceiling" if oracle else
             f"# eval --rl on {summary.run.label}'s predictions: fine-tuned against zero-shot", "",
             f"Produced by `python -m benchmarks.measure_eval --rl {args.rl} --finetune-steps "
             f"{' '.join(map(str, settings))}"
             f"{' --rl-cases ' + args.rl_cases if args.rl_cases else ''}"
             f"{'' if oracle else ' --rl-method ' + args.rl_method}` on {name} ({len(cases)} cases with a drawer or door, spread over its categories: "
             f"{', '.join(cases)}), cores {cores}, one "
             f"process; the machine was shared with other jobs (load average {load:.1f} at the end), so the "
             "times are upper bounds of an idle 2-core machine. "
             + ("The prediction is the ground truth itself (the oracle): its RL score is the policy's ceiling. "
                if oracle else f"The prediction is `{summary.run.label}`'s (regime: {summary.run.regime}); the "
                "policy is fine-tuned on it and scored on the ground truth told the predicted joint. ")
             + "The time is the `rl` stage of each case (the "
             "fine-tuning, both columns' episodes on every ground-truth drawer and door, and the case's "
             "episode video); the first case also pays for imports and loading the weights. CPU s: this process's CPU "
             "time in the stage (all its threads), what an idle machine's wall time would be on one core.", "",
             "| fine-tuning steps | cases | joints scored / total | zero-shot success | fine-tuned success | holdable joints: "
             "fine-tuned | rl stage wall s per case (mean / max) | its CPU s per case (mean / max) |",
             "|---|---|---|---|---|---|---|---|"]
    for steps in settings:
        sel = [r for r in rows if r["finetune_steps"] == steps]
        scored = [r for r in sel if r["zero_shot"] is not None]
        weights = [r["joints"] for r in scored]
        zero = np.average([r["zero_shot"] for r in scored], weights=weights) if sum(weights) else None
        tuned = np.average([r["finetuned"] for r in scored], weights=weights) if sum(weights) else None
        held = [r for r in scored if r["holdable_finetuned"] is not None]
        hold = (np.average([r["holdable_finetuned"] for r in held], weights=[r["holdable"] for r in held])
                if held else None)
        secs = [r["rl_stage_s"] for r in sel if r["rl_stage_s"] is not None]
        cpus = [r["rl_cpu_s"] for r in sel if r["rl_cpu_s"] is not None] or [float("nan")]
        lines.append(f"| {steps} | {len(sel)} | {sum(weights)} / {sum(r['joints_total'] for r in sel)} | "
                     f"{_pct(zero)} | {_pct(tuned)} | "
                     f"{_pct(hold)} of {sum(r['holdable'] for r in held)} | "
                     f"{np.mean(secs):.1f} / {max(secs):.1f} | {np.mean(cpus):.1f} / {max(cpus):.1f} |"
                     if secs else f"| {steps} | {len(sel)} | - |")
    lines += ["", "Rates are over the ground-truth drawers and doors scored (joints; those nobody can open are left "
              "out: spark_bench.opening.judge), each joint one episode per column (eval --rl's default); "
              "holdable joints: a grasp on a handle, a notch, a lid's tab or the front's edges that the grasp planner "
              "gives no reason against (spark_bench.rl.tasks.holdable).", ""]
    out = Path(__file__).resolve().parent / "results" / ("generalist_transfer.md" if oracle else
                                                         f"generalist_transfer_{args.rl_method}.md")
    out.write_text("\n".join(lines))
    print(f"wrote {out}", flush=True)
    return 0


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f}%"


if __name__ == "__main__":
    sys.exit(main())
