"""Train the generalist opening policies (drawer, door) and ship them with the package.

For each kind: synth training tasks (every drawer / door of every synth category x ``--train-seeds``),
validation tasks (``--val-seeds``: the learning curve and the choice of the kept model) and held-out test
tasks (``--test-seeds``: scored once, at the end), then the real objects of ``--real`` (PartNet-Mobility
folders, default ``../shared/partnet_dev``). Stages: demonstrations of the scripted opener + behaviour
cloning, DAgger, PPO (:mod:`generalist_train`). The scripted opener with the ground-truth
joint is scored on the same test and real tasks, as the reference.

Prints the learning curve as it goes; writes the weights (``<kind>.zip``) and the record of the run
(``generalist.json``) into ``--weights`` (default: the package's ``spark_bench/rl/weights``), and the report
``generalist_training.md`` with ``generalist_curve.png`` into ``--results``.

Run: ``nice -n 10 python benchmarks/train_generalist.py [--kinds drawer door] [--train-seeds 1000:1012]
[--ppo-steps 100000] [--ppo-minutes 15] [--real DIR | --no-real]``; ``--score-only`` scores the weights in
``--weights`` again (held-out synth seeds, and ``--real``) and updates their record. The time per case of ``eval --rl`` is measured
by ``benchmarks/measure_eval.py --rl N``.
"""

from __future__ import annotations

import argparse
import hashlib
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

from generalist_train import POLICY_KWARGS, PPO_SETTINGS, StageSettings, train_kind

from spark_bench.data.synth import GENERATOR_VERSION
from spark_bench.rl.generalist import EPISODE_STEPS, FEATURE_VERSION, RECORD_NAME, WEIGHTS_DIR, weights_path
from spark_bench.rl.tasks import (
    build_tasks,
    evaluate,
    evaluate_teacher,
    holdable,
    object_tasks,
    rate_by,
    success_rate,
    synth_tasks,
)

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "partnet_dev"
#: The version of the shipped weights (bumped with each shipped training run).
WEIGHTS_VERSION = "2"
#: The issue's target success rate on unseen synth seeds.
TARGET = 0.9
#: How the synth tasks' objects are named (by seed and generator version, not by path).
SYNTH = {"generator_version": GENERATOR_VERSION,
         "objects": "<category>_<seed> of every synth category, by spark_bench.data.synth.generate_object"}


def seed_range(text: str) -> list[int]:
    """``A:B`` (A to B-1) or a comma list."""
    if ":" in text:
        a, b = text.split(":", 1)
        return list(range(int(a), int(b)))
    return [int(s) for s in text.split(",") if s]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def scores(rows: list[dict], teacher: list[dict]) -> dict:
    """The policy's and the teacher's success on the same tasks: all, holdable grasps, by grasp."""
    hold = [r for r in rows if holdable(r)]
    hold_t = [r for r in teacher if holdable(r)]
    return {"tasks": len(rows), "success_rate": success_rate(rows), "teacher_success_rate": success_rate(teacher),
            "holdable_tasks": len(hold), "holdable_success_rate": success_rate(hold),
            "holdable_teacher_success_rate": success_rate(hold_t),
            "by_grasp": rate_by(rows, "grasp"), "teacher_by_grasp": rate_by(teacher, "grasp"),
            "by_part": rate_by(rows, "part"), "teacher_by_part": rate_by(teacher, "part"),
            "by_end_effector": rate_by(rows, "end_effector"), "teacher_by_end_effector": rate_by(teacher, "end_effector"),
            "holdable_by_part": rate_by(hold, "part")}


def real_tasks(folder: Path, kind: str) -> list:
    tasks = []
    for obj in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        try:
            tasks += [t for t in object_tasks(obj) if t.kind == kind]
        except Exception as exc:  # noqa: BLE001  (one unreadable object never ends the run)
            print(f"  skipping {obj.name}: {' '.join(str(exc).split())[:120]}", flush=True)
    return tasks


def cup_copies(built: list, every: int) -> list:
    """Every ``every``-th task of ``built`` that ``auto`` gives the gripper, again with the suction cup
    forced (a task whose part offers the cup no flat patch fails to build and is skipped).

    :param built: built training tasks
    :param every: keep one in this many (>= 1)
    """
    from dataclasses import replace

    gripped = [b.task for b in built if b.end_effector == "gripper" and b.task.end_effector == "auto"]
    return [replace(task, end_effector="suction") for task in gripped[::every]]


