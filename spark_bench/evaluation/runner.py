"""The eval runner: a method on every case of a benchmark, scored, checked and stored.

Per case (:func:`~spark_bench.evaluation.case_eval.evaluate_case`, plain data in and out, so it runs in a
process pool or as a Ray task): generate (cached under ``runs/<bench>/<label>-<hash>/<case>/``), load, shape
and articulation metrics, sim-readiness checks (in MuJoCo, and in PhysX where ``options.engines`` asks), the
scripted opener with the predicted joints against the ground-truth object, and, with ``rl``, the RL transfer
score.

The driver (:func:`run_eval`) skips cases whose result is already stored (resume), hands the others to an
executor (:mod:`spark_bench.evaluation.executors`: a process pool, or Ray), writes each result as it
arrives, one transaction per case, and shows a progress bar.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.data.case import Benchmark
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.case_eval import RL_VIDEO, evaluate_case, failed_rows, generate_cached
from spark_bench.evaluation.executors import EXECUTORS, run_local, unpinned_note, usable_cores
from spark_bench.evaluation.resume import case_fingerprints, scored_on_this_build
from spark_bench.evaluation.store import ResultsStore, config_hash
from spark_bench.evaluation.tasks import CaseTask, EvalOptions, RunIdentity
from spark_bench.jsonio import plain
from spark_bench.methods.base import MethodSpec, prepare_method
from spark_bench.methods.registry import make_method
from spark_bench.ray_executor import run_ray

DEFAULT_BENCH = "synth-v1"


@dataclass
class EvalSummary:
    """What a run did: its identity, its cases, and the per-benchmark numbers."""

    run: RunIdentity
    n_cases: int
    n_failed: int
    n_skipped: int
    metrics: dict
    failures: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    def to_json(self) -> dict:
        """The ``eval --json`` document: the method's label and input regime (every ground-truth-derived
        input it read, e.g. ``image + gt camera + gt open image + ...``), the benchmark, the case counts
        and the metrics."""
        return {"method": self.run.label, "regime": self.run.regime, "bench": self.run.bench,
                "n_cases": self.n_cases, "n_failed": self.n_failed, "metrics": self.metrics}


# ----- the benchmark ----------------------------------------------------------------------------
def resolve_bench(bench: str | None) -> tuple[str, Path]:
    """``(name, folder)`` of a benchmark: a folder path, or a name ``ensure_benchmark`` knows.

    :param bench: a benchmark folder, a name (``synth-v1``), or None for :data:`DEFAULT_BENCH`
    """
    bench = bench or DEFAULT_BENCH
    path = Path(bench).expanduser()
    if path.is_dir():
        return Benchmark(path).name, path.resolve()
    from spark_bench.data.benchmarks import ensure_benchmark

    # built in spawned processes: this process forks the evaluation's workers next, and a worker that
    # renders (retrieval, the opener's videos) hangs in EGL's set-up after a fork from a process that rendered
    folder = Path(ensure_benchmark(bench, isolate=True))
    return bench, folder


# ----- the run --------------------------------------------------------------------------------------
def _safe_name(text: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_.=" else "_" for c in text)
    return keep.strip("._") or "method"


def run_identity(bench: str, spec: MethodSpec, options: EvalOptions) -> RunIdentity:
    """Resolve the method once: prepare it (its heavy one-time work, before any worker starts), then its
    label, regime, version and configuration hashes."""
    method = make_method(spec)
    prepare_method(method)
    method_config = plain(method.config())
    full = {"method": spec.name, "method_config": method_config, "version": str(method.version),
            "eval": options.identity()}
    return RunIdentity(
        bench=bench, method=spec.name, label=str(method.label()), regime=str(method.regime),
        version=str(method.version), config_json=json.dumps(full, sort_keys=True),
        config_hash=config_hash(full),
        generation_hash=config_hash({"method": spec.name, "config": method_config,
                                     "version": str(method.version)}))


def default_db() -> Path:
    """``$SPARK_BENCH_HOME/results.sqlite``."""
    from spark_bench.paths import home

    return home() / "results.sqlite"


def plan_tasks(bench_dir: Path, run: RunIdentity, spec: MethodSpec, options: EvalOptions, runs_root: Path,
               done: set[str], threads: int = 1, cases: Iterable[str] | None = None,
               fingerprints: dict[str, str] | None = None) -> list[CaseTask]:
    """The tasks of the cases not yet done.

    :param fingerprints: each case's :meth:`BenchmarkCase.fingerprint` (default: not checked)

    :raises InputError: for a case id that would leave the benchmark's cases folder
    """
    bench = Benchmark(bench_dir)
    gen_root = runs_root / _safe_name(run.bench) / f"{_safe_name(run.label)}-{run.generation_hash[:8]}"
    ids = list(cases) if cases is not None else bench.case_ids()
    fingerprints = fingerprints or {}
    return [CaseTask(cid, str(bench.case_dir(cid)), spec, run, str(gen_root / _safe_name(cid)), options,
                     threads, fingerprints.get(cid, "")) for cid in ids if cid not in done]


def _progress():
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TextColumn("{task.fields[failed]} failed"), TimeRemainingColumn(), transient=False,
                    console=Console(stderr=True))


def run_eval(spec: MethodSpec, bench: str | None = None, options: EvalOptions | None = None,
             db: str | Path | None = None, workers: int = 1, executor: str = "local",
             runs_root: str | Path | None = None, progress: bool = True, ray_address: str | None = None,
             cases: Iterable[str] | None = None) -> EvalSummary:
    """Evaluate a method on every case of a benchmark, resuming where a previous run stopped.

    :param spec: the method
    :param bench: benchmark folder or name (default :data:`DEFAULT_BENCH`)
    :param options: what to measure per case
    :param db: results database (default ``$SPARK_BENCH_HOME/results.sqlite``)
    :param workers: worker processes (``0``: in this process)
    :param executor: ``local`` (process pool) or ``ray``
    :param runs_root: generation cache root (default ``$SPARK_BENCH_HOME/runs``)
    :param progress: show a progress bar
    :param ray_address: Ray cluster address for ``executor="ray"``
    :param cases: only these case ids (default: every case of the benchmark)
    """
    if executor not in EXECUTORS:
        raise SparkBenchError(f"unknown executor {executor!r}; choose from {', '.join(EXECUTORS)}")
    options = options or EvalOptions()
    bench_name, bench_dir = resolve_bench(bench)
    run = run_identity(bench_name, spec, options)
    if runs_root is None:
        from spark_bench.paths import cache_dir

        runs_root = cache_dir("runs")
    threads = max(1, usable_cores() // max(1, workers))
    bench_folder = Benchmark(bench_dir)
    all_ids = list(cases) if cases is not None else bench_folder.case_ids()
    for case_id in all_ids:  # an unsafe id is refused before anything is written
        bench_folder.case_dir(case_id)
    start = time.perf_counter()
    fingerprints = case_fingerprints(bench_folder, all_ids)
    with ResultsStore(db or default_db()) as store:
        done = scored_on_this_build(store, run, fingerprints)
        tasks = plan_tasks(bench_dir, run, spec, options, Path(runs_root), done, threads, all_ids, fingerprints)
        failed = [0]

        with _maybe_progress(progress) as bar:
            job = bar.add_task(run.label, total=len(all_ids), completed=len(all_ids) - len(tasks),
                               failed=0) if bar else None

            def on_rows(rows: list[dict]) -> None:
                store.put(rows)
                failed[0] += rows[0]["status"] == "failed"
                if bar:
                    bar.update(job, advance=1, failed=failed[0])

            if executor == "ray":
                where = run_ray(tasks, evaluate_case, failed_rows, workers, on_rows, ray_address,
                                paths=shared_paths(bench_dir, Path(runs_root), spec))
                _say(f"spark-bench: {len(tasks)} cases ran on {where}", progress)
            else:
                note = unpinned_note() if tasks else None
                if note:
                    _say(note, True)
                run_local(tasks, evaluate_case, failed_rows, workers, on_rows)
        rows = [r for r in store.rows(bench=run.bench, label=run.label, where=[("config_hash", run.config_hash)])
                if r["case_id"] in set(all_ids)]
    from spark_bench.evaluation.aggregate import summarize

    main_rows = [r for r in rows if r["variant"] == ""]
    # with --rl always both RL keys; with --engine physx|all the PhysX sim pass and its coverage
    metrics = summarize(main_rows, sim=options.sim, rl=options.rl, physx=options.physx)
    return EvalSummary(run=run, n_cases=len(all_ids), n_failed=sum(r["status"] == "failed" for r in main_rows),
                       n_skipped=len(all_ids) - len(tasks), metrics=metrics,
                       failures={r["case_id"]: f"{r['stage']}: {r['reason']}" for r in main_rows
                                 if r["status"] == "failed"},
                       seconds=time.perf_counter() - start)


def shared_paths(bench_dir: Path, runs_root: Path, spec: MethodSpec) -> list[str]:
    """The files every worker node must see: the benchmark, the generation cache (the tasks write it, the
    leaderboard reads it back) and the method's own absolute inputs (a predictions folder, a methods file,
    a configuration, a gallery)."""
    inputs = [str(v) for v in spec.option_dict.values() if isinstance(v, str) and Path(v).is_absolute()]
    runs_root.mkdir(parents=True, exist_ok=True)
    return [str(bench_dir), str(runs_root.resolve()), *inputs]


def _say(line: str, show: bool) -> None:
    if show:
        print(line, file=sys.stderr, flush=True)


class _NoProgress:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def _maybe_progress(show: bool):
    return _progress() if show else _NoProgress()


__all__ = ["DEFAULT_BENCH", "RL_VIDEO", "CaseTask", "EvalOptions", "EvalSummary", "RunIdentity", "evaluate_case",
           "generate_cached", "plan_tasks", "resolve_bench", "run_eval", "run_identity", "usable_cores"]
