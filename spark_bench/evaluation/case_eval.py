"""One case of a run, in a worker: generate (cached), load, score, check and make the rows to store.

:func:`evaluate_case` takes plain data (:class:`~spark_bench.evaluation.tasks.CaseTask`) and returns plain
rows, so it runs in a process pool or as a Ray task. A failing stage fails the case with a one-line reason;
the run goes on. The ground truth is loaded once, as stored (``gt_bench``: the benchmark frame), for the
metrics; the opening scores bring it to metres themselves. Every row records where it ran and the package
versions and CPU kernels its verdicts were made with (:func:`spark_bench.versions.verdict_versions`). The sim
checks run in the engines the run asks for (``eval --engine``): MuJoCo's verdict is the row's ``sim_pass`` and
``checks["sim"]``; PhysX's, where asked, ``checks["sim_physx"]`` (its report, ``passed`` and the SAPIEN release),
and a row of a run without PhysX has no such key.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import time
import traceback
from collections.abc import Callable
from functools import cache, partial
from pathlib import Path

from spark_bench import __version__
from spark_bench.convention import CONVENTION_VERSION
from spark_bench.data.case import BenchmarkCase
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.evaluation.store import now
from spark_bench.evaluation.tasks import CaseTask, EvalOptions
from spark_bench.jsonio import to_json_text
from spark_bench.methods.base import GENERATION_MARKER, CaseInput, Generation
from spark_bench.methods.registry import make_method
from spark_bench.metrics.names import ARTICULATION_KEYS, JOINT_MEAN, METRIC_COLUMNS, RATES
from spark_bench.versions import verdict_versions

#: The episode video kept beside each case's fine-tuned policies (``eval --rl``).
RL_VIDEO = "episode.gif"
#: The key of a row's ``checks`` each check stage records its result under, and the rates read from it
#: (:data:`spark_bench.metrics.names.RATES`): MuJoCo's checks, PhysX's, the scripted opener, the RL transfer score.
SIM_CHECK, PHYSX_CHECK, OPEN_CHECK, RL_CHECK = "sim", "sim_physx", "open", "rl"


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


def _load_prediction(pred_folder: Path):
    from spark_bench.data.readers import load_object

    return load_object(pred_folder)


def _score(pred, gt_bench, options: EvalOptions, threads: int) -> dict:
    from spark_bench.metrics import compute_metrics

    return compute_metrics(pred, gt_bench, n_samples=options.n_samples, seed=options.seed, align=options.align,
                           workers=threads).to_dict()


def _protocol_scores(stages: _Stages, pred, gt_bench, options: EvalOptions) -> dict[str, dict]:
    """``{protocol: ProtocolResult dict}`` of the prediction under each paper's protocol of ``options``; a
    protocol that fails records ``{"protocol", "error"}`` and never fails the case (its metrics stand).
    Each protocol applies its own paper's normalization to the prediction as stored and the case's ground
    truth as stored (the benchmark frame)."""
    from spark_bench.metrics.protocols import score

    out: dict[str, dict] = {}
    for name in options.protocols:
        try:
            out[name] = stages(f"protocol[{name}]", score, name, pred, gt_bench, options.seed).to_dict()
        except StageError as exc:
            out[name] = {"protocol": name, "error": exc.reason}
    return out


def _sim_checks(pred_folder: Path) -> dict:
    from spark_bench.sim import run_checks

    report = run_checks(pred_folder)
    out = report.to_dict()
    out["passed"] = bool(report.passed)
    return out


def _physx_checks(pred_folder: Path) -> dict:
    """The PhysX checks of the prediction (:func:`spark_bench.sim.physx.engines.run_physx_checks`: the hulls and
    masses MuJoCo's checks made, from the shape cache), with the SAPIEN release they ran on."""
    from importlib import metadata

    from spark_bench.sim.physx.engines import run_physx_checks

    report = run_physx_checks(pred_folder)
    out = report.to_dict()
    out["passed"] = bool(report.passed)
    out["sapien"] = metadata.version("sapien")
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


def rate_columns(checks: dict) -> dict:
    """The results-store columns of a row that hold a copy of a rate's case value (:attr:`Rate.column
    <spark_bench.metrics.names.Rate.column>`: ``sim_pass``, ``open_success``, ``rl_success``), for the check
    stages that ran.

    :param checks: the row's ``checks``: each stage's result under its key
    """
    return {h.rate.column: h.rate.from_checks(checks) for h in RATES if h.rate.column and h.rate.check in checks}


def failed_stage_result(name: str, reason: str) -> dict:
    """The result of a check stage that raised, as its first rate (:data:`spark_bench.metrics.names.RATES`) reads
    it: where that is a verdict on the prediction (``kind`` ``pass``: the sim checks), not passed; else (the
    opening scores act on the ground truth) without a value; ``error`` says why.

    :param name: the stage's key in the row's ``checks``
    :param reason: the one-line reason
    """
    first = next(h.rate for h in RATES if h.rate.check == name)
    return {first.result: False if first.kind == "pass" else None, "error": reason}


def _check_stage(stages: _Stages, name: str, fn: Callable, *args) -> dict:
    """A sim-readiness stage; it never fails the case (the metrics stand on their own).

    An exception in the checks of the prediction (``sim``, and ``sim_physx`` in PhysX) means it is not
    sim-ready (``passed`` False, ``error`` says why). The opening stages act on the ground truth: an exception
    there is not the method's doing, so it is recorded without a success rate (:func:`failed_stage_result`). A
    stage whose module is not installed is skipped, and so are the PhysX checks on a worker without SAPIEN (no
    verdict: the coverage shows it).
    """
    from spark_bench.sim.physx import SapienMissing

    try:
        return stages(name, fn, *args)
    except StageError as exc:
        cause = exc.__cause__
        if isinstance(cause, ImportError) and (cause.name or "").startswith("spark_bench."):
            return {"skipped": f"{cause.name} is not installed"}
        if isinstance(cause, SapienMissing):
            return {"skipped": exc.reason}
        return failed_stage_result(name, exc.reason)


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
        # read once, scored by the metrics and by every paper's protocol (its time counts as the metrics')
        pred = stages("metrics", _load_prediction, generation.folder)
        metrics = stages("metrics", _score, pred, gt_bench, task.options, task.threads)
        metrics = _mark_articulation(metrics, generation.articulation_metrics_valid)
        if task.options.protocols:
            metrics["protocols"] = _protocol_scores(stages, pred, gt_bench, task.options)
        row.update(metrics=metrics, **_metric_columns(metrics))
        checks: dict = {}
        # the prediction and the object the scores act on, loaded by the first score that asks and kept for the
        # next (a real object's source takes seconds); a load that fails is not kept: each stage fails on its own
        pairing = cache(partial(_load_pairing, generation.folder, gt_folder, metrics, gt_bench))
        if task.options.sim:
            if "mujoco" in task.options.engines:
                checks[SIM_CHECK] = _check_stage(stages, SIM_CHECK, _sim_checks, generation.folder)
            if task.options.physx:  # after MuJoCo's: its hulls come from the shape cache
                checks[PHYSX_CHECK] = _check_stage(stages, PHYSX_CHECK, _physx_checks, generation.folder)
            checks[OPEN_CHECK] = _check_stage(stages, OPEN_CHECK, _scripted_open, generation.folder, gt_folder,
                                              metrics, task.options.seed, pairing)
        if task.options.rl:
            checks[RL_CHECK] = _check_stage(stages, RL_CHECK, _rl_transfer, generation.folder, gt_folder, metrics,
                                            Path(task.generation_dir).with_name(Path(task.generation_dir).name + ".rl"),
                                            task.options, pairing)
        row.update(checks=checks, status="ok", **rate_columns(checks))
        rows = [row]
        for variant, folder in generation.variants.items():
            vrow = {**_base_row(task, category), "variant": variant, "prediction_dir": str(folder),
                    "shape_metrics_valid": generation.shape_metrics_valid, "info": row["info"]}
            try:
                vpred = stages(f"metrics[{variant}]", _load_prediction, Path(folder))
                vmetrics = stages(f"metrics[{variant}]", _score, vpred, gt_bench, task.options, task.threads)
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


def failed_rows(task: CaseTask, reason: str, stage: str = "worker") -> list[dict]:
    """The row of a case whose worker could not run it (a crash, a lost node), failed at ``stage``."""
    row = _base_row(task, "")
    row.update(status="failed", stage=stage, reason=reason, finished_at=now(),
               info={"case_fingerprint": task.case_fingerprint, "versions": verdict_versions()})
    return [row]
