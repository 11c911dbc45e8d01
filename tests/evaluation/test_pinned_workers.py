"""A script that imports NumPy before spark_bench runs other CPU kernels than the pinned ones: its eval runs the
cases in worker processes started with the pins (not in the script's process, not in workers forked from it),
says so on stderr, and every row records the pinned kernels its verdicts were made with."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from spark_bench.kernels import NOT_PINNED, NUMPY_ABOVE_AVX2, PINS, cpu_flags

TESTS = Path(__file__).resolve().parents[1]
#: NumPy at its baseline: kernels a CPU with AVX2 does not pick on its own, so "too late" is visible anywhere.
BASELINE_ONLY = "X86_V3 " + NUMPY_ABOVE_AVX2

SCRIPT = """
import json, os, sys
import numpy  # before spark_bench, as in a notebook
os.environ["NPY_DISABLE_CPU_FEATURES"] = {baseline!r}  # too late for the NumPy loaded above

from helpers_bench import FAST, make_tiny_bench
from spark_bench.evaluation.runner import run_eval
from spark_bench.evaluation.store import ResultsStore
from spark_bench.kernels import cpu_kernels
from spark_bench.methods.base import MethodSpec

if __name__ == "__main__":  # the workers are started afresh (spawn) and import this file again
    root = sys.argv[1]
    bench = make_tiny_bench(__import__("pathlib").Path(root), n={n})
    run_eval(MethodSpec.create("oracle"), str(bench), FAST, db=root + "/r.sqlite", workers={workers},
             runs_root=root + "/runs", progress=False)
    with ResultsStore(root + "/r.sqlite") as store:
        rows = store.rows()
    print(json.dumps({{"driver": cpu_kernels(), "pid": os.getpid(),
                      "rows": [[r["info"]["versions"]["cpu kernels"], r["info"]["pid"]] for r in rows]}}))
"""


@pytest.mark.skipif(not {"avx2", "fma"} <= cpu_flags(), reason="needs a CPU with AVX2 to run kernels not asked for")
@pytest.mark.parametrize("workers", [0, 2])
def test_a_process_on_other_kernels_runs_its_cases_in_pinned_workers(tmp_path, workers):
    script = tmp_path / "notebook_like.py"
    script.write_text(textwrap.dedent(SCRIPT.format(baseline=BASELINE_ONLY, n=2, workers=workers)))
    env = {k: v for k, v in os.environ.items() if k not in PINS}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(TESTS), env.get("PYTHONPATH")]))
    done = subprocess.run([sys.executable, str(script), str(tmp_path)], env=env, capture_output=True, text=True,
                          timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["driver"].startswith(f"{NOT_PINNED} (numpy runs X86_V3")
    assert "its cases run in worker processes started with the pins" in done.stderr
    assert len(found["rows"]) == 2
    for kernels, pid in found["rows"]:
        assert pid != found["pid"]  # never in the unpinned process, even with workers=0
        assert kernels.startswith(f"NPY_DISABLE_CPU_FEATURES={BASELINE_ONLY}, OPENBLAS_CORETYPE=")
