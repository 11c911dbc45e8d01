"""The recipe of the shipped generalist opening policies (``spark-bench train-generalist``).

For each kind (``drawer``, ``door``): synth training tasks (every drawer / door of every synth category x the
training seeds, plus suction-cup copies of a share of them), validation tasks (the learning curve and the
choice of the kept model) and held-out test tasks (scored once, at the end); then the real objects of a
folder of PartNet-Mobility objects. The stages (demonstrations of the scripted opener + behaviour cloning,
DAgger, PPO) are :mod:`spark_bench.rl.generalist_stages`. The scripted opener with the ground-truth joint is
scored on the same test and real tasks, as the reference.

Writes the weights (``<kind>.zip``) and the record of the run (``generalist.json``) into a weights folder
(default: the package's ``spark_bench/rl/weights``), and the report ``generalist_training.md`` with
``generalist_curve.png`` (:mod:`spark_bench.rl.generalist_report`) into a results folder. The shipped
weights' record names the command line that made them (``produced_by``).
"""

from __future__ import annotations

import hashlib
import os
import platform
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from spark_bench.data.synth import GENERATOR_VERSION
from spark_bench.errors import InputError
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.rl.generalist import EPISODE_STEPS, FEATURE_VERSION, RECORD_NAME, WEIGHTS_DIR, weights_path
from spark_bench.rl.generalist_report import plot_curves, report
from spark_bench.rl.generalist_stages import POLICY_KWARGS, PPO_SETTINGS, StageSettings, train_kind
from spark_bench.rl.tasks import (
    BuiltTask,
    Task,
    build_tasks,
    evaluate,
    evaluate_teacher,
    holdable,
    object_tasks,
    rate_by,
    success_rate,
    synth_tasks,
)

#: The version of the shipped weights (bumped with each shipped training run).
WEIGHTS_VERSION = "2"
#: How the synth tasks' objects are named (by seed and generator version, not by path).
SYNTH = {"generator_version": GENERATOR_VERSION,
         "objects": "<category>_<seed> of every synth category, by spark_bench.data.synth.generate_object"}
#: What the record says the method is.
METHOD = ("behaviour cloning of the scripted opener with ground-truth joints (DART noise, DAgger), then PPO "
          "(stable-baselines3) on the synth training tasks; grasp-frame features (spark_bench.rl.generalist); "
          "each task with the end-effector the opening score chooses (end_effector='auto': the suction cup where "
          "the grasp planner finds nothing to pinch, the parallel gripper elsewhere), one policy per kind "
          "driving either")


@dataclass
class RecipeOptions:
    """What one run of the recipe does.

    :param command: the command line that ran it (the record's ``produced_by`` / ``scored_by``)
    :param kinds: the policy kinds to train (``drawer``, ``door``)
    :param seeds: synth seeds of the ``train``, ``val`` and ``test`` tasks
    :param stages: the stages' settings
    :param seed: the training seed
    :param cup_every: also train on every N-th training task that ``auto`` gives the gripper, with the
        suction cup forced; 0: none
    :param categories: the synth categories of the tasks (None: all)
    :param real: a folder of real objects to score on (None: none)
    :param weights: where the weights and their record go
    :param results: where the report and the curve go
    :param score_only: only score the weights in ``weights`` again and update their record and report
    """

    command: str
    kinds: tuple[str, ...] = ("drawer", "door")
    seeds: dict[str, list[int]] = field(default_factory=dict)
    stages: StageSettings = field(default_factory=StageSettings)
    seed: int = 0
    cup_every: int = 3
    categories: tuple[str, ...] | None = None
    real: Path | None = None
    weights: Path = WEIGHTS_DIR
    results: Path = Path("benchmarks/results")
    score_only: bool = False


def seed_range(text: str) -> list[int]:
    """Seeds from ``A:B`` (A to B-1) or a comma list.

    :param text: the option's text
    :raises InputError: text that is neither
    """
    try:
        if ":" in text:
            first, end = text.split(":", 1)
            return list(range(int(first), int(end)))
        return [int(s) for s in text.split(",") if s]
    except ValueError:
        raise InputError(None, f"seeds {text!r}: expected A:B or a comma list of integers") from None


def sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def scores(rows: list[dict], teacher: list[dict]) -> dict:
    """The policy's and the teacher's success on the same tasks: all, holdable grasps, by grasp, part and
    end-effector.

    :param rows: the policy's rows (:func:`~spark_bench.rl.tasks.evaluate`)
    :param teacher: the scripted opener's rows on the same tasks (:func:`~spark_bench.rl.tasks.evaluate_teacher`)
    """
    hold = [r for r in rows if holdable(r)]
    hold_t = [r for r in teacher if holdable(r)]
    return {"tasks": len(rows), "success_rate": success_rate(rows), "teacher_success_rate": success_rate(teacher),
            "holdable_tasks": len(hold), "holdable_success_rate": success_rate(hold),
            "holdable_teacher_success_rate": success_rate(hold_t),
            "by_grasp": rate_by(rows, "grasp"), "teacher_by_grasp": rate_by(teacher, "grasp"),
            "by_part": rate_by(rows, "part"), "teacher_by_part": rate_by(teacher, "part"),
            "by_end_effector": rate_by(rows, "end_effector"),
            "teacher_by_end_effector": rate_by(teacher, "end_effector"),
            "holdable_by_part": rate_by(hold, "part")}


def real_tasks(folder: Path, kind: str) -> list[Task]:
    """Every task of ``kind`` of the objects in ``folder``; an unreadable object is skipped with a message.

    :param folder: a folder of object folders
    :param kind: ``drawer`` or ``door``
    """
    tasks = []
    for obj in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        try:
            tasks += [t for t in object_tasks(obj) if t.kind == kind]
        except Exception as exc:  # noqa: BLE001  (one unreadable object never ends the run)
            print(f"  skipping {obj.name}: {' '.join(str(exc).split())[:120]}", flush=True)
    return tasks


def cup_copies(built: list[BuiltTask], every: int) -> list[Task]:
    """Every ``every``-th task of ``built`` that ``auto`` gives the gripper, again with the suction cup
    forced (a task whose part offers the cup no flat patch fails to build and is skipped).

    :param built: built training tasks
    :param every: keep one in this many (>= 1)
    """
    gripped = [b.task for b in built if b.end_effector == EndEffector.GRIPPER and b.task.end_effector == EndEffector.AUTO]
    return [replace(task, end_effector=EndEffector.SUCTION) for task in gripped[::every]]


def new_record(options: RecipeOptions) -> dict:
    """The record of a training run before any policy is trained."""
    import stable_baselines3
    import torch

    synth = SYNTH if options.categories is None else {**SYNTH, "categories": list(options.categories)}
    return {"version": WEIGHTS_VERSION, "feature_version": FEATURE_VERSION, "produced_by": options.command,
            "method": METHOD, "seed": options.seed, "episode_steps": EPISODE_STEPS, "seeds": options.seeds,
            "synth": synth, "policy_kwargs": POLICY_KWARGS, "ppo": PPO_SETTINGS,
            "stages": asdict(options.stages), "cup_every": options.cup_every,
            "software": {"python": platform.python_version(), "stable_baselines3": stable_baselines3.__version__,
                         "torch": torch.__version__},
            "cpus": os.cpu_count(), "policies": {}}


def build_sets(kind: str, options: RecipeOptions) -> dict[str, list[BuiltTask]]:
    """The built ``train`` (with its cup copies), ``val`` and ``test`` tasks of ``kind``."""
    built = {}
    for name, seeds in options.seeds.items():
        tasks = [t for t in synth_tasks(seeds, options.categories) if t.kind == kind]
        built[name], skipped = build_tasks(tasks, progress=True)
        if name == "train" and options.cup_every > 0:
            cups = cup_copies(built[name], options.cup_every)
            more, _ = build_tasks(cups, progress=True)
            more = [b for b in more if not b.reason]  # the cup finds no flat patch, or no way in
            built[name] += more
            print(f"train: {len(more)} of {len(cups)} cup copies built", flush=True)
        print(f"{name}: {len(built[name])} tasks ({len(skipped)} without an opening task)", flush=True)
    return built


def train_policy(kind: str, options: RecipeOptions, record: dict):
    """Train, score on the held-out tasks and save the policy of ``kind``; its entry goes into ``record``.

    :returns: the kept model
    """
    print(f"\n== {kind} ==", flush=True)
    built = build_sets(kind, options)
    teacher_train = evaluate_teacher(built["train"], progress=True)
    solved = {r["task"] for r in teacher_train if r["success_rate"] > 0}
    print(f"teacher opens {len(solved)}/{len(built['train'])} training tasks", flush=True)

    def show(row) -> None:
        print(f"[{kind}] {row.stage:28s} steps {row.env_steps:>9,d}  wall {row.wall_s:7.1f} s  "
              f"val success {row.val_success:.3f}", flush=True)

    result = train_kind(built["train"], solved, built["val"], options.stages, seed=options.seed, on_row=show)
    test = scores(evaluate(result.model, built["test"], progress=True), evaluate_teacher(built["test"]))
    print(f"[{kind}] held-out synth: {test['success_rate']:.3f} (teacher {test['teacher_success_rate']:.3f}); "
          f"holdable grasps {test['holdable_success_rate']:.3f} (teacher "
          f"{test['holdable_teacher_success_rate']:.3f}) over {test['holdable_tasks']} tasks", flush=True)
    path = weights_path(kind, options.weights)
    result.model.save(path)
    record["policies"][kind] = {
        "file": path.name, "sha256": sha256(path), "bytes": path.stat().st_size,
        "env_steps": result.steps, "wall_s": result.wall_s, "demos": result.demos,
        "train_tasks": len(built["train"]), "teacher_solved_train_tasks": len(solved),
        "train_tasks_by_end_effector": {e: sum(b.end_effector == e for b in built["train"])
                                        for e in (EndEffector.GRIPPER, EndEffector.SUCTION)},
        "kept": result.best.__dict__ if result.best else None, "curve": result.curve_dicts(),
        "test": test, "real": None}
    for b in (x for tasks in built.values() for x in tasks):
        b.env.close()
    return result.model


