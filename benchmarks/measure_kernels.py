"""Do the verdicts depend on the CPU? The floating-point work behind them, and `eval` itself, run natively and
under other x86 CPUs emulated by QEMU's user-mode emulator (Debian's ``qemu-user``: ``qemu-x86_64 -cpu MODEL``
runs this machine's Python with another CPU's CPUID, so every library dispatches as it would there).

Two parts:

- **Kernels**: a probe of each library whose numbers reach a verdict (NumPy, SciPy, torch's matrix products,
  vector functions, square roots, Adam steps and convolutions, CoACD, MuJoCo, PyBullet) hashes its results'
  bits; each row is one CPU, each cell says whether its bits equal this machine's. Run with spark-bench's pins
  (:mod:`spark_bench.kernels`) and, with ``--unpinned``, once more with MKL left to choose its own branch
  (``MKL_CBWR=AUTO``), as before the pin.
- **Verdicts**: ``spark-bench eval --method ours`` on ``--cases`` of a prepared benchmark (``--bench``;
  default the main job's ``synth-v1``; a real one too, read in place), natively and under each emulated
  CPU, each in a fresh home; compared are every row's verdicts and numbers
  (sim checks, opening score, joint errors; not their timings) and the predicted URDF files' bytes. QEMU 7.2
  crashes in NumPy's AVX2 code (a ``np.unique`` in trimesh's vertex merge), so these runs, the native one
  included, use NumPy's baseline kernels (``NPY_DISABLE_CPU_FEATURES``; ``--numpy-avx2`` for a QEMU that
  does not crash): NumPy dispatches by instruction set alone and is pinned already, the part checks the rest.
  ``--code DIR`` runs another checkout's ``spark_bench`` (a commit before a change, for the "before" row).

An AVX-512 model (``Icelake-Server``) is in the list, and each CPU's row says what the emulated CPU offers
NumPy (its ``__cpu_features__`` without the pins: ``AVX-512: yes/no``), so that a row is never taken for an
AVX-512 test it was not: QEMU's translator (7.2, Debian 12's) implements no AVX-512, so under it
``Icelake-Server`` offers only AVX2 and tells nothing AVX-512 would; on a real AVX-512 machine the native row
is the AVX-512 one. ``--numpy-first`` also runs the verdict part as a script that imports NumPy before
spark_bench (``import numpy`` and then the CLI, in one process), the order of a notebook: its rows must
equal the CLI's.

What emulation cannot show: QEMU computes the approximate instructions (``rcpps``/``rsqrtps``) exactly, as no
real CPU does, so a function built on them differs between QEMU and this machine as it would between two real
CPU makers. Emulation is slow (about 8x): a case takes minutes.

Run from the repository root: ``python -m benchmarks.measure_kernels [--cpus Haswell-v4,EPYC-v3,Icelake-Server]
[--cases Dishwasher_00009,Door_00004] [--numpy-first]`` (needs ``qemu-x86_64`` on the PATH: Debian's
``qemu-user``; writes ``benchmarks/results/kernels.md``; ``--jobs`` runs at once).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from importlib import import_module
from pathlib import Path

#: The environment as the user set it: the runs get it, not the pins spark_bench would set in this process
#: (a run of another checkout, ``--code``, pins what that checkout pins).
USER_ENV = dict(os.environ)
RESULTS = Path(__file__).resolve().parent / "results"
#: Emulated CPUs: Intel and AMD with AVX2 and FMA (the kernels spark-bench pins), and an Intel AVX-512 model
#: (offered as such only by a QEMU that emulates AVX-512: each row says what its CPU offered).
CPUS = ("Haswell-v4", "EPYC-v3", "Icelake-Server")
#: NumPy's dispatch targets of an AVX-512 CPU, as ``__cpu_features__`` names them.
AVX512_TARGETS = ("AVX512F", "X86_V4", "AVX512_SKX", "AVX512_ICL")
#: Prints what the CPU offers NumPy (no spark_bench, no pins): run natively or under QEMU.
CPU_OFFERS = ("import json; from numpy._core._multiarray_umath import __cpu_features__ as f; "
              "print(json.dumps(sorted(k for k, v in f.items() if v)))")
#: NumPy at its baseline kernels (the verdict part's workaround for QEMU 7.2's crash in its AVX2 code).
NUMPY_BASELINE = "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"
CASES = ("Dishwasher_00009", "Door_00004")
#: The fields of a results row that carry a verdict or a number the leaderboard shows.
ROW_FIELDS = ("status", "reason", "axis_err", "pivot_err", "type_err", "sim_pass", "open_success", "cd",
              "fscore_01", "checks", "metrics")


def _digest(values) -> str:
    import numpy as np

    return hashlib.sha1(np.ascontiguousarray(values).tobytes()).hexdigest()[:12]


def probe() -> dict[str, str]:
    """Hashes of each library's results on fixed inputs, in this process (spark_bench imported first)."""
    import_module("spark_bench")  # first: it pins the CPU kernels before NumPy and torch load
    import coacd
    import mujoco
    import numpy as np
    import pybullet
    import scipy.spatial
    import torch
    import torch.nn.functional as F
    import trimesh

    from spark_bench.versions import CPU_KERNELS, verdict_versions

    try:
        from spark_bench.methods.ours import exact
    except ImportError:  # a checkout from before it (--code)
        exact = None

    torch.set_num_threads(1)  # as spark-bench's torch work runs (joint optimizer, RL fine-tuning)
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((300, 257)), rng.standard_normal((257, 190))
    out = {"numpy matmul": _digest(a @ b), "numpy exp, sin, sum": _digest(np.exp(np.sin(a)).sum(0)),
           "numpy sqrt": _digest(np.sqrt(np.abs(a))), "numpy svd": _digest(np.linalg.svd(a[:50, :50])[1]),
           "scipy kd-tree": _digest(scipy.spatial.cKDTree(a[:, :3]).query(b.T[:, :3])[0])}
    x, w = torch.from_numpy(a.astype(np.float32)), torch.from_numpy(b.astype(np.float32))
    out["torch mm (MKL)"] = _digest((x @ w).numpy())
    out["torch exp, log, sin, cos, tanh"] = _digest(torch.stack(
        [f(x.abs() + 0.1) for f in (torch.exp, torch.log, torch.sin, torch.cos, torch.tanh)]).numpy())
    out["torch.sqrt (MKL)"] = _digest(torch.sqrt(x.abs()).numpy())
    out["exact.sqrt (spark-bench)"] = _digest(exact.sqrt(x.abs()).numpy()) if exact else "absent"
    out["torch conv2d (oneDNN)"] = _digest(F.conv2d(x[None, None, :64, :64], torch.ones(1, 1, 3, 3) / 9).numpy())

    def trained(**adam) -> str:
        torch.manual_seed(0)
        net = torch.nn.Sequential(torch.nn.Linear(257, 64), torch.nn.Tanh(), torch.nn.Linear(64, 8))
        opt = torch.optim.Adam(net.parameters(), lr=1e-3, **adam)
        for _ in range(20):
            loss = (net(x) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
        return _digest(torch.cat([p.detach().flatten() for p in net.parameters()]).numpy())

    out["torch Adam, unfused"] = trained()
    out["torch Adam, fused (spark-bench)"] = trained(fused=True)
    mesh = trimesh.creation.annulus(0.3, 0.5, 0.4, sections=24)
    hulls = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=0.08, seed=0, max_convex_hull=6)
    out["coacd"] = _digest(np.concatenate([np.asarray(v).ravel() for v, _ in hulls]))
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><geom type='plane' size='2 2 .1'/><body pos='0 0 .5'><freejoint/>"
        "<geom type='box' size='.1 .07 .05' euler='10 20 30'/></body><body pos='.05 0 .8'><freejoint/>"
        "<geom type='capsule' size='.04 .1' euler='40 5 0'/></body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    for _ in range(800):
        mujoco.mj_step(model, data)
    out["mujoco"] = _digest(data.qpos)
    client = pybullet.connect(pybullet.DIRECT)
    pybullet.createMultiBody(0, pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client),
                             physicsClientId=client)
    box = pybullet.createMultiBody(
        1, pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[.1, .07, .05], physicsClientId=client),
        basePosition=[0, 0, .5], baseOrientation=pybullet.getQuaternionFromEuler([.2, .3, .4]),
        physicsClientId=client)
    pybullet.setGravity(0, 0, -9.8, physicsClientId=client)
    for _ in range(500):
        pybullet.stepSimulation(physicsClientId=client)
    pose = pybullet.getBasePositionAndOrientation(box, physicsClientId=client)
    out["pybullet"] = _digest(np.array(pose[0] + pose[1]))
    out["_kernels"] = verdict_versions()[CPU_KERNELS]
    return out


