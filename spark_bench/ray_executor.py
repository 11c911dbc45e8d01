"""The Ray executor: independent tasks as Ray tasks, on the cluster the user runs or on a private local Ray.

Which Ray (:func:`connect_ray`): the cluster at ``--ray-address`` (or ``RAY_ADDRESS``); else the cluster
``ray start`` last started on this machine (as ``ray.init()`` finds it: never another process's private
Ray); else a private Ray started for this run with ``--workers`` CPUs, gone when the run ends. A failure to connect is
one line, never a traceback.

What reaches the nodes: the tasks (plain data) and the function's module, by reference: every node needs
spark-bench installed, and the files a task names (a benchmark's case folders, the generation cache, a
method's inputs) on a path every node mounts. :func:`missing_paths` asks each node before the run starts,
so that a run on a cluster without them stops with the nodes and paths named instead of failing every case.

A node lost mid-run (or a worker that crashes) loses its running tasks: Ray runs them again elsewhere
(:data:`RAY_RETRIES`), and each task's result is handed back once, when it finally ends. Every task runs
with the pinned CPU kernels (:func:`spark_bench.kernels.pinned_env` in its runtime environment: set before
the worker process starts, whatever the node's own environment).

This module needs nothing of the evaluation (only :mod:`spark_bench.errors` and :mod:`spark_bench.kernels`),
so that any command can run its tasks on Ray (``data prepare`` as well as ``eval``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from spark_bench import kernels
from spark_bench.errors import SparkBenchError

#: How often Ray runs a task again after its worker process or its node died (a lost node, a crash in
#: native code); a task that fails that often is failed with the reason.
RAY_RETRIES = 3
#: Seconds to wait for a cluster's address to answer at all.
CONNECT_TIMEOUT_S = 10
#: Seconds each node may take to answer :func:`missing_paths`.
PATH_CHECK_TIMEOUT_S = 120


def _ray():
    try:
        import ray
    except ImportError:
        raise SparkBenchError("--executor ray needs Ray: pip install 'spark-bench[ray]'") from None
    return ray


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text[:300]


def connect_ray(address: str | None = None, workers: int = 0) -> str:
    """Connect this process to Ray (once; a process already connected stays so) and say to which.

    :param address: a cluster's address (``ray://host:10001``, ``host:6379``); None: ``RAY_ADDRESS``, else
        the cluster running on this machine, else a private local Ray
    :param workers: CPUs of a private local Ray (``0``: all of this machine's); a running cluster's
        own CPUs are used as they are
    :returns: ``"the Ray cluster at ..."``, ``"the Ray cluster running on this machine"``,
        ``"a private local Ray (N CPUs)"`` or ``"the Ray this process was connected to"``
    :raises SparkBenchError: Ray is not installed, or the cluster cannot be reached (one line)
    """
    ray = _ray()
    if ray.is_initialized():
        return "the Ray this process was connected to"
    quiet = {"log_to_driver": False, "logging_level": "warning"}
    address = address or os.environ.get("RAY_ADDRESS") or None
    if address:
        _require_reachable(address)
        try:
            ray.init(address=address, **quiet)
        except Exception as exc:  # ConnectionError, ValueError, grpc errors: all the same to the user
            raise SparkBenchError(f"could not connect to the Ray cluster at {address}: {_one_line(exc)}") from None
        return f"the Ray cluster at {address}"
    cpus = workers if workers > 0 else (os.cpu_count() or 1)
    try:
        # no address: Ray connects to the cluster `ray start` last started on this machine, and refuses a CPU
        # count for it (a cluster has its own), or starts a private one with these CPUs
        ray.init(num_cpus=cpus, include_dashboard=False, **quiet)
    except ValueError as exc:
        if "existing cluster" not in str(exc):
            raise SparkBenchError(f"could not start a local Ray: {_one_line(exc)}") from None
    except Exception as exc:
        raise SparkBenchError(f"could not start a local Ray: {_one_line(exc)}") from None
    else:
        return f"a private local Ray ({cpus} CPUs)"
    try:
        ray.init(**quiet)
    except Exception as exc:
        raise SparkBenchError(f"could not connect to the Ray cluster running here: {_one_line(exc)}") from None
    return f"the Ray cluster running on this machine ({int(ray.cluster_resources().get('CPU', 0))} CPUs)"


def _require_reachable(address: str) -> None:
    """Refuse, in one line, an address nothing answers at (Ray itself would retry for minutes).

    :param address: ``host:port`` or ``ray://host:port``
    """
    import socket

    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        return  # not host:port (a name Ray resolves itself): leave it to Ray
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise SparkBenchError(f"could not connect to the Ray cluster at {address}: {_one_line(exc)} "
                              "(is it running? `ray status` on its head node)") from None


def _task_options() -> dict:
    """Ray options of every task: retried on a lost node or worker, run with the pinned CPU kernels."""
    return {"max_retries": RAY_RETRIES, "runtime_env": {"env_vars": kernels.pinned_env()}}


def _missing_here(paths: Sequence[str]) -> tuple[str, list[str]]:
    import socket

    return socket.gethostname(), [p for p in paths if not os.path.exists(p)]


def missing_paths(paths: Sequence[str]) -> dict[str, list[str]]:
    """``{node: [paths it does not see]}`` over the live nodes with CPUs (empty: every node sees them).

    :param paths: absolute paths the tasks will read or write
    """
    ray = _ray()
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    check = ray.remote(num_cpus=0)(_missing_here)
    refs = {}
    for node in ray.nodes():
        if node.get("Alive") and node.get("Resources", {}).get("CPU", 0) > 0:
            name = f"{node.get('NodeManagerAddress', '?')} ({node['NodeID'][:8]})"
            strategy = NodeAffinitySchedulingStrategy(node_id=node["NodeID"], soft=False)
            refs[name] = check.options(scheduling_strategy=strategy).remote(list(paths))
    out = {}
    for name, ref in refs.items():
        try:
            host, missing = ray.get(ref, timeout=PATH_CHECK_TIMEOUT_S)
        except Exception:  # a node that died or does not answer runs nothing: not a reason to refuse the run
            continue
        if missing:
            out[f"{name} {host}"] = missing
    return out


def require_paths(paths: Sequence[str]) -> None:
    """Refuse a run whose files some node does not see, in one line naming the nodes and the paths.

    :raises SparkBenchError: a node lacks one of ``paths``
    """
    missing = missing_paths(paths)
    if missing:
        where = "; ".join(f"{node}: {', '.join(found)}" for node, found in sorted(missing.items()))
        raise SparkBenchError(f"Ray nodes that do not see the run's files ({where}): put the benchmark and the "
                              "cache on a path every node mounts (docs/cluster.md)")


def ray_map(fn: Callable[[Any], Any], tasks: Sequence[Any], fail: Callable[[Any, str], Any]) -> Iterator[Any]:
    """``fn(task)`` of every task as Ray tasks (connect first: :func:`connect_ray`), each result as it
    arrives, each task's exactly once: a task Ray could not finish after :data:`RAY_RETRIES` (its node lost
    every time, a crash) gives ``fail(task, reason)`` instead.

    :param fn: a module-level function (Ray ships it by reference)
    :param tasks: picklable arguments
    :param fail: the result of a task that could not run
    """
    ray = _ray()
    remote = ray.remote(fn).options(**_task_options())
    refs = {remote.remote(task): task for task in tasks}
    while refs:
        ready, _ = ray.wait(list(refs), num_returns=1)
        for ref in ready:
            task = refs.pop(ref)
            try:
                result = ray.get(ref)
            except Exception as exc:  # its worker or node died once more than the retries allow
                result = fail(task, f"ray task failed: {type(exc).__name__}: {_one_line(exc)}")
            yield result


def run_ray(tasks: list, evaluate: Callable[[Any], list[dict]], fail: Callable[[Any, str], list[dict]],
            workers: int, on_rows: Callable[[list[dict]], None], address: str | None = None,
            paths: Sequence[str] = ()) -> str:
    """Run the eval's tasks on Ray, calling ``on_rows`` with each task's rows in this process.

    :param workers: CPUs of a private local Ray (``0``: all)
    :param address: a Ray cluster address (default: the running local cluster, else a private Ray)
    :param paths: files every node must see (checked before any task runs)
    :returns: which Ray ran them (:func:`connect_ray`)
    """
    where = connect_ray(address, workers)
    if paths and tasks:
        require_paths(paths)
    for rows in ray_map(evaluate, tasks, fail):
        on_rows(rows)
    return where
