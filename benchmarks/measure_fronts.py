"""Parts whose front is not where the grasp planner looks first (issue 23, item 3), on synth objects: a
front-loading washer's door (its handle a tab on the rim, the body's front right behind it) and a sliding
window's sash (its leading edge inside the frame). For every drawer, door and window joint of ``--categories``
x ``--seeds`` (synth objects generated for this run, none of a named benchmark's): the grasp the planner
takes (where it looks: the front, the front's own grasps after a blocked tab, a sliding plate's broad face),
the end-effector ``auto`` chooses, and ``--episodes`` scripted episodes (seeds 0..) planned from the TRUE
joint and as many from a WRONG axis (the true axis turned by 90 degrees, as ``benchmarks/wrong_axis.py`` turns it).

Writes ``benchmarks/results/fronts.md`` (and, with ``--out``, a per-joint JSON).

Run: ``nice -n 10 python -m benchmarks.measure_fronts [--categories WashingMachine TopLoadingWasher Window]
[--seeds 5000:5030]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from tqdm import tqdm

import spark_bench  # noqa: F401  (registers the environments)
from benchmarks.wrong_axis import wrong_axis
from spark_bench.data.synth import generate_object
from spark_bench.envs import make_env
from spark_bench.envs.assets import load_asset
from spark_bench.envs.registration import ENV_OF_JOINT_TYPE
from spark_bench.errors import InputError
from spark_bench.manipulation.grasp import find_grasp_unchecked
from spark_bench.manipulation.gripper import GripperConfig
from spark_bench.manipulation.rest_meshes import RestMeshes
from spark_bench.manipulation.scene import plan_grasp
from spark_bench.manipulation.suction import cup_mm
from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint
from spark_bench.opening.judge import OPENING_STEPS
from spark_bench.rl.generalist_recipe import seed_range

RESULTS = Path(__file__).resolve().parent / "results"
#: Where the planner took a part (:func:`where`).
PLACES = ("front", "front (tab blocked)", "front (tab too heavy to pinch)", "tab", "broad face")


def where(asset, joint: str, end_effector: str) -> str:
    """Where the part was taken: the grasp planner's choice (:func:`~spark_bench.manipulation.grasp.find_grasp`: its
    broad face (a sliding plate), its front after a tab whose way in is blocked, a tab, or its front), and
    its front (the cup's) where the scene found the tab's pinch too weak for the part (``weak_pinch``)."""
    first = find_grasp_unchecked(RestMeshes(asset), joint, 0, GripperConfig()).source  # before the way-in check
    taken = plan_grasp(asset, joint)
    if taken.broad_face:
        return "broad face"
    if first == "tab" and taken.source != "tab":
        return "front (tab blocked)"
    if taken.source == "tab":
        return "front (tab too heavy to pinch)" if end_effector == "suction" else "tab"
    return "front"


def run_joint(asset, joint, episodes: int, max_steps: int) -> dict:
    """One joint: the planner's grasp and ``auto``'s end-effector, then true-joint and wrong-axis episodes."""
    row = {"joint": joint.name, "type": joint.type, "part": asset.links[joint.child].label}
    try:
        env = make_env(ENV_OF_JOINT_TYPE[joint.type], asset=asset, joint=joint.name, end_effector="auto",
                       max_episode_steps=max_steps)
    except InputError as exc:
        return {**row, "error": " ".join(str(exc).split())}
    grasp = env.unwrapped.scene.grasp
    row.update(end_effector=env.unwrapped.end_effector, grasp=grasp.source,
               where=where(asset, joint.name, env.unwrapped.end_effector),
               reason=grasp.reason,
               cup_mm=cup_mm(grasp.cup_radius))
    try:
        if grasp.reason is None:
            axis, pivot, joint_type = ground_truth_joint(env)
            wrong = wrong_axis(axis, joint_type, grasp.outward)
            row["true"] = [bool(open_with_ground_truth(env, seed=s, max_steps=max_steps).success) for s in range(episodes)]
            row["wrong"] = [bool(open_with_joint(env, wrong, pivot, joint_type, seed=s, max_steps=max_steps).success)
                            for s in range(episodes)]
    finally:
        env.close()
    return row


def write_report(rows: list[dict], args, seconds: float, path: Path) -> Path:
    """``fronts.md``: per category, how many joints are attempted, opened with the true joint, and with a wrong one."""
    lines = ["# Parts whose front is not where the planner looks first (synth)", "",
             f"Produced by `python -m benchmarks.measure_fronts --categories {' '.join(args.categories)} --seeds "
             f"{args.seeds} --episodes {args.episodes}` on {os.cpu_count()} CPU cores ({seconds:.0f} s): every drawer, "
             "door and window joint of freshly generated synth objects, `end_effector=\"auto\"`, "
             f"{args.episodes} scripted episodes (seeds 0..) of at most {args.max_steps} steps from the TRUE joint and "
             "as many from a WRONG axis (turned 90 degrees: a slide sideways, a hinge in the face's plane). *Opened*: "
             "in every episode; *wrong opens*: in any.", "",
             f"| category | joints | attempted | taken at ({' / '.join(PLACES)}) | opened (true joint) | "
             "wrong axis opens | left out |", "|---|---|---|---|---|---|---|"]
    for category in args.categories:
        mine = [r for r in rows if r["category"] == category and r["type"] in ("prismatic", "revolute")]
        tried = [r for r in mine if "true" in r]
        at = {w: sum(r.get("where") == w for r in tried) for w in PLACES}
        left = {}
        for r in mine:
            if "true" not in r:
                why = (r.get("reason") or r.get("error") or "").split(": ", 1)[-1][:70]
                left[why] = left.get(why, 0) + 1
        lines.append(f"| {category} | {len(mine)} | {len(tried)} | {' / '.join(str(at[w]) for w in PLACES)} | "
                     f"{sum(all(r['true']) for r in tried)} | {sum(any(r['wrong']) for r in tried)} | "
                     + ("; ".join(f"{n} x {why}" for why, n in left.items()) or "-") + " |")
    lines += ["", "## Per joint", "", "| object | joint | part | taken at | end-effector | cup | true | wrong |",
              "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "true" in r:
            lines.append(f"| {r['object']} | {r['joint']} | {r['part']} | {r['where']} | "
                         f"{r['end_effector']} | {r['cup_mm'] or '-'} | {sum(r['true'])}/{len(r['true'])} | "
                         f"{sum(r['wrong'])}/{len(r['wrong'])} |")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--categories", nargs="+", default=["WashingMachine", "TopLoadingWasher", "Window"])
    parser.add_argument("--seeds", default="5000:5030", help="synth seeds, A:B or a comma list")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--max-steps", type=int, default=OPENING_STEPS)
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder for fronts.md")
    parser.add_argument("--out", type=Path, default=None, help="per-joint JSON")
    args = parser.parse_args()
    start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as root:
        jobs = [(c, s) for c in args.categories for s in seed_range(args.seeds)]
        for category, seed in tqdm(jobs, desc="objects", unit="obj"):
            name = f"{category}_{seed}"
            try:
                asset = load_asset(str(generate_object(category, seed, root, name)))[0]
            except InputError as exc:  # one bad object never stops the run: it is listed
                print(f"{name}: {exc}", file=sys.stderr)
                continue
            for joint in asset.movable_joints():
                if joint.type in ("prismatic", "revolute"):
                    rows.append({**run_joint(asset, joint, args.episodes, args.max_steps), "object": name,
                                 "category": category})
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=1))
    print(f"wrote {write_report(rows, args, time.perf_counter() - start, args.results / 'fronts.md')}")


if __name__ == "__main__":
    main()