def _python(cpu: str | None) -> list[str]:
    return ([] if cpu is None else ["qemu-x86_64", "-cpu", cpu]) + [sys.executable]


def cpu_offers(cpu: str | None, env: dict) -> str:
    """What NumPy finds on the CPU (``cpu`` under QEMU, None: natively), without the pins: ``AVX-512: yes``
    with the AVX-512 targets found, ``AVX-512: no`` (the highest x86 target found), or the error."""
    clean = {k: v for k, v in env.items() if k != "NPY_DISABLE_CPU_FEATURES"}
    done = subprocess.run(_python(cpu) + ["-c", CPU_OFFERS], env=clean, capture_output=True, text=True, timeout=600)
    if done.returncode:
        return "error: " + (done.stderr.strip().splitlines() or ["no output"])[-1][:120]
    features = set(json.loads(done.stdout.strip().splitlines()[-1]))
    found = [t for t in AVX512_TARGETS if t in features]
    if found:
        return f"AVX-512: yes ({' '.join(found)})"
    top = next((t for t in ("X86_V3", "X86_V2") if t in features), "baseline")
    return f"AVX-512: no (up to {top})"


def run_probe(cpu: str | None, env: dict) -> dict:
    """:func:`probe` in a fresh process, natively (``cpu`` None) or under ``qemu-x86_64 -cpu cpu``."""
    # this file as a script, not ``-m`` from the root: a ``--code`` checkout on PYTHONPATH must come before the root
    done = subprocess.run(_python(cpu) + [__file__, "--probe"], env=env, capture_output=True, text=True,
                          timeout=3600)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode or not lines:
        return {"_error": (done.stderr.strip().splitlines() or ["no output"])[-1][:200]}
    return json.loads(lines[-1])


