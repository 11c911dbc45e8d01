"""The scripted opener on real objects: every drawer, door and lid of the PartNet-Mobility objects in a
folder (default ``../shared/partnet_dev``), opened with the ground-truth joint.

What is measured, per joint whose part is labelled a drawer, door or lid (``semantics.txt``; other joints,
buttons, knobs, a bucket's bail, are not drawers or doors):

- whether the planner declines it (its ``reason``: no handle, a flush lid...) and why;
- otherwise the success rate over ``--episodes`` episodes of ``--max-steps`` steps (the environments'
  registered time limit by default), the task's success fraction (75 % of the joint's range), the
  largest opening reached, the grasp the planner chose, and the time taken (model build and episodes).

Also the issue's per-object number: ``spark-bench rollout --env SparkDrawer-v0|SparkDoor-v0 --policy
scripted`` on each object's *default* joint (drawer for tables, door or lid otherwise).

A part that no pull of the gripper can open (driven directly with the hand's largest force, nothing in
the way: :func:`spark_bench.manipulation.drive_check.stuck_reason`) is declined by the scene with that reason (too heavy
for the gripper, or jammed by its collision shapes) and counted among the declined, as *stuck*; a failed
joint also reports how far it opens driven so (:func:`free_motion`).

Failures are written as small MP4 videos (the first episode that fails, run again with its seed: a close
view of the grasp) into ``--videos`` (default ``benchmarks/results/opener_failures``) with a PNG contact
sheet of their frames, and the report as ``opener_real.md`` (``--results``), with each episode's outcome
(seed, opened or not, largest opening) for every joint not opened in all of them. A per-joint JSON goes to ``--out``.

Run: ``nice -n 10 python -m benchmarks.measure_opener_real [--ids 24644,7304] [--episodes 2]``.

Timing mode (issue 12, item 5): ``--score BENCH --cases ...`` times the opening score
(:func:`spark_bench.opening.judge.open_with_predicted_joints`) of the oracle on cases of a prepared
benchmark, seconds per case, into ``opener_score_speed.md`` (``--before`` an earlier run's ``--out`` JSON
to compare with, verdicts included).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from rich.console import Console

import spark_bench  # noqa: F401  (registers the environments)
from benchmarks.openable import openable_joints
from spark_bench.envs import ENV_OF_JOINT_TYPE, make_env
from spark_bench.envs.assets import load_asset
from spark_bench.errors import InputError

ROOT = Path(__file__).resolve().parents[1].parent / "shared" / "partnet_dev"
RESULTS = Path(__file__).resolve().parent / "results"
FPS = 12
#: The task's success fraction (the environments' default ``target_fraction``).
TARGET = 0.75
console = Console()


def _close_camera(env, distance: float = 0.6):
    """Point the environment's renderer at the grasp point from the front-left, above."""
    unwrapped = env.unwrapped
    unwrapped.render()  # makes the renderer and its camera
    camera = unwrapped._camera
    camera.lookat[:] = unwrapped.scene.grasp.point
    camera.distance = distance
    camera.azimuth, camera.elevation = 35.0, -25.0