def plot(curves: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for kind, rows in curves.items():
        ax.plot([r["env_steps"] for r in rows], [r["val_success"] for r in rows], marker="o", label=kind)
    ax.set_xlabel("environment steps (demonstrations + DAgger + PPO)")
    ax.set_ylabel("validation success rate")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title("generalist opening policies: learning curve")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kinds", nargs="+", default=["drawer", "door"], choices=["drawer", "door"])
    parser.add_argument("--train-seeds", default="1000:1012")
    parser.add_argument("--val-seeds", default="8000:8003")
    parser.add_argument("--test-seeds", default="9000:9005")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cup-every", type=int, default=3,
                        help="also train on every N-th training task that 'auto' gives the gripper, with the "
                             "suction cup forced (cup experience on parts with a handle: synth drawers all have "
                             "one); 0: none")
    parser.add_argument("--demo-episodes", type=int, default=3)
    parser.add_argument("--dagger-rounds", type=int, default=2)
    parser.add_argument("--ppo-steps", type=int, default=100_000)
    parser.add_argument("--ppo-minutes", type=float, default=15.0, help="PPO wall-time limit per kind")
    parser.add_argument("--real", type=Path, default=REAL, help="folder of real objects to score on")
    parser.add_argument("--no-real", action="store_true")
    parser.add_argument("--score-only", action="store_true",
                        help="only score the weights in --weights again, on their held-out synth seeds and on "
                             "--real (unless --no-real), and update their record and report")
    parser.add_argument("--weights", type=Path, default=WEIGHTS_DIR)
    parser.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)

    import stable_baselines3
    import torch

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    settings = StageSettings(demo_episodes=args.demo_episodes, dagger_rounds=args.dagger_rounds,
                             ppo_steps=args.ppo_steps, ppo_max_wall_s=60.0 * args.ppo_minutes)
    seeds = {name: seed_range(getattr(args, f"{name}_seeds")) for name in ("train", "val", "test")}
    args.weights.mkdir(parents=True, exist_ok=True)
    args.results.mkdir(parents=True, exist_ok=True)
    record = {"version": WEIGHTS_VERSION, "feature_version": FEATURE_VERSION,
              "produced_by": "python benchmarks/train_generalist.py " + " ".join(sys.argv[1:] if argv is None else argv),
              "method": "behaviour cloning of the scripted opener with ground-truth joints (DART noise, DAgger), "
                        "then PPO (stable-baselines3) on the synth training tasks; grasp-frame features "
                        "(spark_bench.rl.generalist); each task with the end-effector the opening score chooses "
                        "(end_effector='auto': the suction cup where the grasp planner finds nothing to pinch, "
                        "the parallel gripper elsewhere), one policy per kind driving either",
              "seed": args.seed, "episode_steps": EPISODE_STEPS, "seeds": seeds,
              "synth": SYNTH,
              "policy_kwargs": POLICY_KWARGS, "ppo": PPO_SETTINGS,
              "stages": asdict(settings), "cup_every": args.cup_every,
              "software": {"python": platform.python_version(), "stable_baselines3": stable_baselines3.__version__,
                           "torch": torch.__version__},
              "policies": {}}
    curves, models = {}, {}
    if args.score_only:
        record, models, curves = rescore_synth(args)
    for kind in ([] if args.score_only else args.kinds):
        print(f"\n== {kind} ==", flush=True)
        sets = {name: [t for t in synth_tasks(s) if t.kind == kind] for name, s in seeds.items()}
        built = {}
        for name, tasks in sets.items():
            built[name], skipped = build_tasks(tasks, progress=True)
            if name == "train" and args.cup_every > 0:
                cups = cup_copies(built[name], args.cup_every)
                more, _ = build_tasks(cups, progress=True)
                more = [b for b in more if not b.reason]  # the cup finds no flat patch, or no way in
                built[name] += more
                print(f"train: {len(more)} of {len(cups)} cup copies built", flush=True)
            print(f"{name}: {len(built[name])} tasks ({len(skipped)} without an opening task)", flush=True)
        teacher_train = evaluate_teacher(built["train"], progress=True)
        solved = {r["task"] for r in teacher_train if r["success_rate"] > 0}
        print(f"teacher opens {len(solved)}/{len(built['train'])} training tasks", flush=True)

        def show(row, kind=kind):
            print(f"[{kind}] {row.stage:28s} steps {row.env_steps:>9,d}  wall {row.wall_s:7.1f} s  "
                  f"val success {row.val_success:.3f}", flush=True)

        result = train_kind(built["train"], solved, built["val"], settings, seed=args.seed, on_row=show)
        curves[kind] = result.curve_dicts()
        test_rows = evaluate(result.model, built["test"], progress=True)
        test = scores(test_rows, evaluate_teacher(built["test"]))
        print(f"[{kind}] held-out synth: {test['success_rate']:.3f} (teacher {test['teacher_success_rate']:.3f}); "
              f"holdable grasps {test['holdable_success_rate']:.3f} (teacher "
              f"{test['holdable_teacher_success_rate']:.3f}) over {test['holdable_tasks']} tasks", flush=True)
        path = weights_path(kind, args.weights)
        result.model.save(path)
        record["policies"][kind] = {
            "file": path.name, "sha256": sha256(path), "bytes": path.stat().st_size,
            "env_steps": result.steps, "wall_s": result.wall_s, "demos": result.demos,
            "train_tasks": len(built["train"]), "teacher_solved_train_tasks": len(solved),
            "train_tasks_by_end_effector": {e: sum(b.end_effector == e for b in built["train"])
                                            for e in ("gripper", "suction")},
            "kept": result.best.__dict__ if result.best else None, "curve": curves[kind],
            "test": test, "real": None}
        write_record(record, args, t0, "wall_s")
        models[kind] = result.model
        for b in (x for v in built.values() for x in v):
            b.env.close()
    for kind, model in models.items():  # last: a real object's first conversion can take minutes (CoACD)
        if args.no_real or not args.real.is_dir():
            break
        rb, rskip = build_tasks(real_tasks(args.real, kind), progress=True)
        real_rows = evaluate(model, rb)
        real = {"folder": str(args.real), **scores(real_rows, evaluate_teacher(rb)), "without_task": len(rskip),
                "rows": real_rows}
        record["policies"][kind]["real"] = real
        print(f"[{kind}] real objects: {real['success_rate']} (teacher {real['teacher_success_rate']}) over "
              f"{real['tasks']} tasks; {len(rskip)} joints without an opening task", flush=True)
        for b in rb:
            b.env.close()
    write_record(record, args, t0, "score_wall_s" if args.score_only else "wall_s")
    plot(curves, args.results / "generalist_curve.png")
    print(f"\nwrote {args.weights / RECORD_NAME}, {args.results / 'generalist_training.md'} "
          f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return 0


def rescore_synth(args) -> tuple[dict, dict, dict]:
    """``--score-only``: the record and models in ``--weights``, their held-out synth scores measured again
    (policy and teacher, every test task's row kept)."""
    from spark_bench.rl.generalist import load_generalist, weights_record

    record = weights_record(args.weights)
    record.setdefault("synth", SYNTH)
    record["scored_by"] = "python benchmarks/train_generalist.py " + " ".join(sys.argv[1:])
    models = {kind: load_generalist(kind, args.weights) for kind in args.kinds}
    for kind, model in models.items():
        built, _ = build_tasks([t for t in synth_tasks(record["seeds"]["test"]) if t.kind == kind], progress=True)
        rows = evaluate(model, built, progress=True)
        record["policies"][kind]["test"] = {**scores(rows, evaluate_teacher(built)), "rows": rows}
        test = record["policies"][kind]["test"]
        print(f"[{kind}] held-out synth: {test['success_rate']:.3f} (teacher {test['teacher_success_rate']:.3f}); "
              f"holdable {test['holdable_success_rate']:.3f} over {test['holdable_tasks']} tasks", flush=True)
        for b in built:
            b.env.close()
    return record, models, {kind: record["policies"][kind]["curve"] for kind in record["policies"]}


def write_record(record: dict, args, t0: float, wall_key: str) -> None:
    """The record beside the weights and the Markdown report (rewritten as the run goes on).

    :param wall_key: where the wall time so far goes (``wall_s`` training, ``score_wall_s`` ``--score-only``)
    """
    from spark_bench.jsonio import to_json_text

    record[wall_key] = round(time.perf_counter() - t0, 1)
    (args.weights / RECORD_NAME).write_text(to_json_text(record, indent=1) + "\n")
    (args.results / "generalist_training.md").write_text(report(record, args))


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f}%"