#: The CLI run from a script that imports NumPy first (a notebook's order), in one process.
NUMPY_FIRST = ("import numpy, runpy, sys; sys.argv = ['spark-bench', *sys.argv[1:]]; "
               "runpy.run_module('spark_bench.cli', run_name='__main__')")


def run_eval(cpu: str | None, bench: Path, cases: list[str], home: Path, env: dict, numpy_first: bool = False) -> dict:
    """``spark-bench eval --method ours`` on ``cases`` of the prepared benchmark folder ``bench`` (read in
    place), in a fresh home: per case and variant, the row's verdict fields, and the prediction files' digests.

    :param numpy_first: run it from a script that imports NumPy before spark_bench (:data:`NUMPY_FIRST`)
    """
    home.mkdir(parents=True)
    t0 = time.perf_counter()
    entry = ["-c", NUMPY_FIRST] if numpy_first else ["-m", "spark_bench.cli"]
    done = subprocess.run(_python(cpu) + entry + ["eval", "--method", "ours", "--bench",
                                                  str(bench.resolve()), "--cases", ",".join(cases), "--workers",
                                                  "0", "--no-progress"],
                          env={**env, "SPARK_BENCH_HOME": str(home)}, capture_output=True, text=True, timeout=7200,
                          cwd=home)  # not this folder: `python -m` would import its spark_bench before PYTHONPATH's
    out: dict = {"_wall_s": round(time.perf_counter() - t0, 1)}
    if done.returncode:
        out["_error"] = (done.stderr.strip().splitlines() or ["no output"])[-1][:200]
    db = home / "results.sqlite"
    if db.is_file():
        with sqlite3.connect(db) as connection:
            query = f"select case_id, variant, info, {', '.join(ROW_FIELDS)} from results"
            for case, variant, info, *fields in connection.execute(query):
                out[f"{case} {variant}".strip()] = {f: without_timings(v) for f, v in zip(ROW_FIELDS, fields)}
                out.setdefault("_kernels", set()).add(json.loads(info or "{}").get("versions", {}).get("cpu kernels"))
    for path in sorted((home / "runs").rglob("*.urdf")):
        out[f"file {path.relative_to(home / 'runs')}"] = hashlib.sha1(path.read_bytes()).hexdigest()[:12]
    return out


#: Checks whose value is a time (``spark_bench.sim.checks``: ``mjcf_compiles`` is seconds to compile).
TIMED_CHECKS = ("mjcf_compiles",)