def run_joint(asset, object_id: str, row: dict, episodes: int, max_steps: int, video_dir: Path | None) -> dict:
    """One joint of ``asset`` (loaded once per object: its joints' environments share its prepared
    collision shapes): the planner's verdict, then ``episodes`` scripted episodes (seeds 0..; the first
    that fails is filmed when ``video_dir`` is given)."""
    from spark_bench.rl.policies import ScriptedPolicy
    from spark_bench.rl.rollout import run_episode

    start = time.perf_counter()
    try:
        env = make_env(row["env"], asset=asset, joint=row["joint"], max_episode_steps=max_steps,
                       render_mode="rgb_array" if video_dir else None, width=320, height=240)
    except InputError as exc:
        return {**row, "error": " ".join(str(exc).split()), "success_rate": 0.0, "build_s": time.perf_counter() - start}
    build = time.perf_counter() - start
    grasp = env.unwrapped.scene.grasp
    out = {**row, "grasp": grasp.source, "build_s": build}
    if grasp.reason is not None:
        env.close()
        jam = env.unwrapped.scene.free_fraction
        return {**out, "reason": grasp.reason, "success_rate": None,
                **({"free_fraction": jam, "stuck": True} if jam is not None and jam < TARGET else {})}
    runs = [run_episode(env, ScriptedPolicy(), seed) for seed in range(episodes)]
    successes = [r["success"] for r in runs]
    out.update(success_rate=float(np.mean(successes)), max_fraction=float(np.mean([r["max_fraction"] for r in runs])),
               successes=successes, max_fractions=[r["max_fraction"] for r in runs],
               episodes=episodes, run_s=time.perf_counter() - start - build)
    frames: list = []
    if out["success_rate"] < 1.0:  # the opener's fault, or a part the simulation does not let move or reach?
        if video_dir:  # the first failed episode again (an episode is a function of its seed), filmed
            _close_camera(env, 0.25 + 0.5 * float(np.linalg.norm(np.ptp(env.unwrapped.scene.workspace, axis=0))) / 3)
            run_episode(env, ScriptedPolicy(), successes.index(False), frames=frames)
        out["free_fraction"] = free_motion(env)
        out["hull_gap"] = hull_gap(env)
    env.close()
    if video_dir and out["success_rate"] < 1.0 and frames:
        out["video"] = str(_write_failure(frames, video_dir, object_id, row["joint"]))
    return out


def free_motion(env) -> float:
    """The largest fraction of its range the environment's joint reaches when driven directly
    (:func:`spark_bench.manipulation.drive_check.free_motion`: a force at the grasp, the gripper parked away), from rest."""
    from spark_bench.manipulation.drive_check import free_motion as drive
    from spark_bench.manipulation.gripper import largest_pull

    scene = env.unwrapped.scene
    return scene.free_fraction if scene.free_fraction is not None else drive(scene, largest_pull(scene.gripper.config))


#: Collision shapes standing in the way (:func:`hull_gap`): how far (m) out along the approach the check
#: looks, and how far (m) in front of the visual surface the collision surface must stand on one of the
#: approach lines to count (convex pieces approximate a surface to a few mm; 8 mm is a pad's way blocked).
GAP_REACH = 0.15
FILLED_GAP = 0.008


def hull_gap(env) -> float:
    """How far (m) the object's collision shapes stand in front of its visual surface on the hand's way to
    the grasp: along the approach lines through the grasp point and through where each open pad comes down,
    the first collision surface met from :data:`GAP_REACH` out, less the first visual (planner's) surface
    met, each counted from the fingertips' level at the grasp. A gap of centimetres is a handle whose gaps
    (a spoked wheel, a recessed grip) the convex pieces fill: the hand stops on the hull, short of the
    grasp, whatever the opener does (the simulation's collision shapes, like a jammed part)."""
    from spark_bench.manipulation.features import first_hit
    from spark_bench.mujoco_gl import mujoco_module

    mujoco = mujoco_module()
    u = env.unwrapped
    m, d, scene = u.model, u.data, u.scene
    grasp, cfg = scene.grasp, u._gripper_config
    mujoco.mj_resetData(m, d)
    d.qpos[:] = scene.rest_qpos
    d.qpos[u._tcp_q] = scene.workspace[1] - 0.01  # the gripper parked away, as in free_motion
    mujoco.mj_forward(m, d)
    opening = cfg.max_opening if grasp.opening is None else grasp.opening
    lines = [grasp.point, grasp.point + opening * grasp.closing, grasp.point - opening * grasp.closing]
    floor = -cfg.tip_beyond_tcp  # levels below the fingertips' do not stand in the hand's way
    triangles = np.asarray(scene.asset.mesh().triangles)
    groups = np.zeros(6, dtype=np.uint8)
    groups[3] = 1  # collision geoms only (sim/mjcf.py: group 3)
    hand = {b for b in range(m.nbody) if (m.body(b).name or "").startswith("spark_gripper")}
    worst = 0.0
    for line in lines:
        start = line + GAP_REACH * grasp.outward
        seen = first_hit(triangles, start, -grasp.outward, 0.0, GAP_REACH - floor)
        visual = floor if seen is None else GAP_REACH - seen
        geom = np.array([-1], dtype=np.int32)
        t = mujoco.mj_ray(m, d, start, -grasp.outward, groups, 1, -1, geom)
        if geom[0] >= 0 and int(m.geom_bodyid[geom[0]]) in hand:
            continue
        collision = floor if geom[0] < 0 or t < 0 else max(GAP_REACH - t, floor)
        worst = max(worst, collision - max(visual, floor))
    return worst


