"""Executors: run independent tasks in worker processes and hand each result back as it arrives.

A task is any picklable object; ``evaluate(task) -> list[dict]`` runs it and ``fail(task, reason) ->
list[dict]`` makes the rows of a task that could not run. A crash in native code takes a worker down
with it: the executors find which task did it and fail that task alone, so a long run never dies for
one bad case.

Every worker runs the pinned CPU kernels (:mod:`spark_bench.kernels`): a pool's workers are forked from a
pinned process, or, when this process runs other kernels (its NumPy loaded before ``spark_bench``),
started afresh with the pins in their environment; Ray's workers get them in the job's runtime
environment (:mod:`spark_bench.ray_executor`).
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from spark_bench import kernels

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


def pool_context():
    """The way a pool starts its workers: forked from this process where it runs the pinned kernels (the
    workers inherit them, and nothing is imported twice); started afresh (``spawn``) where it does not, so
    that each worker loads NumPy and torch with the pins already in its environment."""
    if kernels.kernels_hold():
        return None
    os.environ.update(kernels.pinned_env())
    return multiprocessing.get_context("spawn")


def unpinned_note() -> str | None:
    """What the driver says when its own kernels are not the pinned ones (None when they are): its cases
    run in pinned worker processes, never in it."""
    if kernels.kernels_hold():
        return None
    return (f"spark-bench: this process's CPU kernels are {kernels.cpu_kernels()}; its cases run in worker "
            "processes started with the pins (import spark_bench before NumPy to run them here)")


def run_isolated(task: Any, evaluate: Evaluate, fail: Fail) -> list[dict]:
    """One task in a process of its own: a crash there is that task's."""
    with ProcessPoolExecutor(max_workers=1, mp_context=pool_context()) as pool:
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
    :param workers: worker processes (``0``: in this process, if its kernels are the pinned ones; else in one
        worker process started with them)
    :param on_rows: receives each task's rows, in this process
    """
    context = pool_context()
    if workers <= 0 and context is None:
        for task in tasks:
            on_rows(evaluate(task))
        return
    workers = max(1, workers)
    pending, crashes = list(tasks), 0
    while pending and crashes < MAX_CRASHES:
        with ProcessPoolExecutor(max_workers=workers, initializer=limit_threads, mp_context=context,
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