def without_timings(value, key: str = ""):
    """A row field with its timings left out (the ``seconds`` tables, ``convert_seconds``, the value of a timed
    check): what a machine's speed changes, not its arithmetic. A configured duration (a check's ``seconds``
    of simulated time, a number) stays."""
    if isinstance(value, str) and value[:1] in "{[":
        try:
            return without_timings(json.loads(value), key)
        except json.JSONDecodeError:
            return value
    if isinstance(value, dict):
        return {k: without_timings(v, k) for k, v in value.items()
                if not (k == "seconds" and isinstance(v, dict)) and k != "convert_seconds"
                and not (key in TIMED_CHECKS and k == "value")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def compare(native: dict, other: dict) -> list[str]:
    """The keys whose values differ (or are missing on one side), internal keys (``_``) aside."""
    keys = sorted(k for k in set(native) | set(other) if not k.startswith("_"))
    return [k for k in keys if native.get(k) != other.get(k)]


def _row_differences(native: dict, other: dict) -> list[str]:
    found = []
    for key in compare(native, other):
        a, b = native.get(key), other.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            fields = [f for f in ROW_FIELDS if a.get(f) != b.get(f)]
            found.append(f"{key}: {', '.join(fields)}")
        else:
            found.append(f"{key}: {'missing' if a is None or b is None else 'other bytes'}")
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--probe", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--cpus", default=",".join(CPUS), help="QEMU CPU models (qemu-x86_64 -cpu help)")
    parser.add_argument("--cases", default=",".join(CASES), help="synth-v1 cases for the verdict part ('': none)")
    parser.add_argument("--bench", default=None, help="a prepared benchmark folder (default: synth-v1, built)")
    parser.add_argument("--unpinned", action="store_true", help="also probe with MKL_CBWR=AUTO (before the pin)")
    parser.add_argument("--numpy-avx2", action="store_true", help="verdict part: NumPy's AVX2 kernels too")
    parser.add_argument("--numpy-first", action="store_true",
                        help="verdict part: also from a script that imports NumPy before spark_bench")
    parser.add_argument("--code", default=None, help="run this checkout's spark_bench (PYTHONPATH)")
    parser.add_argument("--jobs", type=int, default=2, help="runs at once")
    parser.add_argument("--out", default=str(RESULTS / "kernels.md"))
    args = parser.parse_args(argv)
    if args.probe:
        print(json.dumps(probe()))
        return 0
    if shutil.which("qemu-x86_64") is None:
        print("needs qemu-x86_64 (Debian: apt-get install qemu-user)", file=sys.stderr)
        return 2
    cpus = [c for c in args.cpus.split(",") if c]
    cases = [c for c in args.cases.split(",") if c]
    env = dict(USER_ENV)
    if args.code:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(Path(args.code).resolve()), env.get("PYTHONPATH")) if p)
    settings = [("pinned", env)] + ([("MKL_CBWR=AUTO", {**env, "MKL_CBWR": "AUTO"})] if args.unpinned else [])
    offers = {cpu: cpu_offers(cpu, env) for cpu in [None, *cpus]}
    probes, lines = _kernel_section(args, cpus, settings, offers)
    runs = _verdict_section(args, cpus, env, lines) if cases else {}
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    raw = {"offers": {cpu or "native": text for cpu, text in offers.items()},
           "probes": {f"{name} {cpu or 'native'}": found for (name, cpu), found in probes.items()},
           "runs": {key: found for key, found in runs.items()}}
    Path(args.out).with_suffix(".json").write_text(json.dumps(raw, indent=1, default=str), encoding="utf-8")
    print("\n".join(lines))
    return 0


