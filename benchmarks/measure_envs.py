"""Benchmark of the opening environments: speed, scripted solvability, and learning.

1. **Speed**: environment steps per second of ``SparkDrawer-v0`` / ``SparkDoor-v0`` (through
   ``gymnasium.make``'s wrappers, and unwrapped) against raw ``mujoco.mj_step`` on the same model for the
   same physics time (``N_SUBSTEPS`` steps); the overhead ratio is env time / raw time. Reference from the
   issue: Meta-World's drawer-open-v3 runs about 2,500 steps/s at 4x its raw physics cost.
2. **Scripted opener**: success rate of the ground-truth scripted opener on every drawer and door of
   ``--synth`` synth objects and of the shared real objects 41083, 40147, 45780.
3. **Training**: PPO and SAC on the default drawer for ``--train-minutes`` each: success rate reached,
   environment steps and wall time (``--skip-train`` to skip).

Run: ``python -m benchmarks.measure_envs [--synth 30] [--train-minutes 30] [--skip-train] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from rich.console import Console
from rich.table import Table

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.manipulation.scene import N_SUBSTEPS
from spark_bench.mujoco_gl import mujoco_module

mujoco = mujoco_module()

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "real_objects"
METAWORLD_STEPS_PER_S, METAWORLD_OVERHEAD = 2500.0, 4.0
console = Console()


def _time_env(env, actions: np.ndarray, ctrl_log: list | None = None) -> float:
    env.reset(seed=0)
    data = env.unwrapped.data
    t = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if ctrl_log is not None:
            ctrl_log.append(data.ctrl.copy())
        if terminated or truncated:
            env.reset()
    return (time.perf_counter() - t) / len(actions)


def _time_raw(env, ctrls: list) -> float:
    """Raw physics on the same model and trajectory: the recorded controls replayed with ``mj_step``
    (``N_SUBSTEPS`` steps per control, as the environment does), from the same reset state."""
    model = env.unwrapped.model
    env.reset(seed=0)
    data = mujoco.MjData(model)
    mujoco.mj_copyData(data, model, env.unwrapped.data)
    t = time.perf_counter()
    for ctrl in ctrls:
        data.ctrl[:] = ctrl
        mujoco.mj_step(model, data, nstep=N_SUBSTEPS)
    return (time.perf_counter() - t) / len(ctrls)


def speed(env_id: str, n: int = 3000, rounds: int = 5) -> dict:
    """Best-of-``rounds`` (interleaved) time per step: wrapped env, unwrapped env, raw physics replaying
    the unwrapped run's controls. Episodes are ``n`` steps long here (no time limit), so resets do not
    dilute the comparison."""
    env = gym.make(env_id, max_episode_steps=n + 1)
    actions = np.random.default_rng(0).uniform(-1, 1, size=(n, 4)).astype(np.float32)
    actions[:, :3] *= 0.3  # stay near the object, as a policy does (contacts included)
    wrapped, unwrapped, raw = [], [], []
    for _ in range(rounds):
        wrapped.append(_time_env(env, actions))
        ctrls: list = []
        unwrapped.append(_time_env(env.unwrapped, actions, ctrls))
        raw.append(_time_raw(env, ctrls))
    w, u, r = min(wrapped), min(unwrapped), min(raw)
    return {"env": env_id, "steps_per_s": 1 / w, "unwrapped_steps_per_s": 1 / u, "raw_steps_per_s": 1 / r,
            "overhead": w / r, "overhead_unwrapped": u / r, "ngeom": int(env.unwrapped.model.ngeom)}


def scripted_study(n_synth: int, out: Path) -> tuple[list[dict], list[dict]]:
    """Ground-truth scripted opener on every drawer and door of the synth and real objects."""
    from spark_bench.data.synth import generate_dataset
    from spark_bench.opening.judge import open_every_joint

    folders = generate_dataset(out / "synth", n_synth, seed=0, categories=["StorageFurniture"])
    synth = []
    from tqdm import tqdm

    for folder in tqdm(folders, desc="scripted opener, synth", unit="obj"):
        for row in open_every_joint(str(folder)):
            synth.append({"object": folder.name, **row})
    real = []
    for object_id in ("41083", "40147", "45780"):
        if (REAL / object_id).is_dir():
            for row in open_every_joint(str(REAL / object_id)):
                real.append({"object": object_id, **row})
    return synth, real


def training(minutes: float, out: Path, algos: tuple[str, ...] = ("ppo", "sac")) -> list[dict]:
    """Train each algorithm on the default drawer for ``minutes`` of wall time (one after another)."""
    from spark_bench.rl.train import train

    for algo in algos:
        n_envs = 8 if algo == "ppo" else 1
        train("SparkDrawer-v0", algo=algo, steps=50_000_000, out=out / algo, n_envs=n_envs, seed=0,
              eval_every=20_000 if algo == "ppo" else 5_000, eval_episodes=20,
              max_wall_s=minutes * 60, progress_bar=True)
    return training_rows(out, algos)


def training_rows(out: Path, algos: tuple[str, ...] = ("ppo", "sac")) -> list[dict]:
    """One summary row per trained algorithm found under ``out`` (its ``train.json`` and ``curve.csv``)."""
    import csv

    rows = []
    for algo in algos:
        meta_path, curve_path = out / algo / "train.json", out / algo / "curve.csv"
        if not meta_path.is_file() or not curve_path.is_file():
            continue
        meta = json.loads(meta_path.read_text())
        curve = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(curve_path.open())]
        best = max(curve, key=lambda r: r["success_rate"])
        first80 = next((r for r in curve if r["success_rate"] >= 0.8), None)
        rows.append({"algo": algo, "n_envs": meta["n_envs"], "final_success": meta["final"]["success_rate"],
                     "steps": meta["steps"], "wall_s": meta["wall_s"], "best_success": best["success_rate"],
                     "best_at_steps": int(best["steps"]), "best_at_wall_s": best["wall_s"],
                     "first_80_steps": None if first80 is None else int(first80["steps"]),
                     "first_80_wall_s": None if first80 is None else first80["wall_s"],
                     "curve": str(out / algo / "curve.png"), "evaluations": len(curve)})
    return rows


def write_training_md(rows: list[dict], results: Path, note: str = "") -> Path:
    """``envs_training.md`` (and the learning-curve PNGs beside it) in ``results``."""
    import shutil

    results.mkdir(parents=True, exist_ok=True)
    lines = ["# Training on the default drawer (SparkDrawer-v0, no kwargs)", "",
             "Produced by `python -m benchmarks.measure_envs` (training part), on the 2 shared CPU cores",
             f"({os.cpu_count()} visible; other jobs were running). Evaluation: 20 episodes with the",
             "deterministic policy every 20k (PPO) / 5k (SAC) environment steps; wall time includes evaluations.",
             *([note] if note else []), "",
             "| algo | n_envs | env steps | wall time | final success | best success (at steps, wall) "
             "| first >= 80% (steps, wall) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        first = "never" if r["first_80_steps"] is None else f"{r['first_80_steps']:,}, {r['first_80_wall_s']:.0f} s"
        lines.append(f"| {r['algo'].upper()} | {r['n_envs']} | {r['steps']:,} | {r['wall_s']:.0f} s | "
                     f"{r['final_success']:.2f} | {r['best_success']:.2f} ({r['best_at_steps']:,}, "
                     f"{r['best_at_wall_s']:.0f} s) | {first} |")
        png = results / f"envs_training_{r['algo']}.png"
        shutil.copyfile(r["curve"], png)
    lines += [""] + [f"![{r['algo'].upper()} learning curve](envs_training_{r['algo']}.png)" for r in rows]
    path = results / "envs_training.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def _rate(rows: list[dict], kind: str) -> tuple[int, int]:
    sel = [r for r in rows if (r["type"] == "prismatic") == (kind == "prismatic")]
    return sum(r["success_rate"] >= 1.0 for r in sel), len(sel)


def write_scripted_md(report: dict, n_synth: int, results: Path) -> Path:
    """``envs_scripted.md`` in ``results``: the speed table, the scripted opener's success per kind on
    the synth objects and per object on the real ones, and every joint it did not open."""
    results.mkdir(parents=True, exist_ok=True)
    load = report.get("load", {})
    lines = ["# Opening environments: speed and the scripted opener", "",
             "Produced by `python -m benchmarks.measure_envs --skip-train --results benchmarks/results` on "
             f"{os.cpu_count()} visible CPU cores shared with other engineers' jobs (1-minute load average "
             f"{load.get('start', float('nan')):.1f} at the start, {load.get('end', float('nan')):.1f} at the end): "
             "absolute steps/s vary with that load; the overhead ratios compare runs interleaved in the same "
             "seconds.", "",
             f"## Speed (control step = {N_SUBSTEPS} physics steps; random actions near the handle)", "",
             "| env | env steps/s | unwrapped steps/s | raw mj_step steps/s | overhead (env / raw) |",
             "|---|---|---|---|---|"]
    for r in report["speed"]:
        lines.append(f"| {r['env']} | {r['steps_per_s']:,.0f} | {r['unwrapped_steps_per_s']:,.0f} | "
                     f"{r['raw_steps_per_s']:,.0f} | {r['overhead']:.2f}x |")
    lines += ["", f"Reference (issue): Meta-World drawer-open-v3, about {METAWORLD_STEPS_PER_S:,.0f} steps/s at "
              f"{METAWORLD_OVERHEAD:.0f}x its raw physics cost.", "",
              "## Scripted opener with the ground-truth joint (one episode per joint, 150 steps, seed 0)", "",
              "| objects | drawers (prismatic) opened | doors (revolute) opened |", "|---|---|---|"]
    synth, real = report["scripted_synth"], report["scripted_real"]

    def cell(rows, kind):
        ok, n = _rate(rows, kind)
        return f"{ok}/{n} ({100.0 * ok / n:.1f}%)" if n else "-"

    lines.append(f"| synth StorageFurniture, {n_synth} objects (generate_dataset seed 0) | "
                 f"{cell(synth, 'prismatic')} | {cell(synth, 'revolute')} |")
    for object_id in sorted({r["object"] for r in real}):
        rows = [r for r in real if r["object"] == object_id]
        lines.append(f"| real {object_id} | {cell(rows, 'prismatic')} | {cell(rows, 'revolute')} |")
    grips = {}
    for r in synth + real:
        grips[r.get("grasp", "error")] = grips.get(r.get("grasp", "error"), 0) + 1
    thin = [f"{r['object']} {r['joint']} ({1000 * r['pad_thickness']:.1f} mm)" for r in synth + real
            if r.get("pad_thickness") is not None]
    lines += ["", "Grasps: " + ", ".join(f"{k} {v}" for k, v in sorted(grips.items())) +
              " (label: an annotated handle link; geometry: a handle found proud of the front; notch: a "
              "finger-pull notch, gripped from inside; face: no handle).", "",
              f"Pads thinned to fit beside the handle (another part's feature, e.g. the other leaf's edge lip "
              f"of a double door, stands inside the open fingers' sweep; the fingers approach pre-closed): "
              f"{len(thin)} joints" + (f": {', '.join(thin)}." if thin else "."), "", "Not opened:", ""]
    failures = [r for r in synth + real if r["success_rate"] < 1.0]
    lines += [f"- {r['object']} {r['joint']} ({r['type']}, grasp {r.get('grasp')}, largest opening "
              f"{r.get('max_fraction', 0):.2f}) {r.get('error', '')}".rstrip() for r in failures] or ["- none"]
    declined = [r for r in synth + real if r.get("reason")]
    lines += ["", "Declined by the planner or the scene (a `reason`; the episodes were run all the same):", ""]
    lines += [f"- {r['object']} {r['joint']}: {r['reason']}" for r in declined] or ["- none"]
    path = results / "envs_scripted.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--synth", type=int, default=30, help="synth objects in the scripted study")
    parser.add_argument("--train-minutes", type=float, default=30.0, help="wall-time budget per algorithm")
    parser.add_argument("--skip-train", action="store_true")
    parser.add_argument("--only-train", action="store_true", help="only the training part")
    parser.add_argument("--algos", default="ppo,sac", help="algorithms to train (comma-separated)")
    parser.add_argument("--summarize-train", type=Path, default=None,
                        help="only write the training report from an earlier run's train folder")
    parser.add_argument("--note", default="", help="a line added to the training report (how it was run)")
    parser.add_argument("--results", type=Path, default=None,
                        help="also write the markdown reports (envs_scripted.md, envs_training.md) here")
    parser.add_argument("--only-speed", action="store_true", help="only the speed measurement")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="bench_envs_"))
    out.mkdir(parents=True, exist_ok=True)
    report: dict = {"load": {"start": os.getloadavg()[0]}}
    algos = tuple(a.strip().lower() for a in args.algos.split(",") if a.strip())
    if args.summarize_train is not None:
        rows = training_rows(args.summarize_train, algos)
        console.print(f"wrote {write_training_md(rows, args.results or out, args.note)}")
        return
    if args.only_train:
        report["training"] = training(args.train_minutes, out / "train", algos)
        (out / "measure_envs.json").write_text(json.dumps(report, indent=2, default=float))
        console.print(report["training"])
        return

    table = Table(title=f"Environment speed (control step = {N_SUBSTEPS} physics steps)")
    for col in ("env", "env steps/s", "unwrapped steps/s", "raw steps/s", "overhead", "vs Meta-World"):
        table.add_column(col)
    report["speed"] = []
    for env_id in ("SparkDrawer-v0", "SparkDoor-v0"):
        row = speed(env_id)
        report["speed"].append(row)
        table.add_row(env_id, f"{row['steps_per_s']:.0f}", f"{row['unwrapped_steps_per_s']:.0f}",
                      f"{row['raw_steps_per_s']:.0f}", f"{row['overhead']:.2f}x",
                      f"{row['steps_per_s'] / METAWORLD_STEPS_PER_S:.2f}x speed, "
                      f"{row['overhead'] / METAWORLD_OVERHEAD:.2f}x overhead")
    console.print(table)

    if args.only_speed:
        (out / "measure_envs.json").write_text(json.dumps(report, indent=2, default=float))
        return
    synth, real = scripted_study(args.synth, out)
    report["scripted_synth"], report["scripted_real"] = synth, real
    for name, rows in (("synth", synth), ("real", real)):
        for kind in ("prismatic", "revolute"):
            sel = [r for r in rows if (r["type"] == "prismatic") == (kind == "prismatic")]
            if sel:
                rate = np.mean([r["success_rate"] for r in sel])
                console.print(f"scripted opener, {name} {kind}: {rate:.3f} over {len(sel)} joints")
    failures = [r for r in synth + real if r["success_rate"] < 1.0]
    for r in failures:
        console.print(f"  not opened: {r['object']} {r['joint']} ({r['type']}, grasp {r.get('grasp')}, "
                      f"largest opening {r.get('max_fraction', 0):.2f}) {r.get('error', '')}")

    if not args.skip_train:
        report["training"] = training(args.train_minutes, out / "train", algos)
        if args.results is not None:
            write_training_md(report["training"], args.results, args.note)
        for row in report["training"]:
            console.print(f"{row['algo'].upper()}: success {row['final_success']:.2f} after {row['steps']} steps, "
                          f"{row['wall_s']:.0f} s (best {row['best_success']:.2f} at {row['best_at_steps']} steps, "
                          f"{row['best_at_wall_s']:.0f} s); curve {row['curve']}")
    report["load"]["end"] = os.getloadavg()[0]
    (out / "measure_envs.json").write_text(json.dumps(report, indent=2, default=float))
    if args.results is not None:
        console.print(f"wrote {write_scripted_md(report, args.synth, args.results)}")
    console.print(f"report: {out / 'measure_envs.json'}")


if __name__ == "__main__":
    main()
