"""The stages that train one generalist opening policy (:mod:`spark_bench.rl.generalist_recipe` runs them for
every kind and ships the result).

One policy kind (``drawer`` or ``door``) at a time, in three stages, each scored on validation tasks
(synth seeds of their own, never the test seeds) so that the learning curve covers the whole run:

1. **demonstrations + behaviour cloning**: the scripted opener with the ground-truth joint on the training
   tasks it solves, with noise on the executed motion
   (:func:`~spark_bench.rl.imitation.collect_demos`); the PPO policy's mean action is fitted to them
   (:func:`~spark_bench.rl.imitation.clone`);
2. **DAgger**: rounds in which the policy acts on a share of the steps and the teacher labels every state;
3. **PPO** (stable-baselines3) on every training task of the kind (the teacher's failures included): the
   value network first learns alone (the policy frozen) for ``warmup_steps``, then both.

Every stage sees the grasp frame turned at random each episode (``frame_noise``, see
:mod:`spark_bench.rl.generalist`). The model with the best validation success is kept (ties go to the
later one).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from spark_bench.rl.generalist import FRAME_NOISE, GraspFrameWrapper
from spark_bench.rl.imitation import clone, collect_demos
from spark_bench.rl.policies import fused_adam
from spark_bench.rl.tasks import BuiltTask, evaluate, success_rate

#: The policy network (separate actor and critic MLPs) and the initial action noise (std 0.3).
POLICY_KWARGS = {"net_arch": {"pi": [128, 128], "vf": [128, 128]}, "log_std_init": -1.2}
#: PPO settings of stage 3 (per environment copy: ``n_steps``).
PPO_SETTINGS = {"n_steps": 256, "batch_size": 256, "n_epochs": 5, "learning_rate": 3e-5, "gamma": 0.98,
                "gae_lambda": 0.95, "clip_range": 0.1, "ent_coef": 0.0, "target_kl": 0.03}


@dataclass
class CurveRow:
    """One point of the learning curve: the stage, environment steps so far (demonstrations, DAgger and
    PPO together), wall time, and the validation success rate."""

    stage: str
    env_steps: int
    wall_s: float
    val_success: float


@dataclass
class StageSettings:
    """What :func:`train_kind` does.

    :param demo_episodes: teacher episodes per solvable training task
    :param demo_noise: noise on the executed motion during demonstrations
    :param bc_epochs: behaviour-cloning epochs after the demonstrations
    :param dagger_rounds: DAgger rounds (``beta`` halves each round from 0.5)
    :param dagger_episodes: episodes per task per DAgger round
    :param dagger_epochs: behaviour-cloning epochs after each round
    :param ppo_steps: PPO environment steps (0: no PPO)
    :param ppo_max_wall_s: stop PPO after this much wall time
    :param warmup_steps: PPO steps with the policy frozen (the value network learns alone)
    :param eval_every: PPO steps between validation evaluations
    :param n_envs: PPO environment copies (the tasks are split among them)
    :param frame_noise: random turn (rad) of the observed grasp frame per training episode
        (:func:`~spark_bench.rl.generalist.perturb_frame`), demonstrations and PPO alike
    """

    demo_episodes: int = 3
    demo_noise: float = 0.3
    bc_epochs: int = 40
    dagger_rounds: int = 2
    dagger_episodes: int = 2
    dagger_epochs: int = 25
    ppo_steps: int = 100_000
    ppo_max_wall_s: float | None = None
    warmup_steps: int = 8_192
    eval_every: int = 16_384
    n_envs: int = 8
    frame_noise: float = FRAME_NOISE


@dataclass
class KindResult:
    """What :func:`train_kind` produced: the model (best on validation), its curve, step counts."""

    model: object
    curve: list[CurveRow] = field(default_factory=list)
    steps: dict = field(default_factory=dict)
    wall_s: float = 0.0
    best: CurveRow | None = None
    demos: dict = field(default_factory=dict)

    def curve_dicts(self) -> list[dict]:
        """The learning curve as plain dicts (the record's ``curve``)."""
        return [asdict(r) for r in self.curve]


def task_vec_env(built: list[BuiltTask], n_envs: int, seed: int, frame_noise: float = 0.0):
    """``n_envs`` environment copies for stable-baselines3, the tasks split round-robin among them (each
    copy a :class:`~spark_bench.rl.generalist.TaskMixture` of its share), seeded.

    :param frame_noise: see :class:`~spark_bench.rl.generalist.GraspFrameWrapper`
    """
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from spark_bench.rl.generalist import TaskMixture

    n = max(1, min(n_envs, len(built)))
    shares = [[GraspFrameWrapper(b.raw, frame_noise) for b in built[k::n]] for k in range(n)]
    vec = DummyVecEnv([lambda share=share: Monitor(TaskMixture(share), info_keywords=("is_success",))
                       for share in shares])
    vec.seed(seed)
    return vec


def new_model(vec, seed: int = 0):
    """A fresh PPO model on ``vec`` with :data:`POLICY_KWARGS` and :data:`PPO_SETTINGS`."""
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", vec, policy_kwargs=copy.deepcopy(POLICY_KWARGS), seed=seed, device="cpu",
                verbose=0, **PPO_SETTINGS)
    fused_adam(model)
    return model