def _kernel_section(args, cpus: list[str], settings: list[tuple[str, dict]], offers: dict) -> tuple[dict, list[str]]:
    """The probes of every CPU and setting, and the report's first part: what each CPU offered, and per
    library whether its bits equal the native ones."""
    from rich.progress import track

    from spark_bench.kernels import cpu_field

    jobs = [(name, cpu) for name, _ in settings for cpu in [None, *cpus]]
    with ThreadPoolExecutor(max(1, args.jobs)) as pool:
        futures = [pool.submit(run_probe, cpu, dict(settings)[name]) for name, cpu in jobs]
        probes = dict(zip(jobs, [f.result() for f in track(futures, description="kernel probes")]))
    lines = ["# Do the verdicts depend on the CPU?", "",
             f"`benchmarks/measure_kernels.py`, {time.strftime('%Y-%m-%d')}: this machine ("
             f"{cpu_field('model name') or 'unknown CPU'}) natively, and under QEMU user-mode emulation (`qemu-x86_64 -cpu MODEL`, "
             f"{_qemu_version()}) as {', '.join(cpus)}. Recorded kernels: "
             f"`{probes[('pinned', None)].get('_kernels', '?')}`."
             + (f" Code: `{args.code}`." if args.code else ""), "",
             "What each CPU offers NumPy (unpinned): " + "; ".join(f"{cpu or 'native'}: {text}"
                                                              for cpu, text in offers.items()) + ".", "",
             "## Kernels: the bits of each library's results (same: equal to this machine's, natively)", ""]
    keys = [k for k in probes[("pinned", None)] if not k.startswith("_")]
    columns = [(name, cpu) for name, cpu in jobs if cpu is not None]
    lines += ["| result | " + " | ".join(f"{cpu} ({name})" for name, cpu in columns) + " |",
              "|" + "---|" * (len(columns) + 1)]
    for key in keys:
        cells = []
        for name, cpu in columns:
            found, base = probes[(name, cpu)], probes[(name, None)]
            cells.append("error" if "_error" in found or "_error" in base
                         else "same" if found.get(key) == base.get(key) else "**differs**")
        lines.append(f"| {key} | " + " | ".join(cells) + " |")
    errors = [f"{cpu or 'native'} ({name}): {found['_error']}" for (name, cpu), found in probes.items()
              if "_error" in found]
    lines += [""] + [f"- probe failed: {e}" for e in errors] if errors else []
    return probes, lines


def _verdict_section(args, cpus: list[str], env: dict, lines: list[str]) -> dict:
    """``eval`` natively and under each CPU (and, with ``--numpy-first``, from a script that imports NumPy
    first), compared with the native CLI run; appends the report's second part to ``lines``."""
    from rich.progress import track

    cases = [c for c in args.cases.split(",") if c]
    bench = Path(args.bench) if args.bench else _synth_bench()
    eval_env = env if args.numpy_avx2 else {**env, "NPY_DISABLE_CPU_FEATURES": NUMPY_BASELINE}
    entries = [(cpu, False) for cpu in [None, *cpus]] + ([(cpu, True) for cpu in [None, *cpus]] if args.numpy_first else [])
    with tempfile.TemporaryDirectory() as scratch, ThreadPoolExecutor(max(1, args.jobs)) as pool:
        futures = {(cpu, first): pool.submit(run_eval, cpu, bench, cases,
                                             Path(scratch) / f"{cpu or 'native'}{'-numpy-first' if first else ''}",
                                             eval_env, first) for cpu, first in entries}
        found_all = [f.result() for f in track(list(futures.values()), description="eval runs")]
    runs = {f"{cpu or 'native'}{' (numpy first)' if first else ''}": found
            for (cpu, first), found in zip(futures, found_all)}
    native = runs["native"]
    numpy_note = "" if args.numpy_avx2 else f" (NumPy at its baseline: `NPY_DISABLE_CPU_FEATURES={NUMPY_BASELINE}`)"
    lines += ["", f"## Verdicts: `spark-bench eval --method ours --bench {bench.name} --cases {','.join(cases)}`"
              f"{numpy_note}", "",
              "| CPU | wall s | rows | rows' cpu kernels | differences from native (row fields; prediction files) |",
              "|---|---|---|---|---|"]
    for key, found in runs.items():
        rows = sum(1 for k in found if not k.startswith(("_", "file ")))
        diff = "; ".join(_row_differences(native, found)) or "none"
        if "_error" in found:
            diff = f"failed: {found['_error']}"
        kernels = "; ".join(sorted(str(k) for k in found.get("_kernels", ())))
        lines.append(f"| {key} | {found['_wall_s']} | {rows} | {kernels} | {diff} |")
    return runs


def _qemu_version() -> str:
    done = subprocess.run(["qemu-x86_64", "--version"], capture_output=True, text=True)
    return done.stdout.splitlines()[0] if done.stdout else "QEMU"


def _synth_bench() -> Path:
    from spark_bench.data.benchmarks import ensure_benchmark

    return Path(ensure_benchmark("synth-v1"))


if __name__ == "__main__":
    raise SystemExit(main())