def report(record: dict, args) -> str:
    lines = ["# Generalist opening policies: training run", "",
             f"Produced by `{record['produced_by']}` on 2 shared CPU cores (other jobs running), "
             f"{record['wall_s']:.0f} s in all. Weights: `{args.weights}` version {record['version']} "
             f"(feature version {record['feature_version']}); the full record is `generalist.json` beside them.",
             *([f"Scores (held-out synth, real objects) measured again with the shipped weights by "
                f"`{record['scored_by']}` ({record.get('score_wall_s', 0):.0f} s)."] if record.get("scored_by") else []),
             "", f"Method: {record['method']}.", "",
             f"Synth seeds: train {record['seeds']['train'][0]}..{record['seeds']['train'][-1]}, validation "
             f"{record['seeds']['val'][0]}..{record['seeds']['val'][-1]}, held-out test "
             f"{record['seeds']['test'][0]}..{record['seeds']['test'][-1]} (every synth category; a task is one "
             "drawer or door). One episode per task, at most "
             f"{record['episode_steps']} steps; success = the joint passes 75 % of its range.", "",
             "| policy | env steps (demos / DAgger / PPO) | wall | held-out synth: all | holdable grasps | "
             "teacher (all / holdable) | real objects | teacher on real (all / holdable) |", "|---|---|---|---|---|---|---|---|"]
    for kind, p in record["policies"].items():
        s, t, real = p["env_steps"], p["test"], p["real"]
        real_cell = "-" if real is None else (f"{_pct(real['success_rate'])} of {real['tasks']} (holdable "
                                              f"{_pct(real['holdable_success_rate'])} of {real['holdable_tasks']})")
        teach_real = "-" if real is None else (f"{_pct(real['teacher_success_rate'])} / "
                                               f"{_pct(real['holdable_teacher_success_rate'])}")
        lines.append(f"| {kind} | {s['total']:,} ({s['demos']:,} / {s['dagger']:,} / {s['ppo']:,}) | "
                     f"{p['wall_s']:.0f} s | {_pct(t['success_rate'])} of {t['tasks']} | "
                     f"{_pct(t['holdable_success_rate'])} of {t['holdable_tasks']} | "
                     f"{_pct(t['teacher_success_rate'])} / {_pct(t['holdable_teacher_success_rate'])} | "
                     f"{real_cell} | {teach_real} |")
    lines += ["", "Holdable: a grasp on a labelled or geometric handle, a finger-pull notch, a lid's tab or the "
              "front's edges, or the suction cup's flat patch (`suction`), that the grasp planner gives no reason "
              "against (spark_bench.rl.tasks.holdable); the rest (`face`: bare fronts; or a planner reason) "
              "neither end-effector can pull open. They count in `all`.", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        verdict = lambda rate: "met" if rate is not None and rate >= TARGET else "not met"  # noqa: E731
        lines.append(f"- Target >= {TARGET:.0%} on unseen synth seeds, {kind}: {verdict(t['success_rate'])} on all "
                     f"tasks ({_pct(t['success_rate'])}), {verdict(t['holdable_success_rate'])} on holdable grasps "
                     f"({_pct(t['holdable_success_rate'])}); the scripted teacher itself reaches "
                     f"{_pct(t['teacher_success_rate'])} / {_pct(t['holdable_teacher_success_rate'])}.")
    lines += ["",
              "## By grasp (held-out synth; policy / teacher)", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        cells = [f"{g}: {_pct(v['success_rate'])} / {_pct(t['teacher_by_grasp'].get(g, {}).get('success_rate'))} "
                 f"({v['tasks']})" for g, v in t["by_grasp"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    lines += ["", "## By end-effector (held-out synth; policy / teacher)", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        if "by_end_effector" not in t:  # a record scored before rows named their end-effector
            continue
        cells = [f"{e}: {_pct(v['success_rate'])} / "
                 f"{_pct(t['teacher_by_end_effector'].get(e, {}).get('success_rate'))} ({v['tasks']})"
                 for e, v in t["by_end_effector"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    lines += ["", "## By moving part (held-out synth; the part's label; policy / teacher, then the policy on "
              "holdable grasps)", "",
              "The door policy's tasks are every revolute joint of every category (doors, lids, windows, "
              "screens, levers, pedals); the drawer policy's every prismatic one.", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        if "by_part" not in t:  # a record scored before rows named their part
            continue
        cells = [f"{g or '(none)'}: {_pct(v['success_rate'])} / "
                 f"{_pct(t['teacher_by_part'].get(g, {}).get('success_rate'))} ({v['tasks']}); holdable "
                 f"{_pct(t['holdable_by_part'].get(g, {}).get('success_rate'))} "
                 f"({t['holdable_by_part'].get(g, {}).get('tasks', 0)})" for g, v in t["by_part"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    lines += ["", "## Learning curve (validation success)", "", "![learning curve](generalist_curve.png)", ""]
    for kind, p in record["policies"].items():
        lines += [f"### {kind}", "", "| stage | env steps | wall | validation success |", "|---|---|---|---|"]
        lines += [f"| {r['stage']} | {r['env_steps']:,} | {r['wall_s']:.0f} s | {_pct(r['val_success'])} |"
                  for r in p["curve"]]
        lines.append("")
    for kind, p in record["policies"].items():
        if p["real"] is None:
            continue
        lines += [f"## Real objects, {kind} ({p['real']['folder']})", "",
                  "| task | part | end-effector | grasp | policy | max fraction | asset sha256 |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['task']} | {r.get('part', '')} | {r.get('end_effector', 'gripper')} | {r['grasp']} | "
                  f"{'opened' if r['success_rate'] > 0 else 'no'} | {r['max_fraction']:.2f} | "
                  f"{(r.get('asset') or {}).get('sha256', '')[:12]} |" for r in p["real"]["rows"]]
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
