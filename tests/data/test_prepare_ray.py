"""``data prepare --executor ray``: one Ray task per object, on a private local Ray, makes the cases the local
executor makes (same files, same ground truth, same manifest, a failed object listed the same way); an address
nothing answers at is one line and writes nothing."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from spark_bench.cli import main

ray = pytest.importorskip("ray", reason="the Ray executor is optional: pip install 'spark-bench[ray]'")

#: Small cases: the point is where they are made, not how well.
SMALL = ["--image-size", "64", "--resolution", "40", "--no-progress"]


def _prepare(src: Path, out: Path, *extra: str, env: dict | None = None) -> subprocess.CompletedProcess:
    """``spark-bench data prepare`` in a process of its own (a private Ray ends with it)."""
    cmd = [sys.executable, "-m", "spark_bench.cli", "data", "prepare", "--src", str(src), "--out", str(out),
           *SMALL, *extra]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=150)


def _files(case: Path) -> list[str]:
    return sorted(str(p.relative_to(case)) for p in case.rglob("*") if p.is_file())


@pytest.mark.slow
def test_ray_makes_the_cases_the_local_executor_makes(tmp_path):
    src = tmp_path / "src"
    assert main(["data", "synth", "--out", str(src), "--n", "2"]) == 0
    (src / "broken").mkdir()  # an object folder without a URDF: failed, listed, the run goes on
    local = _prepare(src, tmp_path / "local")
    # a private Ray of this test's own: its own RAY_TMPDIR (no cluster another process started is found
    # there), no address, no token authentication (as tests/evaluation/test_ray_cluster.py)
    ray_tmp = tempfile.mkdtemp(prefix="rp", dir="/tmp")  # short: Ray's sockets live under it
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    env.update(RAY_TMPDIR=ray_tmp, RAY_AUTH_MODE="disabled")
    try:
        on_ray = _prepare(src, tmp_path / "ray", "--executor", "ray", "--workers", "2", env=env)
    finally:
        shutil.rmtree(ray_tmp, ignore_errors=True)
    assert local.returncode == on_ray.returncode == 1, (local.stderr[-2000:], on_ray.stderr[-2000:])  # 1: failed
    assert "prepared on a private local Ray (2 CPUs)" in on_ray.stderr and "Traceback" not in on_ray.stderr
    assert on_ray.stdout.replace(str(tmp_path / "ray"), "OUT") == local.stdout.replace(str(tmp_path / "local"), "OUT")

    manifests = [json.loads((tmp_path / run / "manifest.json").read_text()) for run in ("local", "ray")]
    assert len(manifests[0]["cases"]) == 2 and list(manifests[0]["failed"]) == ["broken"]
    for key in ("cases", "failed", "options", "source", "convention"):
        assert manifests[0][key] == manifests[1][key], key
    for case_id in manifests[0]["cases"]:
        a, b = tmp_path / "local" / "cases" / case_id, tmp_path / "ray" / "cases" / case_id
        assert _files(a) == _files(b)
        assert (a / "case.json").read_text() == (b / "case.json").read_text()
        assert (a / "gt" / "mobility.urdf").read_text() == (b / "gt" / "mobility.urdf").read_text()
        meshes = [f for f in _files(a) if f.startswith("gt/") and f.endswith(".obj")]
        assert meshes and all((a / f).read_bytes() == (b / f).read_bytes() for f in meshes)
        assert all((b / f).stat().st_size > 0 for f in _files(b) if f.endswith(".png"))


@pytest.mark.slow
def test_an_address_nothing_answers_at_is_one_line_and_writes_nothing(tmp_path, capsys, isolated_home):
    src = tmp_path / "src"
    assert main(["data", "synth", "--out", str(src), "--n", "1"]) == 0
    capsys.readouterr()
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    out = tmp_path / "bench"
    code = main(["data", "prepare", "--src", str(src), "--out", str(out), *SMALL, "--executor", "ray",
                 "--ray-address", f"127.0.0.1:{port}"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "Traceback" not in err and len(err.splitlines()) == 1
    assert f"could not connect to the Ray cluster at 127.0.0.1:{port}" in err
    assert not out.exists()
