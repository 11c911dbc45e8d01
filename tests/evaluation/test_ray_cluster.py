"""``eval --executor ray`` as users run it: on the Ray cluster running on the machine (``ray start``), on one at
``--ray-address``, never a traceback; a worker node lost mid-run has its cases run again, none lost or
duplicated; the run's files checked on every node; every task on the pinned CPU kernels."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest
from helpers_bench import make_tiny_bench

from spark_bench.cli import main
from spark_bench.data.case import Benchmark
from spark_bench.evaluation.store import ResultsStore
from spark_bench.kernels import PINS, cpu_kernels, pinned_env

ray = pytest.importorskip("ray", reason="the Ray executor is optional: pip install 'spark-bench[ray]'")

RAY = str(Path(sys.executable).parent / "ray")
#: A lost node is noticed in about 3 s instead of Ray's default 30 s.
FAST_HEALTH_CHECK = {"RAY_health_check_period_ms": "1000", "RAY_health_check_timeout_ms": "1000",
                     "RAY_health_check_failure_threshold": "3"}


def test_an_address_nothing_answers_at_is_one_line(tmp_path, capsys, isolated_home):
    bench = make_tiny_bench(tmp_path, n=1)
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    code = main(["eval", "--method", "oracle", "--bench", str(bench), "--no-sim", "--executor", "ray",
                 "--ray-address", f"127.0.0.1:{port}", "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "Traceback" not in err
    assert f"could not connect to the Ray cluster at 127.0.0.1:{port}" in err and len(err.splitlines()) == 1


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _ray_node(args: list[str], env: dict, log: Path) -> subprocess.Popen:
    """A Ray node in a session of its own (``ray start --block``): killing its process group kills the node,
    its raylet and its workers, and nothing of any other Ray on the machine (never ``ray stop``)."""
    return subprocess.Popen([RAY, "start", "--block", "--disable-usage-stats", *args], env=env, stdout=log.open("w"),
                            stderr=subprocess.STDOUT, start_new_session=True)


def _wait_for_cpus(env: dict, cpus: int, deadline: float) -> None:
    code = "import ray; ray.init(logging_level='error'); print(int(ray.cluster_resources().get('CPU', 0)))"
    while time.time() < deadline:
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
        if done.stdout.strip().splitlines()[-1:] == [str(cpus)]:
            return
        time.sleep(1)
    raise AssertionError(f"the test cluster did not reach {cpus} CPUs")


@pytest.fixture(scope="module")
def two_node_cluster(tmp_path_factory):
    """A head node and a worker node on this machine, 1 CPU each, found by ``ray.init()`` through their own
    ``RAY_TMPDIR`` (no other process on the machine sees them). Their environment has no pins and asks
    OpenBLAS for other kernels than the pins: only the tasks' runtime environment can pin them. One for the
    module (a cluster takes 20 s to start): the test that kills its worker node runs last."""
    logs = tmp_path_factory.mktemp("ray-logs")
    tmp = Path(tempfile.mkdtemp(prefix="rt", dir="/tmp"))  # short: Ray's sockets live under it
    env = {k: v for k, v in os.environ.items() if k not in PINS and not k.startswith("RAY_")}
    # RAY_AUTH_MODE: a head started where ~/.ray/auth_token exists turns token authentication on, and a worker
    # node then needs the token too (Ray's own rule); this private test cluster goes without
    env.update(RAY_TMPDIR=str(tmp), RAY_AUTH_MODE="disabled", OPENBLAS_CORETYPE="Prescott", **FAST_HEALTH_CHECK)
    port = _free_port()
    head = _ray_node(["--head", "--port", str(port), "--num-cpus", "1", "--include-dashboard", "false"], env,
                     logs / "head.log")
    worker = None
    try:
        _wait_for_cpus(env, 1, time.time() + 60)
        worker = _ray_node(["--address", f"127.0.0.1:{port}", "--num-cpus", "1"], env, logs / "worker.log")
        _wait_for_cpus(env, 2, time.time() + 60)
        yield {"env": env, "worker": worker, "address": f"127.0.0.1:{port}"}
    finally:
        for node in (worker, head):
            if node is not None:
                os.killpg(node.pid, signal.SIGKILL)
                node.wait()


def _slow_copier(tmp_path: Path, source: Path, started: Path) -> Path:
    """A command method that marks each start (case, pid), works 4 s, then copies ``source``."""
    program = tmp_path / "method.py"
    program.write_text(textwrap.dedent(f"""
        import os, shutil, sys, time
        from pathlib import Path
        case_id, out = sys.argv[3], sys.argv[2]
        Path({str(started)!r}, f"{{case_id}}-{{os.getpid()}}").touch()
        time.sleep(4.0)
        shutil.copytree({str(source)!r}, out, dirs_exist_ok=True)
    """))
    methods = tmp_path / "methods.toml"
    methods.write_text(f'[methods.copier]\ncommand = [{json.dumps(sys.executable)}, {json.dumps(str(program))}, '
                       f'"{{image}}", "{{out}}", "{{case_id}}"]\ntimeout = 60\nversion = "0.1"\n')
    return methods


@pytest.mark.slow
def test_each_node_is_asked_for_the_run_s_files(two_node_cluster, tmp_path, monkeypatch):
    """Before a run, every node says which of the run's files it does not see: a run whose benchmark is not on
    a path every node mounts stops with the nodes and paths named, before any case runs."""
    from spark_bench.errors import SparkBenchError
    from spark_bench.ray_executor import connect_ray, missing_paths, require_paths

    monkeypatch.setenv("RAY_TMPDIR", two_node_cluster["env"]["RAY_TMPDIR"])
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    try:
        assert connect_ray(two_node_cluster["address"]) == f"the Ray cluster at {two_node_cluster['address']}"
        absent = str(tmp_path / "not-mounted")
        missing = missing_paths([str(tmp_path), absent])
        assert len(missing) == 2 and all(found == [absent] for found in missing.values())  # both nodes
        require_paths([str(tmp_path)])
        with pytest.raises(SparkBenchError, match="not-mounted"):
            require_paths([absent])
    finally:
        ray.shutdown()


@pytest.mark.slow
def test_a_worker_node_lost_mid_run_has_its_cases_run_again(two_node_cluster, tmp_path):
    """``eval --executor ray`` without an address runs on the cluster running here (before: "ValueError: When
    connecting to an existing cluster, num_cpus and num_gpus must not be provided"). The worker node is killed
    while both nodes run a case: every case still ends with exactly one row, and a case ran twice."""
    n = 4
    bench = make_tiny_bench(tmp_path, n=n)
    started = tmp_path / "started"
    started.mkdir()
    methods = _slow_copier(tmp_path, Benchmark(bench).case("cab0").gt_dir, started)
    db = tmp_path / "r.sqlite"
    cmd = [sys.executable, "-m", "spark_bench.cli", "eval", "--method", "copier", "--methods-file", str(methods),
           "--bench", str(bench), "--no-sim", "--n-samples", "2000", "--db", str(db), "--runs-dir",
           str(tmp_path / "runs"), "--executor", "ray", "--workers", "2"]
    env = {**two_node_cluster["env"], "SPARK_BENCH_HOME": str(tmp_path / "home")}
    env.pop("OPENBLAS_CORETYPE")
    run = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    try:
        deadline = time.time() + 60
        while len(list(started.iterdir())) < 2 and time.time() < deadline:
            time.sleep(0.2)
        assert len(list(started.iterdir())) >= 2, "the two nodes did not both start a case"
        os.killpg(two_node_cluster["worker"].pid, signal.SIGKILL)  # mid-case: its case is 4 s long
        out, err = run.communicate(timeout=150)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 0, err[-3000:]
    assert "ran on the Ray cluster running on this machine" in err and "Traceback" not in err
    with ResultsStore(db) as store:
        rows = store.rows()
    assert sorted(r["case_id"] for r in rows) == [f"cab{k}" for k in range(n)]  # none lost, none twice
    assert all(r["status"] == "ok" for r in rows), [r.get("reason") for r in rows]
    starts = [p.name.split("-")[0] for p in started.iterdir()]
    assert len(starts) > n, "the killed node's case was not run again"
    # the nodes' own environment asks OpenBLAS for other kernels: the tasks ran on the pinned ones
    assert {r["info"]["versions"]["cpu kernels"] for r in rows} == {cpu_kernels()}
    assert f"OPENBLAS_CORETYPE={pinned_env()['OPENBLAS_CORETYPE']}" in cpu_kernels()
