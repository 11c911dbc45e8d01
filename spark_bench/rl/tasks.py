"""Opening tasks for the generalist policies: every drawer and door of synth objects (by category and
seed) or of object folders, their environments, and a policy's (or the scripted opener's) success on them.

A task is one joint of one object: ``drawer`` for a prismatic joint, ``door`` for a revolute one
(continuous joints, knobs and caps, are not opening tasks). Synth objects are generated once into
``$SPARK_BENCH_HOME/rl/synth_v<generator version>/<category>_<seed>`` and reused.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np

import spark_bench.rl.rollout as rollout
from spark_bench.errors import InputError
from spark_bench.manipulation.end_effector import EndEffector
from spark_bench.opening.pairing import OPENING_TYPES, opening_joints
from spark_bench.rl.generalist import EPISODE_STEPS, KIND_OF_TYPE, GraspFrameWrapper, make_task_env

#: The policy kind of each joint type that is an opening task (:data:`spark_bench.opening.pairing.OPENING_TYPES`;
#: continuous joints, knobs and caps, are not).
TASK_KIND = {t: KIND_OF_TYPE[t] for t in OPENING_TYPES}


@dataclass
class Task:
    """One joint to open.

    :param folder: the object folder
    :param joint: the joint's name
    :param kind: ``drawer`` or ``door``
    :param category: the object's category
    :param seed: the synth seed (None for a real object)
    :param end_effector: ``auto`` (the opening score's choice: the suction cup where the grasp planner finds
        nothing to pinch), or ``gripper`` / ``suction`` forced (a training task's cup on a part with a handle)
    """

    folder: Path
    joint: str
    kind: str
    category: str = ""
    seed: int | None = None
    end_effector: str = "auto"

    @property
    def name(self) -> str:
        forced = "" if self.end_effector == EndEffector.AUTO else f" ({self.end_effector})"
        return f"{Path(self.folder).name}/{self.joint}{forced}"


@dataclass
class BuiltTask:
    """A task with its environment (:class:`GraspFrameWrapper` over the ``frame`` environment).

    :param grasp: the grasp's source (``label``, ``geometry``, ``notch``, ``tab``, ``edge``, ``face``;
        ``suction`` for the cup's place)
    :param reason: the planner's reason why the end-effector cannot pull the part open, or None
    :param part: the moving part's label (``door``, ``lid``, ``drawer``, ``window``, ...; empty if none)
    :param asset: the simulated object, as stored records name it: ``{"path", "sha256"}``
        (:func:`spark_bench.rl.records.asset_content_hash` of the asset the environment was built from)
    :param end_effector: ``gripper`` or ``suction``: what the environment carries (``auto``'s choice)
    """

    task: Task
    env: gym.Env
    grasp: str = ""
    info: dict = field(default_factory=dict)
    reason: str | None = None
    part: str = ""
    asset: dict | None = None
    end_effector: str = "gripper"

    @property
    def raw(self) -> gym.Env:
        """The environment under the wrapper (``frame`` observations, world-frame actions)."""
        return self.env.env


def synth_root() -> Path:
    """Where the synth objects of the tasks are generated (per generator version)."""
    from spark_bench.data.synth import GENERATOR_VERSION
    from spark_bench.paths import cache_dir

    return cache_dir("rl") / f"synth_v{GENERATOR_VERSION}"


def benchmark_object_seeds() -> set[int]:
    """The synth seeds of every named synth benchmark's objects (training must not see them)."""
    from spark_bench.data.benchmarks import BENCHMARKS
    from spark_bench.data.synth.generate import object_seed

    return {object_seed(b.seed, i) for b in BENCHMARKS.values() if not getattr(b, "ids", ())
            for i in range(b.n_objects)}


def object_tasks(folder: str | Path, category: str = "", seed: int | None = None) -> list[Task]:
    """Every drawer and door of the object in ``folder``."""
    from spark_bench.data import load_object

    asset = load_object(folder, load_meshes=False)
    return [Task(Path(folder), j.name, TASK_KIND[j.type], category or asset.category, seed)
            for j in opening_joints(asset)]


def synth_tasks(seeds, categories=None, root: str | Path | None = None) -> list[Task]:
    """Every drawer and door of the synth objects of ``categories`` (default: all) x ``seeds``.

    :raises InputError: a seed that a named benchmark's object also has
    """
    from spark_bench.data.synth import CATEGORIES, generate_object

    seeds = [int(s) for s in seeds]
    shared = sorted(set(seeds) & benchmark_object_seeds())
    if shared:
        raise InputError(None, f"synth seed {shared[0]} is a named benchmark object's seed: pick other seeds")
    root = Path(root) if root is not None else synth_root()
    tasks = []
    for seed in seeds:
        for category in categories or CATEGORIES:
            folder = root / f"{category}_{seed}"
            if not (folder / "mobility.urdf").is_file():
                folder = Path(generate_object(category, seed, root, folder.name))
            tasks.extend(object_tasks(folder, category, seed))
    return tasks


def build_tasks(tasks: list[Task], max_episode_steps: int = EPISODE_STEPS, progress: bool = False
                ) -> tuple[list[BuiltTask], list[tuple[Task, str]]]:
    """The environments of ``tasks``, each with its end-effector (:attr:`Task.end_effector`; ``auto``, the
    scripted opening score's choice, unless forced); a task whose environment cannot be made (no grasp on the
    part, an MJCF that does not compile) is skipped with the reason.

    :returns: ``(built, skipped)``
    """
    from tqdm import tqdm

    from spark_bench.rl.records import asset_content_hash

    built, skipped, hashes = [], [], {}
    for task in tqdm(tasks, desc="building tasks", unit="task", disable=not progress):
        try:
            env = make_task_env(task.kind, task.folder, task.joint, max_episode_steps=max_episode_steps,
                                end_effector=task.end_effector)
        except InputError as exc:
            skipped.append((task, " ".join(str(exc).split())[:200]))
            continue
        scene = env.unwrapped.scene
        path = str(Path(task.folder).resolve())
        if path not in hashes:  # every joint of an object shares its asset: hash it once
            hashes[path] = asset_content_hash(scene.asset)
        built.append(BuiltTask(task, GraspFrameWrapper(env), scene.grasp.source,
                               reason=scene.grasp.reason,
                               part=scene.asset.links[scene.joint.child].label, asset={"path": path, "sha256": hashes[path]},
                               end_effector=scene.end_effector))
    return built, skipped


def run_episode(env: gym.Env, policy, seed: int, max_steps: int = EPISODE_STEPS, stop_on_success: bool = True,
                frames: list | None = None, frame_every: int = 1) -> dict:
    """:func:`spark_bench.rl.rollout.run_episode` with the tasks' defaults: at most :data:`EPISODE_STEPS`
    steps, ended at success."""
    return rollout.run_episode(env, policy, seed, max_steps, stop_on_success, frames, frame_every)


def run_episodes(env: gym.Env, policy, episodes: int, seed: int) -> rollout.RolloutStats:
    """``episodes`` episodes of :func:`run_episode` (seeds ``seed + k``).

    :param policy: ``reset(env)``, ``__call__(obs)``
    :param seed: the first episode's reset seed
    """
    return rollout.run_episodes(env, policy, episodes, seed, max_steps=EPISODE_STEPS, stop_on_success=True)


def evaluate(model, built: list[BuiltTask], episodes: int = 1, seed: int = 0, progress: bool = False) -> list[dict]:
    """The model's episodes on every task (seeds ``seed + k``), one row per task.

    :returns: rows ``{"task", "kind", "category", "part", "grasp", "reason", "end_effector", "asset",
        "success_rate", "max_fraction"}``
    """
    from spark_bench.rl.policies import ModelPolicy

    return _score(built, lambda bt: (bt.env, ModelPolicy(model)), episodes, seed, progress, "policy")


def evaluate_teacher(built: list[BuiltTask], episodes: int = 1, seed: int = 0, progress: bool = False) -> list[dict]:
    """The scripted opener with the ground-truth joint on every task, as :func:`evaluate` scores a model."""
    from spark_bench.rl.policies import ScriptedPolicy

    return _score(built, lambda bt: (bt.raw, ScriptedPolicy()), episodes, seed, progress, "scripted opener")


def _score(built, actor_of, episodes, seed, progress, what) -> list[dict]:
    from tqdm import tqdm

    rows = []
    for bt in tqdm(built, desc=f"evaluating {what}", unit="task", disable=not progress):
        env, actor = actor_of(bt)
        runs = run_episodes(env, actor, episodes, seed)
        rows.append({"task": bt.task.name, "kind": bt.task.kind, "category": bt.task.category, "part": bt.part,
                     "grasp": bt.grasp, "reason": bt.reason, "end_effector": bt.end_effector, "asset": bt.asset,
                     "success_rate": runs.success_rate, "max_fraction": runs.mean_max_fraction})
    return rows


def holdable(row: dict) -> bool:
    """Whether a task (a row with ``grasp`` and ``reason``) offers its end-effector something to hold: a
    grasp on a handle, a notch, a lid's tab or the front's edges (not a bare ``face``), or the suction
    cup's flat patch (``suction``), that the planner gives no ``reason`` against. The rest neither
    end-effector can pull open; scores report them apart."""
    return bool(row.get("grasp")) and row["grasp"] != "face" and not row.get("reason")


def success_rate(rows: list[dict], kind: str | None = None) -> float | None:
    """Mean success of ``rows`` (of one ``kind`` if given); None for none."""
    picked = [r["success_rate"] for r in rows if kind is None or r["kind"] == kind]
    return float(np.mean(picked)) if picked else None


def rate_by(rows: list[dict], key: str) -> dict:
    """Success rate and count of ``rows`` grouped by ``key``.

    :param rows: :func:`evaluate` / :func:`evaluate_teacher` rows
    :param key: the row field to group by (``grasp``, ``category``, ``part``, ``end_effector``)
    """
    groups: dict = {}
    for r in rows:
        groups.setdefault(r[key], []).append(r["success_rate"])
    return {k: {"success_rate": round(float(np.mean(v)), 4), "tasks": len(v)} for k, v in sorted(groups.items())}
