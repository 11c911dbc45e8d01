"""The suction cup on real objects: every drawer, door, lid, window and board of the PartNet-Mobility objects
in the given folders (default ``../shared/partnet_dev`` and ``../shared/real_objects``) that the grasp planner
declines today, opened with ``end_effector="auto"``.

Per joint (the joints :func:`benchmarks.openable.openable_joints` enumerates, by the part's label):

- the planner's verdict for the gripper (``declined``: ``no_handle``, ``too_wide``, ``blocked``, ``button``;
  a part the planner takes is not measured here: ``auto`` leaves it to the gripper, unchanged);
- the end-effector ``auto`` chose, the cup the planner took (40 mm, or a smaller one of
  :func:`spark_bench.manipulation.suction.cup_sizes` where the 40 mm cup has no place), and the cup's own verdict (no
  flat patch, something in its way, too heavy for its hold: the scene's drive check with the cup's largest hold);
- ``--episodes`` scripted episodes (seeds 0..) of at most ``--max-steps`` steps planned from the TRUE joint,
  and as many planned from a WRONG axis: the true axis turned by 90 degrees (a drawer's about the vertical:
  sideways; a door's or lid's about the face's outward direction: a hinge turned in the face's plane, through
  the same pivot). Success is the environments' (75 % of the range).

Writes ``benchmarks/results/suction.md`` and, with ``--out``, a per-joint JSON.

Run: ``nice -n 10 python -m benchmarks.measure_suction [--episodes 5] [--ids 100664,7304]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import spark_bench  # noqa: F401  (registers the environments)
from benchmarks.openable import openable_joints
from benchmarks.wrong_axis import wrong_axis
from spark_bench.envs import make_env
from spark_bench.envs.assets import load_asset
from spark_bench.errors import InputError
from spark_bench.manipulation.scene import plan_grasp
from spark_bench.manipulation.suction import SuctionConfig, cup_mm, cup_sizes
from spark_bench.opening.episodes import ground_truth_joint, open_with_joint

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
ROOTS = (SHARED / "partnet_dev", SHARED / "real_objects")
RESULTS = Path(__file__).resolve().parent / "results"
#: The opening score's step limit (:data:`spark_bench.opening.judge.OPENING_STEPS`).
MAX_STEPS = 200


def episodes(env, axis, pivot, joint_type: str, n: int, max_steps: int) -> list[dict]:
    """``n`` scripted episodes (seeds 0..) planned from the given joint."""
    out = []
    for seed in range(n):
        result = open_with_joint(env, axis, pivot, joint_type, seed=seed, max_steps=max_steps)
        out.append({"success": bool(result.success), "max_fraction": float(result.max_fraction),
                    "steps": int(result.steps), "end_effector": result.end_effector})
    return out


def run_joint(asset, row: dict, n: int, max_steps: int) -> dict:
    """One joint: the gripper planner's verdict, then (declined only) ``auto``'s end-effector and episodes."""
    gripper = plan_grasp(asset, row["joint"])
    out = {**row, "gripper_reason": gripper.reason, "declined": gripper.declined}
    if gripper.reason is None or gripper.declined is None:  # the planner takes it (a stuck part: the scene's)
        return {**out, "measured": False}
    start = time.perf_counter()
    try:
        env = make_env(row["env"], asset=asset, joint=row["joint"], end_effector="auto", max_episode_steps=max_steps)
    except InputError as exc:
        return {**out, "measured": True, "error": " ".join(str(exc).split())}
    scene = env.unwrapped.scene
    out.update(measured=True, end_effector=scene.end_effector, reason=scene.grasp.reason,
               free_fraction=scene.free_fraction, build_s=time.perf_counter() - start)
    if scene.grasp.cup_radius is not None:
        out["cup_mm"] = cup_mm(scene.grasp.cup_radius)
    if scene.grasp.reason is None:
        axis, pivot, joint_type = ground_truth_joint(env)
        out["true"] = episodes(env, axis, pivot, joint_type, n, max_steps)
        out["wrong"] = episodes(env, wrong_axis(axis, joint_type, scene.grasp.outward), pivot, joint_type, n, max_steps)
        out["grasp_point"] = scene.grasp.point.tolist()
    out["run_s"] = time.perf_counter() - start - out["build_s"]
    env.close()
    return out


def _rate(runs: list[dict]) -> str:
    return f"{sum(r['success'] for r in runs)}/{len(runs)}"


def _cup(row: dict) -> str:
    return f"{row['cup_mm']:g} mm" if "cup_mm" in row else "-"


def _best(runs: list[dict]) -> str:
    return f"{max(r['max_fraction'] for r in runs):.2f}"


def write_report(rows: list[dict], args, seconds: float, path: Path) -> Path:
    """``suction.md``: what ``auto`` does on each declined joint, true joint and wrong axis."""
    cfg = SuctionConfig()
    measured = [r for r in rows if r.get("measured")]
    cup = [r for r in measured if r.get("end_effector") == "suction"]
    tried = [r for r in cup if "true" in r]
    opened = [r for r in tried if all(e["success"] for e in r["true"])]
    some = [r for r in tried if any(e["success"] for e in r["true"])]
    wrong_open = [r for r in tried if any(e["success"] for e in r["wrong"])]
    lines = [
        "# The suction cup on the parts the grasp planner declines", "",
        f"Produced by `python -m benchmarks.measure_suction --episodes {args.episodes}` on {os.cpu_count()} CPU "
        f"cores shared with other jobs ({seconds:.0f} s): every drawer, door, lid, window and board (by the part's "
        f"`semantics.txt` label) of the PartNet-Mobility objects in {', '.join(f'`{p.name}/`' for p in args.roots)} "
        "that the grasp planner declines for the parallel gripper, opened with `end_effector=\"auto\"`, "
        f"{args.episodes} scripted episodes (seeds 0..) of at most {args.max_steps} steps (the opening score's "
        "limit) planned from the TRUE joint, and as many from a WRONG axis (the true axis turned by 90 degrees: a "
        "drawer's sideways, a door's or lid's hinge turned in the face's plane about the face's outward "
        "direction, same pivot). Success: the joint passes 75 % of its range.", "",
        f"The cup: {1000 * 2 * cfg.cup_radius:.0f} mm across, holding {cfg.max_force:.0f} N along the face's "
        f"normal (MuJoCo's `adhesion` actuator; `spark_bench/manipulation/suction.py`), friction {cfg.friction:g}, carried "
        "by the gripper's servoed carriage (the same largest pull: 60 N per axis). Where it finds no place, the "
        "smaller cups of the same line, largest first: " + ", ".join(
            f"{1000 * 2 * c.cup_radius:.0f} mm ({c.max_force:.0f} N)" for c in cup_sizes(cfg)[1:])
        + " (the same vacuum over a smaller area); the column `cup` says which.", "",
        "| | joints |", "|---|---|",
        f"| drawers, doors, lids, windows, boards | {len(rows)} |",
        f"| declined by the planner for the gripper | {len(measured)} |",
        f"| of which `auto` gives the cup (nothing to pinch: `no_handle`, `too_wide`, `unholdable`) | {len(cup)} |",
        f"| of which the cup's planner or drive check declines too | {len(cup) - len(tried)} |",
        f"| attempted with the cup | {len(tried)} |",
        f"| opened with the true joint in every episode | {len(opened)} |",
        f"| opened with the true joint in at least one episode | {len(some)} |",
        f"| opened with the wrong axis in any episode | {len(wrong_open)} |",
        f"| attempted with a cup smaller than {1000 * 2 * cfg.cup_radius:.0f} mm | "
        f"{sum(r.get('cup_mm', cup_mm(cfg.cup_radius)) < cup_mm(cfg.cup_radius) for r in tried)} |",
        "", "## Per joint", "",
        "| object | joint | part | declined (gripper) | end-effector | cup | cup's verdict | true: opened | true: "
        "largest opening | wrong axis: opened | wrong: largest opening |",
        "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in measured:
        verdict = r.get("error") or r.get("reason") or "attempted"
        if "true" in r:
            cells = [_rate(r["true"]), _best(r["true"]), _rate(r["wrong"]), _best(r["wrong"])]
        else:
            cells = ["-"] * 4
        lines.append(f"| {r['object']} | {r['joint']} | {r['category']} {r['label']} | {r['declined']} | "
                     f"{r.get('end_effector', '-')} | {_cup(r)} | {verdict} | " + " | ".join(cells) + " |")
    lines += ["", "Per seed (true joint; wrong axis), largest opening:", ""]
    for r in tried:
        lines.append(f"- {r['object']} {r['joint']}: true " + ", ".join(
            f"{e['max_fraction']:.2f}{'*' if e['success'] else ''}" for e in r["true"]) + "; wrong " + ", ".join(
            f"{e['max_fraction']:.2f}{'*' if e['success'] else ''}" for e in r["wrong"]) + " (* opened)")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--roots", type=Path, nargs="+", default=list(ROOTS), help="folders of objects")
    parser.add_argument("--ids", default=None, help="comma-separated object ids (default: every object)")
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--max-steps", type=int, default=MAX_STEPS)
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder for suction.md")
    parser.add_argument("--out", type=Path, default=None, help="per-joint JSON")
    args = parser.parse_args()
    ids = set(args.ids.split(",")) if args.ids else None
    start = time.perf_counter()
    rows = []
    for root in args.roots:
        for folder in sorted(p for p in root.iterdir() if (p / "mobility.urdf").is_file()):
            if ids is not None and folder.name not in ids:
                continue
            try:
                asset = load_asset(str(folder))[0]
                joints = openable_joints(asset)
            except InputError as exc:
                print(f"{folder.name}: {exc}")
                continue
            for row in joints:
                result = {**run_joint(asset, row, args.episodes, args.max_steps), "object": folder.name,
                          "root": root.name}
                rows.append(result)
                if result.get("measured"):
                    said = result.get("error") or result.get("reason") or (
                        f"true {_rate(result['true'])}, wrong {_rate(result['wrong'])}")
                    print(f"{folder.name} {row['joint']} ({row['category']} {row['label']}, "
                          f"{result.get('end_effector')}): {said}", flush=True)
    seconds = time.perf_counter() - start
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=1, default=float))
    print(f"wrote {write_report(rows, args, seconds, args.results / 'suction.md')}")


if __name__ == "__main__":
    main()
