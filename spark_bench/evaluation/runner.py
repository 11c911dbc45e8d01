"""The eval runner: a method on every case of a benchmark, scored, checked and stored.

Per case (:func:`evaluate_case`, plain data in and out, so it runs in a process pool or as a Ray task):
generate (cached under ``runs/<bench>/<label>-<hash>/<case>/``), load, shape and articulation metrics,
sim-readiness checks, the scripted opener with the predicted joints against the ground-truth object
(:func:`spark_bench.opening.judge.open_with_predicted_joints`), and, with ``rl``, the RL transfer score (the
shipped generalist opening policy fine-tuned on the prediction, run on the ground truth,
:func:`spark_bench.rl.transfer.rl_transfer_score`). A failing stage fails the case with a one-line reason;
the run goes on. The ground truth is loaded once, as stored (``gt_bench``: the benchmark frame), for the
metrics; the opening scores bring it to metres themselves.

The driver (:func:`run_eval`) skips cases whose result is already stored (resume), writes each result
as it arrives, one transaction per case, and shows a progress bar.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import time
import traceback
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from functools import cache, partial
from pathlib import Path

from spark_bench import CONVENTION_VERSION, __version__
from spark_bench.data.case import Benchmark, BenchmarkCase
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.evaluation.executors import EXECUTORS, run_local, run_ray, usable_cores
from spark_bench.evaluation.resume import case_fingerprints, scored_on_this_build
from spark_bench.evaluation.store import ResultsStore, config_hash, now
from spark_bench.jsonio import plain, to_json_text
from spark_bench.methods.base import GENERATION_MARKER, CaseInput, Generation, MethodSpec, prepare_method
from spark_bench.methods.registry import make_method
from spark_bench.metrics.names import ARTICULATION_KEYS, JOINT_MEAN, METRIC_COLUMNS
from spark_bench.rl import FINETUNE_STEPS
from spark_bench.versions import verdict_versions

DEFAULT_BENCH = "synth-v1"
#: The episode video kept beside each case's fine-tuned policies (``eval --rl``).
RL_VIDEO = "episode.gif"


@dataclass(frozen=True)
class EvalOptions:
    """What is measured per case (part of the run's identity: changing it starts a new run).

    :param sim: run the sim-readiness checks and the scripted opener
    :param rl: the RL transfer score: the shipped opening policy fine-tuned on the prediction, zero-shot and
        fine-tuned on the ground truth
    :param n_samples: surface samples per shape for the metrics
    :param seed: sampling seed
    :param align: ``none`` or ``icp``
    :param rl_finetune_steps: fine-tuning steps per policy kind with ``rl`` (0: zero-shot only)
    """

    sim: bool = True
    rl: bool = False
    n_samples: int = 100_000
    seed: int = 0
    align: str = "none"
    rl_finetune_steps: int = FINETUNE_STEPS

    def identity(self) -> dict:
        out = asdict(self)
        if not self.rl:
            out.pop("rl_finetune_steps")
        return out


@dataclass(frozen=True)
class RunIdentity:
    """Who produced the rows of a run, resolved once in the driver.

    :param bench: benchmark name
    :param method: registry name
    :param label: display label (leaderboard row)
    :param regime: input regime
    :param version: method version
    :param config_json: method configuration and eval options, as JSON
    :param config_hash: hash of ``config_json`` (results key)
    :param generation_hash: hash of the method configuration alone (generation cache key)
    """

    bench: str
    method: str
    label: str
    regime: str
    version: str
    config_json: str
    config_hash: str
    generation_hash: str


@dataclass(frozen=True)
class CaseTask:
    """One case of one run, as plain data.

    :param case_id: the case id
    :param case_dir: the case folder
    :param spec: the method
    :param run: the run identity
    :param generation_dir: where this case's generation is cached
    :param options: what to measure
    :param threads: threads for the nearest-neighbour queries in this worker
    :param case_fingerprint: :meth:`BenchmarkCase.fingerprint` of the case when the run was planned
        (stored with the rows and the generation; empty: not checked)
    """

    case_id: str
    case_dir: str
    spec: MethodSpec
    run: RunIdentity
    generation_dir: str
    options: EvalOptions
    threads: int = 1
    case_fingerprint: str = ""


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


# ----- one case -----------------------------------------------------------------------------------
class StageError(Exception):
    """A stage failed: the case is recorded as failed at ``stage`` with the one-line ``reason``."""

    def __init__(self, stage: str, reason: str):
        self.stage, self.reason = stage, " ".join(reason.split())
        super().__init__(f"{stage}: {self.reason}")


def _reason(exc: BaseException) -> str:
    text = str(exc) or type(exc).__name__
    if not isinstance(exc, (SparkBenchError, StageError)):
        text = f"{type(exc).__name__}: {text}"
    return " ".join(text.split())[:500]


class _Stages:
    """Runs named stages, timing each and turning any exception into a :class:`StageError`."""

    def __init__(self):
        self.timings: dict[str, float] = {}

    def __call__(self, name: str, fn: Callable, *args, **kwargs):
        start = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        except StageError:
            raise
        except Exception as exc:  # a method or check may fail in any way: record it, go on
            raise StageError(name, _reason(exc)) from exc
        finally:
            self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - start


def generate_cached(task: CaseTask, method) -> tuple[Generation, bool]:
    """The case's generation: read from the cache marker, or produced now and then marked.

    A generation without its marker (a run killed mid-way), or made from another build of the case (its
    marker's ``case_fingerprint`` differs from the task's), is discarded and redone. The method sees the
    case through a :class:`~spark_bench.methods.base.CaseInput` that refuses every input it did not declare.

    :returns: ``(generation, was_cached)``
    """
    out_dir = Path(task.generation_dir)
    marker = out_dir / GENERATION_MARKER
    if marker.is_file():
        try:
            stored = read_json(marker)
            if not task.case_fingerprint or stored.get("case_fingerprint") == task.case_fingerprint:
                return Generation.from_json(stored), True
        except (InputError, OSError, ValueError, AttributeError):
            pass  # a damaged marker: generate again
    if out_dir.exists():
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True)
    case = CaseInput(BenchmarkCase(task.case_dir), frozenset(method.inputs))
    generation = Generation.from_result(method.generate(case, out_dir), out_dir)
    tmp = marker.with_suffix(".tmp")
    tmp.write_text(to_json_text({**generation.to_json(), "case_fingerprint": task.case_fingerprint}))
    os.replace(tmp, marker)  # atomic: the marker is either absent or complete
    return generation, False


def _base_row(task: CaseTask, category: str) -> dict:
    run = task.run
    return {
        "bench": run.bench, "case_id": task.case_id, "category": category, "method": run.method,
        "label": run.label, "variant": "", "regime": run.regime, "config": json.loads(run.config_json),
        "config_hash": run.config_hash, "method_version": run.version, "package_version": __version__,
        "convention": CONVENTION_VERSION, "case_dir": task.case_dir, "started_at": now(),
    }


def _metric_columns(metrics: dict) -> dict:
    return {column: metrics.get(key) for key, column in METRIC_COLUMNS.items()}


def _mark_articulation(metrics: dict, valid: bool) -> dict:
    """The metrics of a prediction that has no joints at all (a shape-only method) say so: its articulation
    errors (per object and over all joints) are None, stored and averaged as n/a; the part matching stays."""
    if valid:
        return metrics
    return {**metrics, "articulation_metrics_valid": False, JOINT_MEAN: None,
            **{key: None for key in ARTICULATION_KEYS}}


def _score(pred_folder: Path, gt_bench, options: EvalOptions, threads: int) -> dict:
    from spark_bench.data.readers import load_object
    from spark_bench.metrics import compute_metrics

    pred = load_object(pred_folder)
    return compute_metrics(pred, gt_bench, n_samples=options.n_samples, seed=options.seed, align=options.align,
                           workers=threads).to_dict()


def _sim_checks(pred_folder: Path) -> dict:
    from spark_bench.sim import run_checks

    report = run_checks(pred_folder)
    out = report.to_dict()
    out["passed"] = bool(report.passed)
    return out


def _load_pairing(pred_folder: Path, gt_folder: Path, metrics: dict, gt_bench):
    from spark_bench.opening.pairing import load_pairing

    return load_pairing(pred_folder, gt_folder, metrics, gt_bench)


def _scripted_open(pred_folder: Path, gt_folder: Path, metrics: dict, seed: int, pairing: Callable) -> dict:
    from spark_bench.opening.judge import open_with_predicted_joints

    return open_with_predicted_joints(pred_folder, gt_folder, metrics, seed=seed, pairing=pairing())


def _rl_transfer(pred_folder: Path, gt_folder: Path, metrics: dict, out_dir: Path, options: EvalOptions,
                 pairing: Callable) -> dict:
    from spark_bench.rl.transfer import rl_transfer_score

    return rl_transfer_score(pred_folder, gt_folder, metrics, out_dir=out_dir, finetune_steps=options.rl_finetune_steps,
                             seed=options.seed, video=out_dir / RL_VIDEO, pairing=pairing())


def _success_rate(result: dict) -> float | None:
    for key in ("success_rate", "success", "open_success_rate"):
        if result.get(key) is not None:
            return float(result[key])
    return None


def _check_stage(stages: _Stages, name: str, fn: Callable, *args) -> dict:
    """A sim-readiness stage; it never fails the case (the metrics stand on their own).

    An exception in the checks of the prediction (``sim``) means it is not sim-ready (``passed``
    False, ``error`` says why). The opening stages act on the ground truth: an exception there is not
    the method's doing, so it is recorded without a success rate. A stage whose module is not installed
    is skipped.
    """
    try:
        return stages(name, fn, *args)
    except StageError as exc:
        cause = exc.__cause__
        if isinstance(cause, ImportError) and (cause.name or "").startswith("spark_bench."):
            return {"skipped": f"{cause.name} is not installed"}
        if name == "sim":
            return {"passed": False, "error": exc.reason}
        return {"success_rate": None, "error": exc.reason}


def evaluate_case(task: CaseTask) -> list[dict]:
    """Generate, score and check one case; the rows to store (the result, then any variants).

    Never raises for a problem of the case or the method: a failure is a row with ``status='failed'``,
    the stage and a one-line reason.

    :param task: the case and the run
    """
    stages = _Stages()
    category = ""
    row: dict = {}
    case = BenchmarkCase(task.case_dir)
    try:
        record = stages("case", lambda: case.record)
        category = str(record.get("category", ""))
        row = _base_row(task, category)
        method = stages("method", make_method, task.spec)
        generation, cached = stages("generate", generate_cached, task, method)
        row.update(prediction_dir=str(generation.folder), info={**generation.info, "generation_cached": cached},
                   shape_metrics_valid=generation.shape_metrics_valid)
        gt_folder = case.gt_dir
        gt_bench = stages("load_gt", case.load_gt)  # as stored: the benchmark frame (the scores bring it to metres)
        metrics = stages("metrics", _score, generation.folder, gt_bench, task.options, task.threads)
        metrics = _mark_articulation(metrics, generation.articulation_metrics_valid)
        row.update(metrics=metrics, **_metric_columns(metrics))
        checks: dict = {}
        # the prediction and the object the scores act on, loaded by the first score that asks and kept for the
        # next (a real object's source takes seconds); a load that fails is not kept: each stage fails on its own
        pairing = cache(partial(_load_pairing, generation.folder, gt_folder, metrics, gt_bench))
        if task.options.sim:
            checks["sim"] = _check_stage(stages, "sim", _sim_checks, generation.folder)
            row["sim_pass"] = checks["sim"].get("passed")
            checks["open"] = _check_stage(stages, "open", _scripted_open, generation.folder, gt_folder, metrics,
                                          task.options.seed, pairing)
            row["open_success"] = _success_rate(checks["open"])
        if task.options.rl:
            checks["rl"] = _check_stage(stages, "rl", _rl_transfer, generation.folder, gt_folder, metrics,
                                        Path(task.generation_dir).with_name(Path(task.generation_dir).name + ".rl"),
                                        task.options, pairing)
            row["rl_success"] = _success_rate(checks["rl"])
        row.update(checks=checks, status="ok")
        rows = [row]
        for variant, folder in generation.variants.items():
            vrow = {**_base_row(task, category), "variant": variant, "prediction_dir": str(folder),
                    "shape_metrics_valid": generation.shape_metrics_valid, "info": row["info"]}
            try:
                vmetrics = stages(f"metrics[{variant}]", _score, Path(folder), gt_bench, task.options, task.threads)
                vmetrics = _mark_articulation(vmetrics, generation.articulation_metrics_valid)
                vrow.update(metrics=vmetrics, status="ok", **_metric_columns(vmetrics))
            except StageError as exc:
                vrow.update(status="failed", stage=exc.stage, reason=exc.reason)
            rows.append(vrow)
    except StageError as exc:
        row = row or _base_row(task, category)
        row.update(status="failed", stage=exc.stage, reason=exc.reason,
                   info={**row.get("info", {}), "traceback": traceback.format_exc(limit=8)[-4000:]})
        rows = [row]
    finished = now()
    for r in rows:
        r["timings"] = dict(stages.timings)
        r["finished_at"] = finished
        r["info"] = {**r.get("info", {}), "host": socket.gethostname(), "pid": os.getpid(),
                     "versions": verdict_versions(),
                     "case_fingerprint": task.case_fingerprint}
    return rows


def _failed_rows(task: CaseTask, reason: str, stage: str = "worker") -> list[dict]:
    row = _base_row(task, "")
    row.update(status="failed", stage=stage, reason=reason, finished_at=now(),
               info={"case_fingerprint": task.case_fingerprint, "versions": verdict_versions()})
    return [row]


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
                run_ray(tasks, evaluate_case, _failed_rows, workers, on_rows, ray_address)
            else:
                run_local(tasks, evaluate_case, _failed_rows, workers, on_rows)
        rows = [r for r in store.rows(bench=run.bench, label=run.label, where=[("config_hash", run.config_hash)])
                if r["case_id"] in set(all_ids)]
    from spark_bench.evaluation.aggregate import summarize

    main_rows = [r for r in rows if r["variant"] == ""]
    metrics = summarize(main_rows, sim=options.sim, rl=options.rl)  # with --rl always both RL keys
    return EvalSummary(run=run, n_cases=len(all_ids), n_failed=sum(r["status"] == "failed" for r in main_rows),
                       n_skipped=len(all_ids) - len(tasks), metrics=metrics,
                       failures={r["case_id"]: f"{r['stage']}: {r['reason']}" for r in main_rows
                                 if r["status"] == "failed"},
                       seconds=time.perf_counter() - start)


class _NoProgress:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def _maybe_progress(show: bool):
    return _progress() if show else _NoProgress()


__all__ = ["DEFAULT_BENCH", "CaseTask", "EvalOptions", "EvalSummary", "RunIdentity", "evaluate_case",
           "generate_cached", "plan_tasks", "resolve_bench", "run_eval", "run_identity"]