def _write_failure(frames: list, video_dir: Path, object_id: str, joint: str) -> Path:
    from spark_bench.rl.rollout import write_video

    video_dir.mkdir(parents=True, exist_ok=True)
    path = video_dir / f"{object_id}_{joint}.mp4"
    write_video(frames[::2], path, fps=FPS)
    return path


def contact_sheet(rows: list[dict], path: Path, per_row: int = 6) -> Path | None:
    """A PNG: one line per failed joint, ``per_row`` frames of its video, half size."""
    import imageio.v3 as iio

    lines = []
    for row in rows:
        if "video" not in row:
            continue
        frames = iio.imread(row["video"])
        picks = frames[np.linspace(0, len(frames) - 1, per_row).astype(int)]
        lines.append(np.concatenate(list(picks), axis=1)[::2, ::2])
    if not lines:
        return None
    width = max(line.shape[1] for line in lines)
    sheet = np.concatenate([np.pad(line, ((0, 4), (0, width - line.shape[1]), (0, 0))) for line in lines])
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, sheet)
    return path


def default_rows(asset, object_id: str, rows: list[dict], episodes: int, max_steps: int) -> dict | None:
    """The issue's per-object number: the environment's *default* joint (no ``--joint``), drawer for an
    object with drawers, door or lid otherwise; reuses the joint's row when it was measured."""
    from spark_bench.manipulation.scene import choose_joint

    own = [r for r in rows if r["object"] == object_id]
    if not own:
        return None
    kind = "prismatic" if any(r["type"] == "prismatic" for r in own) else "revolute"
    joint = choose_joint(asset, kind, None).name
    for r in own:
        if r["joint"] == joint:
            return {**r, "default": True}
    row = {"joint": joint, "type": asset.joints[joint].type, "label": asset.links[asset.joints[joint].child].label,
           "category": asset.category, "env": ENV_OF_JOINT_TYPE[kind]}
    return {**run_joint(asset, object_id, row, episodes, max_steps, None), "object": object_id, "default": True}


def jammed(row: dict) -> bool:
    """Whether a joint does not open even driven directly (:func:`free_motion`): the scene declines it with
    that reason (:func:`spark_bench.manipulation.task.build_scene`)."""
    return row.get("free_fraction") is not None and row["free_fraction"] < TARGET


def summarize(rows: list[dict]) -> list[dict]:
    """One line per category (and ``all``): joints, declined by the planner (of which jammed in the
    simulation), attempted, opened (every episode), opened / attempted, opened / all."""
    out = []
    categories = sorted({r["category"] for r in rows})
    for category in categories + ["all"]:
        sel = [r for r in rows if category in ("all", r["category"])]
        declined = [r for r in sel if r.get("reason")]
        attempted = [r for r in sel if not r.get("reason")]
        opened = [r for r in attempted if r.get("success_rate", 0.0) >= 1.0]
        stuck = [r for r in sel if jammed(r)]
        out.append({"category": category, "joints": len(sel), "declined": len(declined), "attempted": len(attempted),
                    "opened": len(opened), "jammed": len(stuck),
                    "rate_attempted": len(opened) / len(attempted) if attempted else None,
                    "rate_all": len(opened) / len(sel) if sel else None})
    return out


def _per_seed(row: dict) -> str:
    """``seed: opened / largest opening`` for each episode of a row."""
    return ", ".join(f"{seed}: {'opened' if ok else 'not opened'} {best:.2f}"
                     for seed, (ok, best) in enumerate(zip(row["successes"], row["max_fractions"])))


def _pct(value) -> str:
    return "-" if value is None else f"{100 * value:.0f} %"


