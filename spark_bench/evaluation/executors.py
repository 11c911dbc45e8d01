"""Executors: run independent tasks in worker processes and hand each result back as it arrives.

A task is any picklable object; ``evaluate(task) -> list[dict]`` runs it and ``fail(task, reason) ->
list[dict]`` makes the rows of a task that could not run. A crash in native code takes a worker down
with it: the executors find which task did it and fail that task alone, so a long run never dies for
one bad case.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from spark_bench.errors import SparkBenchError

EXECUTORS = ("local", "ray")
#: How often a task may take its worker process down (a crash in native code) before it is failed.
MAX_CRASHES = 2

Evaluate = Callable[[Any], list[dict]]
Fail = Callable[[Any, str], list[dict]]
OnRows = Callable[[list[dict]], None]


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def limit_threads(threads: int) -> None:
    """Pool-worker initializer: at most ``threads`` BLAS/OpenMP/torch threads per worker, so that
    several worker processes do not oversubscribe the cores."""
    # OpenMP reads this when a library that uses it (pykdtree) is first loaded, after this runs
    os.environ["OMP_NUM_THREADS"] = str(threads)
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        pass
    else:
        threadpool_limits(threads)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(threads)


def run_isolated(task: Any, evaluate: Evaluate, fail: Fail) -> list[dict]:
    """One task in a process of its own: a crash there is that task's."""
    with ProcessPoolExecutor(max_workers=1) as pool:
        try:
            return pool.submit(evaluate, task).result()
        except BrokenProcessPool:
            return fail(task, "the worker process died on this case (a crash in native code?)")


def as_completed(futures: Iterable[Future]):
    """Futures in the order they finish (unlike ``concurrent.futures.as_completed``, a broken pool
    does not raise here: each future's ``result()`` does)."""
    remaining = set(futures)
    while remaining:
        done, remaining = wait(remaining, return_when=FIRST_COMPLETED)
        yield from done


def run_local(tasks: list, evaluate: Evaluate, fail: Fail, workers: int, on_rows: OnRows) -> None:
    """Run tasks in a process pool (inline for ``workers == 0``), calling ``on_rows`` as each ends.

    A worker that dies breaks the whole pool, and which task killed it is unknown: the unfinished tasks
    are run again in a fresh pool, and after a second crash one at a time, each in its own process, so
    that the crashing task is found and failed alone.

    :param tasks: the tasks
    :param evaluate: runs one task in a worker
    :param fail: the rows of a task whose worker crashed
    :param workers: worker processes (``0``: in this process)
    :param on_rows: receives each task's rows, in this process
    """
    if workers <= 0:
        for task in tasks:
            on_rows(evaluate(task))
        return
    pending, crashes = list(tasks), 0
    while pending and crashes < MAX_CRASHES:
        with ProcessPoolExecutor(max_workers=workers, initializer=limit_threads,
                                 initargs=(max(1, usable_cores() // workers),)) as pool:
            futures = {pool.submit(evaluate, t): t for t in pending}
            pending = []
            for future in as_completed(futures):
                try:
                    rows = future.result()
                except BrokenProcessPool:
                    pending.append(futures[future])
                    continue
                on_rows(rows)
        crashes += bool(pending)
    for task in pending:
        on_rows(run_isolated(task, evaluate, fail))


def run_ray(tasks: list, evaluate: Evaluate, fail: Fail, workers: int, on_rows: OnRows,
            address: str | None = None) -> None:
    """Run tasks as Ray tasks (a cluster with ``address``, else a local Ray), results back here.

    :param workers: CPUs of a local Ray (``0``: Ray's default)
    :param address: a Ray cluster address
    """
    try:
        import ray
    except ImportError:
        raise SparkBenchError("--executor ray needs Ray: pip install 'spark-bench[ray]'") from None
    if not ray.is_initialized():
        kwargs = {"address": address} if address else ({"num_cpus": workers} if workers > 0 else {})
        ray.init(ignore_reinit_error=True, log_to_driver=False, **kwargs)
    remote = ray.remote(max_retries=MAX_CRASHES - 1)(evaluate)
    refs = {remote.remote(t): t for t in tasks}
    while refs:
        ready, _ = ray.wait(list(refs), num_returns=1)
        for ref in ready:
            task = refs.pop(ref)
            try:
                on_rows(ray.get(ref))
            except Exception as exc:  # a task that died (node lost, worker crash) after its retries
                on_rows(fail(task, f"ray task failed: {type(exc).__name__}: {exc}"))
