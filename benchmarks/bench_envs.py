"""Benchmark of the opening environments: speed, scripted solvability, and learning.

1. **Speed**: environment steps per second of ``SparkDrawer-v0`` / ``SparkDoor-v0`` (through
   ``gymnasium.make``'s wrappers, and unwrapped) against raw ``mujoco.mj_step`` on the same model for the
   same physics time (``N_SUBSTEPS`` steps); the overhead ratio is env time / raw time. Reference from the
   issue: Meta-World's drawer-open-v3 runs about 2,500 steps/s at 4x its raw physics cost.
2. **Scripted opener**: success rate of the ground-truth scripted opener on every drawer and door of
   ``--synth`` synth objects and of the shared real objects 41083, 40147, 45780.
3. **Training**: PPO and SAC on the default drawer for ``--train-minutes`` each: success rate reached,
   environment steps and wall time (``--skip-train`` to skip).

Run: ``python benchmarks/bench_envs.py [--synth 30] [--train-minutes 30] [--skip-train] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

import spark_bench  # noqa: E402,F401
from spark_bench.envs.scene import N_SUBSTEPS  # noqa: E402

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
    from spark_bench.rl.scripted import open_every_joint

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


def training(minutes: float, out: Path) -> list[dict]:
    from spark_bench.rl.train import train

    rows = []
    for algo, n_envs in (("ppo", 8), ("sac", 1)):
        result = train("SparkDrawer-v0", algo=algo, steps=50_000_000, out=out / algo, n_envs=n_envs, seed=0,
                       eval_every=20_000 if algo == "ppo" else 5_000, eval_episodes=20,
                       max_wall_s=minutes * 60, progress_bar=True)
        best = max(result.curve, key=lambda r: r.success_rate)
        rows.append({"algo": algo, "final_success": result.final["success_rate"], "steps": result.final["steps"],
                     "wall_s": result.wall_s, "best_success": best.success_rate, "best_at_steps": best.steps,
                     "best_at_wall_s": best.wall_s, "curve": str(out / algo / "curve.png")})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--synth", type=int, default=30, help="synth objects in the scripted study")
    parser.add_argument("--train-minutes", type=float, default=30.0, help="wall-time budget per algorithm")
    parser.add_argument("--skip-train", action="store_true")
    parser.add_argument("--only-speed", action="store_true", help="only the speed measurement")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="bench_envs_"))
    out.mkdir(parents=True, exist_ok=True)
    report: dict = {}

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
        (out / "bench_envs.json").write_text(json.dumps(report, indent=2, default=float))
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
        report["training"] = training(args.train_minutes, out / "train")
        for row in report["training"]:
            console.print(f"{row['algo'].upper()}: success {row['final_success']:.2f} after {row['steps']} steps, "
                          f"{row['wall_s']:.0f} s (best {row['best_success']:.2f} at {row['best_at_steps']} steps, "
                          f"{row['best_at_wall_s']:.0f} s); curve {row['curve']}")
    (out / "bench_envs.json").write_text(json.dumps(report, indent=2, default=float))
    console.print(f"report: {out / 'bench_envs.json'}")


if __name__ == "__main__":
    main()