def write_report(rows: list[dict], defaults: list[dict], args, seconds: float, path: Path,
                 sheet: Path | None) -> Path:
    """``opener_real.md``: rates per category, the issue's per-object number, every failure and every
    declined part with its reason, and the time taken."""
    from spark_bench.manipulation.drive_check import OVERLOAD
    from spark_bench.manipulation.gripper import GripperConfig, largest_pull

    lines = ["# The scripted opener on real objects", "",
             f"Produced by `python -m benchmarks.measure_opener_real` on {os.cpu_count()} CPU cores shared with "
             f"other jobs: every drawer, door and lid (by the part's `semantics.txt` label) of the "
             f"PartNet-Mobility objects in `{args.root.name}/`, opened by the scripted opener with the "
             f"ground-truth joint, {args.episodes} episodes of at most {args.max_steps} steps each (seeds 0..), "
             f"success = the joint passes {100 * TARGET:.0f} % of its range. A joint counts as opened when every episode opens it. "
             "*Declined*: the planner says, before any episode, why a parallel gripper cannot pull the part "
             f"(that line is the rollout's `reason`). Total time {seconds:.0f} s.", "",
             "*Stuck*: a joint that does not reach the success fraction when driven directly with the gripper's "
             f"largest pull ({largest_pull(GripperConfig()):.0f} N at the grasp point's lever arm, nothing in the "
             "way, until it stands still: `spark_bench.manipulation.drive_check.stuck_reason`): no policy of this hand can open "
             f"it, whatever it does; the reason says whether {OVERLOAD:g} times that force opens it (too heavy for "
             "the gripper) or not (jammed by its "
             "collision shapes). The scene checks this when it is built and declines such a part with that reason "
             "(counted under *declined*).",
             "",
             "| category | joints | declined | of which stuck | attempted | opened | opened / attempted "
             "| opened / all |",
             "|---|---|---|---|---|---|---|---|"]
    for s in summarize(rows):
        lines.append(f"| {s['category']} | {s['joints']} | {s['declined']} | {s['jammed']} | {s['attempted']} | "
                     f"{s['opened']} | {_pct(s['rate_attempted'])} | {_pct(s['rate_all'])} |")
    if defaults:
        lines += ["", "## Per object, default joint (`spark-bench rollout --env SparkDrawer-v0|SparkDoor-v0 "
                  f"--policy scripted --episodes {args.episodes}`)", "",
                  "| category | objects | opened | declined |", "|---|---|---|---|"]
        for category in sorted({r["category"] for r in defaults}):
            sel = [r for r in defaults if r["category"] == category]
            ok = sum(1 for r in sel if not r.get("reason") and r.get("success_rate", 0.0) >= 1.0)
            lines.append(f"| {category} | {len(sel)} | {ok} | {sum(1 for r in sel if r.get('reason'))} |")
    failed = [r for r in rows if not r.get("reason") and r.get("success_rate", 0.0) < 1.0]
    lines += ["", "## Not opened", ""]
    lines += [f"- {r['object']} {r['joint']} ({r['category']} {r['label']}, grasp {r.get('grasp')}): success "
              f"{r.get('success_rate', 0.0):.2f}, largest opening {r.get('max_fraction', 0.0):.2f} of the range"
              + (f" (per seed: {_per_seed(r)})" if len(r.get("successes", [])) > 1 else "")
              + (f"; {r['error']}" if r.get("error") else "")
              + (f"; **stuck**: driven directly it reaches {r['free_fraction']:.2f}" if jammed(r) else "")
              + (f"; the collision shapes stand {1000 * r['hull_gap']:.0f} mm in front of the visual surface on "
                 "the hand's way in" if r.get("hull_gap", 0.0) >= FILLED_GAP else "")
              + (f" — [video]({os.path.relpath(r['video'], path.parent)})" if r.get("video") else "")
              for r in failed] or ["- none"]
    if sheet is not None:
        lines += ["", f"![failures, one per line]({os.path.relpath(sheet, path.parent)})"]
    lines += ["", "## Declined by the planner or the scene", ""]
    lines += [f"- {r['object']} {r['joint']} ({r['category']} {r['label']}): {r['reason']}"
              for r in rows if r.get("reason")] or ["- none"]
    builds = [r["build_s"] for r in rows if "build_s" in r]
    runs = [r["run_s"] for r in rows if "run_s" in r]
    if builds:
        lines += ["", f"Time per joint: model build median {np.median(builds):.1f} s (max {max(builds):.1f} s), "
                  f"episodes median {np.median(runs) if runs else 0.0:.1f} s (max {max(runs) if runs else 0.0:.1f} s); "
                  "builds reuse the collision-hull cache of `$SPARK_BENCH_HOME`."]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def score_speed(bench: Path, cases: list[str], seed: int = 0, path: Path | None = None) -> list[dict]:
    """The opening score (:func:`spark_bench.opening.judge.open_with_predicted_joints`) of the oracle
    on each case of a prepared benchmark: the ground truth predicted by itself, every joint matched with
    itself (what the oracle's metrics give). Wall time per case, and the verdicts, written to ``path`` (JSON)
    after each case when given."""
    from spark_bench.data import load_object
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.opening.judge import open_with_predicted_joints

    out = []
    for case_id in cases:
        gt_dir = BenchmarkCase(bench / "cases" / case_id).gt_dir
        gt_bench = load_object(gt_dir, load_meshes=False)
        matching = {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in gt_bench.movable_joints()]}
        start = time.perf_counter()
        result = open_with_predicted_joints(gt_dir, gt_dir, matching, seed=seed)
        seconds = time.perf_counter() - start
        verdicts = {name: j.get("success") for name, j in result["joints"].items()}
        out.append({"case": case_id, "category": gt_bench.category, "seconds": seconds, "success_rate": result["success_rate"],
                    "verdicts": verdicts, "joints": result["joints"]})
        console.print(f"{case_id} ({gt_bench.category}): {seconds:.1f} s, success rate {result['success_rate']}, {verdicts}")
        if path is not None:  # as it goes: a long run stopped early keeps its cases
            path.write_text(json.dumps(out, indent=1, default=float))
    return out