def _actor_parameters(model):
    """The parameters of ``model``'s policy network and action head (frozen while the value network warms up)."""
    return [p for name, p in model.policy.named_parameters()
            if name.startswith(("mlp_extractor.policy_net", "action_net", "log_std"))]


def train_kind(train: list[BuiltTask], teacher_solved: set[str], val: list[BuiltTask], settings: StageSettings,
               seed: int = 0, on_row: Callable[[CurveRow], None] | None = None) -> KindResult:
    """Train one policy kind on ``train`` (see the module docstring).

    :param train: the training tasks (one kind)
    :param teacher_solved: names of the training tasks the teacher opens (demonstrations come from these)
    :param val: the validation tasks (one kind)
    :param on_row: called with each new point of the learning curve
    """
    t0 = time.perf_counter()
    result = KindResult(model=None)
    steps = {"demos": 0, "dagger": 0, "ppo": 0}
    best_state: dict = {}

    def point(stage: str) -> None:
        rate = success_rate(evaluate(result.model, val, seed=10_000)) or 0.0
        row = CurveRow(stage, sum(steps.values()), round(time.perf_counter() - t0, 1), round(rate, 4))
        result.curve.append(row)
        if result.best is None or row.val_success >= result.best.val_success:
            result.best = row
            best_state["policy"] = copy.deepcopy(result.model.policy.state_dict())
        if on_row is not None:
            on_row(row)

    vec = task_vec_env(train, settings.n_envs, seed, settings.frame_noise)
    result.model = new_model(vec, seed)
    point("initial (random weights)")
    solvable = [b for b in train if b.task.name in teacher_solved]
    demos = collect_demos(solvable, episodes=settings.demo_episodes, noise=settings.demo_noise, seed=seed,
                          frame_noise=settings.frame_noise)
    steps["demos"] = demos.steps
    clone(result.model, demos, epochs=settings.bc_epochs, seed=seed)
    point("behaviour cloning")
    beta = 0.5
    for k in range(settings.dagger_rounds):
        more = collect_demos(solvable, episodes=settings.dagger_episodes, noise=settings.demo_noise / 2,
                             seed=seed + 1000 * (k + 1), learner=result.model, beta=beta,
                             frame_noise=settings.frame_noise)
        steps["dagger"] += more.steps
        demos = demos.extend(more)
        clone(result.model, demos, epochs=settings.dagger_epochs, seed=seed + k + 1)
        point(f"DAgger round {k + 1} (beta {beta:g})")
        beta /= 2
    result.demos = {"samples": len(demos), "episodes": demos.episodes, "kept": demos.kept,
                    "tasks": len(solvable)}
    if settings.ppo_steps > 0:
        _ppo(result, settings, steps, point, t0)
    result.model.policy.load_state_dict(best_state["policy"])
    result.steps = {**steps, "total": sum(steps.values())}
    result.wall_s = round(time.perf_counter() - t0, 1)
    return result


def _ppo(result: KindResult, settings: StageSettings, steps: dict, point: Callable, t0: float) -> None:
    """Stage 3: PPO on ``result.model`` in place, the value network first alone, within the wall-time limit.

    :param steps: the step counts so far (``ppo`` updated as it goes)
    :param point: adds a point to the learning curve (validation success) given the stage's name
    """
    from stable_baselines3.common.callbacks import BaseCallback

    model = result.model
    deadline = None if settings.ppo_max_wall_s is None else time.perf_counter() + settings.ppo_max_wall_s

    class Every(BaseCallback):
        """A point of the curve every ``eval_every`` PPO steps; stops learning at the deadline."""

        def __init__(self, start: int):
            super().__init__()
            self.start, self.next = start, start + settings.eval_every

        def _on_step(self) -> bool:
            steps["ppo"] = int(self.num_timesteps)
            if self.num_timesteps >= self.next:
                self.next += settings.eval_every
                point("PPO")
            return deadline is None or time.perf_counter() < deadline

    warmup = min(settings.warmup_steps, settings.ppo_steps)
    actor = _actor_parameters(model)
    if warmup > 0:
        for p in actor:
            p.requires_grad_(False)
        model.learn(total_timesteps=warmup, callback=Every(10**12), reset_num_timesteps=True)
        for p in actor:
            p.requires_grad_(True)
    rest = settings.ppo_steps - int(model.num_timesteps)
    if rest > 0 and (deadline is None or time.perf_counter() < deadline):
        model.learn(total_timesteps=rest, callback=Every(int(model.num_timesteps)), reset_num_timesteps=False)
    steps["ppo"] = int(model.num_timesteps)
    if not result.curve or result.curve[-1].env_steps != sum(steps.values()):
        point("PPO (end)")