def score_real(kind: str, model, folder: Path) -> dict:
    """The policy's and the teacher's success on the tasks of ``kind`` of the real objects in ``folder``,
    every task's row kept."""
    built, skipped = build_tasks(real_tasks(folder, kind), progress=True)
    rows = evaluate(model, built)
    real = {"folder": str(folder), **scores(rows, evaluate_teacher(built)), "without_task": len(skipped),
            "rows": rows}
    print(f"[{kind}] real objects: {real['success_rate']} (teacher {real['teacher_success_rate']}) over "
          f"{real['tasks']} tasks; {len(skipped)} joints without an opening task", flush=True)
    for b in built:
        b.env.close()
    return real


def rescore_synth(options: RecipeOptions) -> tuple[dict, dict]:
    """``--score-only``: the record and models in ``options.weights``, their held-out synth scores measured
    again (policy and teacher, every test task's row kept).

    :returns: ``(record, {kind: model})``
    """
    from spark_bench.rl.generalist import load_generalist, weights_record

    record = weights_record(options.weights)
    record.setdefault("synth", SYNTH)
    record["scored_by"] = options.command
    models = {kind: load_generalist(kind, options.weights) for kind in options.kinds}
    categories = options.categories or record["synth"].get("categories")
    for kind, model in models.items():
        tasks = [t for t in synth_tasks(record["seeds"]["test"], categories) if t.kind == kind]
        built, _ = build_tasks(tasks, progress=True)
        rows = evaluate(model, built, progress=True)
        record["policies"][kind]["test"] = test = {**scores(rows, evaluate_teacher(built)), "rows": rows}
        print(f"[{kind}] held-out synth: {test['success_rate']:.3f} (teacher {test['teacher_success_rate']:.3f}); "
              f"holdable {test['holdable_success_rate']:.3f} over {test['holdable_tasks']} tasks", flush=True)
        for b in built:
            b.env.close()
    return record, models


def write_record(record: dict, options: RecipeOptions, t0: float, wall_key: str) -> None:
    """The record beside the weights and the Markdown report (rewritten as the run goes on).

    :param t0: when the run started (``time.perf_counter``)
    :param wall_key: where the wall time so far goes (``wall_s`` training, ``score_wall_s`` ``--score-only``)
    """
    from spark_bench.jsonio import to_json_text

    record[wall_key] = round(time.perf_counter() - t0, 1)
    (options.weights / RECORD_NAME).write_text(to_json_text(record, indent=1) + "\n")
    (options.results / "generalist_training.md").write_text(report(record, shown_path(options.weights)))


def shown_path(path: Path) -> str:
    """``path`` as a report shows it: relative to the working folder when inside it (no machine's path)."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def run_recipe(options: RecipeOptions) -> dict:
    """Train (or, with ``score_only``, score again) the generalist policies, writing their weights, record,
    report and learning curve.

    :returns: the record
    """
    import torch

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    options.weights.mkdir(parents=True, exist_ok=True)
    options.results.mkdir(parents=True, exist_ok=True)
    if options.score_only:
        record, models = rescore_synth(options)
    else:
        record, models = new_record(options), {}
        for kind in options.kinds:
            models[kind] = train_policy(kind, options, record)
            write_record(record, options, t0, "wall_s")
    if options.real is not None and options.real.is_dir():
        for kind, model in models.items():  # last: a real object's first conversion can take minutes (CoACD)
            record["policies"][kind]["real"] = score_real(kind, model, options.real)
    write_record(record, options, t0, "score_wall_s" if options.score_only else "wall_s")
    plot_curves({kind: p["curve"] for kind, p in record["policies"].items()},
                options.results / "generalist_curve.png")
    print(f"\nwrote {options.weights / RECORD_NAME}, {options.results / 'generalist_training.md'} "
          f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return record