def write_score_speed(rows: list[dict], before: list[dict] | None, path: Path, note: str) -> Path:
    """``opener_score_speed.md``: the oracle's opening score per case, seconds (and those of ``before``, an
    earlier code's run on the same cases, with whether the verdicts changed)."""
    old = {r["case"]: r for r in before or []}
    lines = ["# The opening score's time per real case (oracle)", "",
             f"Produced by `python -m benchmarks.measure_opener_real --score BENCH --cases ...` on "
             f"{os.cpu_count()} CPU cores shared with other jobs. {note}", "",
             "| case | category | joints (scored / left out) | seconds" + (" | before (s) | verdicts" if old else "")
             + " |", "|---|---|---|---" + ("|---|---" if old else "") + "|"]
    for r in rows:
        scored = sum(1 for v in r["verdicts"].values() if v is not None)
        cells = [r["case"], r["category"], f"{scored} / {len(r['verdicts']) - scored}", f"{r['seconds']:.1f}"]
        if old:
            b = old.get(r["case"])
            if b is None:
                cells += ["-", "-"]
            else:
                same = {k: v for k, v in r["verdicts"].items() if v is not None} == {
                    k: v for k, v in b["verdicts"].items() if v is not None}
                cells += [f"{b['seconds']:.1f}", "same" if same else f"before {b['verdicts']}, now {r['verdicts']}"]
        lines.append("| " + " | ".join(cells) + " |")
    seconds = [r["seconds"] for r in rows]
    lines += ["", f"Median {np.median(seconds):.1f} s, max {max(seconds):.1f} s per case"
              + (f" (before: median {np.median([b['seconds'] for b in before]):.1f} s, max "
                 f"{max(b['seconds'] for b in before):.1f} s)." if before else ".")]
    lines += ["", "Left out, with the reason the score records:", ""]
    for r in rows:
        for name, j in r["joints"].items():
            if j.get("success") is None:
                lines.append(f"- {r['case']} {name}: {j.get('reason') or j.get('why')}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT, help="folder of PartNet-Mobility objects")
    parser.add_argument("--ids", default=None, help="comma-separated object ids (default: every object)")
    parser.add_argument("--half", choices=("tune", "holdout"), default=None,
                        help="only the objects of this half of partnet_dev (benchmarks/partnet_dev_split.py): tune a rule "
                             "on one, report the other")
    parser.add_argument("--episodes", type=int, default=2)
    parser.add_argument("--max-steps", type=int, default=None,
                        help="steps per episode (default: the environments' registered time limit)")
    parser.add_argument("--videos", default=str(RESULTS / "opener_failures"),
                        help="folder for the failures' MP4s and contact sheet ('' for none)")
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder for opener_real.md")
    parser.add_argument("--out", type=Path, default=None, help="per-joint JSON (default: none)")
    parser.add_argument("--no-defaults", action="store_true", help="skip the per-object default-joint number")
    parser.add_argument("--score", type=Path, default=None,
                        help="instead: time the oracle's opening score on the cases of this prepared benchmark")
    parser.add_argument("--cases", default=None, help="with --score: comma-separated case ids")
    parser.add_argument("--before", type=Path, default=None,
                        help="with --score: an earlier run's --out JSON, compared in opener_score_speed.md")
    parser.add_argument("--note", default="", help="with --score: a line for the report (what was run how)")
    args = parser.parse_args()
    if args.score is not None:
        cases = args.cases.split(",") if args.cases else sorted(p.name for p in (args.score / "cases").iterdir())
        rows = score_speed(args.score, cases, path=args.out)
        before = json.loads(args.before.read_text()) if args.before else None
        console.print(f"wrote {write_score_speed(rows, before, args.results / 'opener_score_speed.md', args.note)}")
        return
    if args.max_steps is None:
        from spark_bench.envs.registration import MAX_EPISODE_STEPS

        args.max_steps = MAX_EPISODE_STEPS
    if not args.root.is_dir():
        raise SystemExit(f"{args.root}: no such folder")
    ids = args.ids.split(",") if args.ids else sorted(p.name for p in args.root.iterdir() if (p / "mobility.urdf").is_file())
    if args.half is not None:
        from benchmarks.partnet_dev_split import read_halves

        half = set(read_halves()[args.half])
        ids = [i for i in ids if i in half]
    videos = Path(args.videos) if args.videos else None  # '' is no videos (Path('') would be the cwd)
    if videos is not None and videos.is_dir():  # no stale video of an earlier run's failure
        for old in videos.glob("*.mp4"):
            if args.ids is None or old.name.split("_")[0] in ids:
                old.unlink()
    from tqdm import tqdm

    start = time.perf_counter()
    rows, defaults = [], []
    for object_id in tqdm(ids, desc="objects", unit="obj"):
        try:
            asset = load_asset(str(args.root / object_id))[0]
            joints = openable_joints(asset)
        except InputError as exc:  # one bad object does not stop the run
            console.print(f"[red]{object_id}[/]: {exc}")
            continue
        for row in joints:
            result = {**run_joint(asset, object_id, row, args.episodes, args.max_steps, videos), "object": object_id}
            rows.append(result)
            verdict = result.get("reason") or f"success {result.get('success_rate', 0.0):.2f}"
            console.print(f"{object_id} {row['joint']} ({row['category']} {row['label']}): {verdict}")
        if joints and not args.no_defaults:
            found = default_rows(asset, object_id, rows, args.episodes, args.max_steps)
            if found is not None:
                defaults.append(found)
    seconds = time.perf_counter() - start
    for s in summarize(rows):
        console.print(f"{s['category']}: {s['opened']}/{s['attempted']} attempted opened, {s['declined']} declined ({s['jammed']} stuck), "
                      f"{s['joints']} joints")
    if args.out is not None:
        args.out.write_text(json.dumps({"rows": rows, "defaults": defaults}, indent=1, default=float))
    sheet = contact_sheet(rows, videos / "contact_sheet.png") if videos else None
    console.print(f"wrote {write_report(rows, defaults, args, seconds, args.results / 'opener_real.md', sheet)}")


if __name__ == "__main__":
    main()
