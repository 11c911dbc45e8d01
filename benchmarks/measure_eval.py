"""Time the whole eval of a benchmark (default ``synth-v1``, no RL) on 2 cores, per stage, with 1 and 2
workers, and report the 2-worker speed-up against the 1-worker run measured here.

Each configuration starts from an empty results store and an empty generation cache, so nothing is
reused between them. Run: ``python benchmarks/measure_eval.py [--bench synth-v1] [--methods oracle,geometry]``
(``--cases 10`` for a quick look; ``--no-sim`` to time the metrics alone).
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
    args = parser.parse_args(argv)

    cores = _pin_to_cores(2)
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


if __name__ == "__main__":
    sys.exit(main())
