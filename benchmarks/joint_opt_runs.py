"""SPARK's joint optimization on a benchmark's cases, run and cached per case: what
``measure_joint_opt`` (Table 4, render sizes) and ``measure_joint_opt_real`` (seconds per real object)
share. A run is ``run_ours`` with config overrides and the metrics of its objects, cached in the run's
``table4.json`` (stale when the SPARK sources change: :func:`code_version`).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from rich.console import Console

#: Where the reports go.
RESULTS = Path(__file__).resolve().parent / "results"
#: The rows besides the prior: name -> config overrides.
VARIANTS = {"spark": ["optimize.method=spark"], "native": ["optimize.method=native"],
            "native-masks": ["optimize.method=native", "optimize.part_masks=true"]}
#: The joint errors a run scores.
KEYS = ("axis_err", "pivot_err", "type_err")


def resolve_bench(bench: str) -> Path:
    """A benchmark folder from a path or a named benchmark (built on first use)."""
    from spark_bench.data.case import Benchmark

    path = Path(bench).expanduser()
    if Benchmark(path).cases_dir.is_dir():
        return path
    from spark_bench.data import ensure_benchmark

    return Path(ensure_benchmark(bench))


def case_dirs(bench: Path, limit: int | None, ids: list[str] | None = None) -> list[Path]:
    """The complete cases of ``bench`` (those of ``ids`` if given), the first ``limit`` if given."""
    from spark_bench.data.case import Benchmark

    benchmark = Benchmark(bench)
    cases = [benchmark.case_dir(c) for c in benchmark.complete_case_ids() if not ids or c in ids]
    return cases[:limit] if limit else cases


def code_version() -> str:
    """A hash of the SPARK package's sources and the torch FK, and the metrics' convention version: a
    cached case is stale when they change."""
    import spark_bench.asset.torch_fk as torch_fk
    import spark_bench.methods.ours as spark
    from spark_bench import CONVENTION_VERSION

    digest = hashlib.sha256(CONVENTION_VERSION.encode())
    for path in sorted(Path(spark.__file__).parent.glob("*.py")) + [Path(torch_fk.__file__)]:
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def run_case(case_dir: str, out: str, overrides: list[str], n_samples: int, code: str, score_prior: bool) -> dict:
    """``run_ours`` on one case and the metrics of its refined (and ``prior/``) objects, cached in
    ``out/table4.json`` (``code`` is :func:`code_version` when the run started; ``n_samples`` 0: no
    metrics)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import torch

    torch.set_num_threads(1)
    from spark_bench.data import load_object
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.methods.ours import SparkConfig, run_ours
    from spark_bench.methods.ours.method import ours_case
    from spark_bench.metrics import compute_metrics
    from spark_bench.metrics.report import joint_errors

    case_dir, out = Path(case_dir), Path(out)
    cached = out / "table4.json"
    config = SparkConfig().with_overrides(overrides)
    if cached.is_file():
        row = json.loads(cached.read_text())
        if row.get("config") == config.to_dict() and row.get("code") == code and (
                not score_prior or "prior" in row["scores"]) and (not n_samples or "refined" in row["scores"]):
            return row
    load_before = os.getloadavg()[0]
    start, start_cpu = time.perf_counter(), time.process_time()
    case = ours_case(case_dir, config)  # what the runner hands ``ours``: the declared inputs only
    report = run_ours(case, out, config)
    seconds, cpu_seconds = time.perf_counter() - start, time.process_time() - start_cpu
    load = (load_before + os.getloadavg()[0]) / 2
    gt = BenchmarkCase(case_dir).load_gt()  # the scorer's ground truth, not the method's
    scores, joints = {}, {}
    for variant, folder in (("prior", out / "prior"), ("refined", out))[0 if score_prior else 1:] if n_samples else ():
        metrics = compute_metrics(load_object(folder), gt, n_samples=n_samples, seed=0, workers=1).to_dict()
        scores[variant] = {k: metrics[k] for k in KEYS}
        joints[variant] = joint_errors(metrics)
    row = {"case": case_dir.name, "category": case.category, "label": report["label"], "seconds": seconds,
           "cpu_seconds": cpu_seconds, "load": load, "timings": report["timings"], "scores": scores,
           "joints": joints, "config": config.to_dict(), "code": code,
           "n_joints": len(report.get("movable_joints", [])),
           "n_revolute": sum(1 for j in report.get("prior_joints", []) if j["type"] == "revolute")}
    cached.write_text(json.dumps(row, indent=1))
    return row


def run_tasks(tasks: list[tuple], jobs: int, console: Console) -> dict[tuple, dict]:
    """``tasks`` of ``(key, case_dir, out, overrides, n_samples, score_prior)``; failures are reported and
    skipped. Shows a progress bar."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    code, results = code_version(), {}
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console) as progress, ProcessPoolExecutor(max_workers=jobs) as pool:
        bar = progress.add_task("run_ours + metrics", total=len(tasks))
        futures = {pool.submit(run_case, c, o, ov, n, code, sp): key for key, c, o, ov, n, sp in tasks}
        for future in as_completed(futures):
            key = futures[future]
            try:
                results[key] = future.result()
            except Exception as exc:  # noqa: BLE001 - one bad case must not stop the table
                console.print(f"{key}: failed: {exc!r}")
            progress.advance(bar)
    return results


def cached_results(tasks: list[tuple], console: Console) -> dict[tuple, dict]:
    """``--cached``: the rows of ``tasks`` already under ``--work`` with the task's configuration and
    scores, whatever SPARK sources made them (each row names its ``code``; the report lists them), so
    that a long run can be reported after another edit of the sources; nothing runs."""
    from spark_bench.methods.ours import SparkConfig

    results = {}
    for key, _, out, overrides, n_samples, score_prior in tasks:
        path = Path(out) / "table4.json"
        if not path.is_file():
            continue
        row = json.loads(path.read_text())
        if row.get("config") != SparkConfig().with_overrides(overrides).to_dict():
            console.print(f"{key}: cached with another configuration, left out")
            continue
        if (score_prior and "prior" not in row["scores"]) or (n_samples and "refined" not in row["scores"]):
            continue
        results[key] = row
    console.print(f"{len(results)} of {len(tasks)} runs cached")
    return results


def write_result(console: Console, lines: list[str], name: str) -> int:
    """Print the table ``lines`` and write them to ``results/<name>``; returns the exit status 0."""
    text = "\n".join(lines) + "\n"
    console.print(text)
    out = RESULTS / name
    out.write_text(text)
    console.print(f"wrote {out}")
    return 0
