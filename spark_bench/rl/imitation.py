"""Imitation of the scripted opener, the generalist's starting point before PPO (the first two stages of
:mod:`spark_bench.rl.generalist_stages`).

- :func:`collect_demos`: episodes of the scripted opener with the ground-truth joint (the teacher,
  :class:`~spark_bench.rl.policies.ScriptedPolicy`), recorded in the generalist's terms (features,
  joint-frame actions). The executed motion carries Gaussian noise so that the states cover the
  teacher's recoveries (DART, Laskey et al. 2017), or is the learner's own action on a share of the steps
  (DAgger, Ross et al. 2011); the label is always the teacher's clean action. Only the episodes that open
  the joint are kept.
- :func:`clone`: behaviour cloning: the stable-baselines3 policy's mean action regressed on the labels
  (the value network and the action noise are left to PPO).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.rl.generalist import (
    EPISODE_STEPS,
    N_FEATURES,
    Memory,
    end_effector_flag,
    features,
    perturb_frame,
    random_rotation,
    to_frame,
    to_world,
)
from spark_bench.rl.tasks import BuiltTask

#: Standard deviation of the noise on the executed TCP motion (action units: 1 = 0.02 m).
DEMO_NOISE = 0.3


@dataclass
class Demos:
    """Labelled states: ``obs`` (N, :data:`N_FEATURES`) features, ``actions`` (N, 4) joint-frame labels.

    :param episodes: episodes run
    :param kept: episodes kept (the joint was opened)
    :param steps: environment steps taken, kept or not
    """

    obs: np.ndarray = field(default_factory=lambda: np.zeros((0, N_FEATURES), np.float32))
    actions: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.float32))
    episodes: int = 0
    kept: int = 0
    steps: int = 0

    def extend(self, other: Demos) -> Demos:
        """Both sets of demonstrations in one."""
        return Demos(np.concatenate([self.obs, other.obs]), np.concatenate([self.actions, other.actions]),
                     self.episodes + other.episodes, self.kept + other.kept, self.steps + other.steps)

    def __len__(self) -> int:
        return len(self.obs)


def collect_demos(built: list[BuiltTask], episodes: int = 2, noise: float = DEMO_NOISE, seed: int = 0,
                  learner=None, beta: float = 1.0, frame_noise: float = 0.0, progress: bool = False) -> Demos:
    """Teacher-labelled episodes on every task.

    :param built: the tasks
    :param episodes: episodes per task (reset seeds ``seed + k``)
    :param noise: standard deviation of the Gaussian noise on the executed TCP motion
    :param learner: a model on :func:`~spark_bench.rl.generalist.features` (DAgger); None: the teacher acts
    :param beta: with a learner, the probability that a step executes the teacher's action
    :param frame_noise: turn the observed grasp frame by a random rotation of up to this angle (rad) each
        episode (:func:`~spark_bench.rl.generalist.perturb_frame`; the teacher sees the true one)
    """
    from tqdm import tqdm

    from spark_bench.rl.policies import ScriptedPolicy

    rng = np.random.default_rng(seed)
    obs_rows, act_rows, run, kept, steps = [], [], 0, 0, 0
    for bt in tqdm(built, desc="demonstrations", unit="task", disable=not progress):
        env = bt.raw
        suction = end_effector_flag(env)  # feature 39: the gripper's or the cup's episode
        for k in range(episodes):
            teacher, memory = ScriptedPolicy(), Memory()
            rotation = random_rotation(rng, frame_noise) if frame_noise > 0 else None
            obs, _ = env.reset(seed=seed + k)
            teacher.reset(env)
            seen = perturb_frame(obs, rotation)
            memory.reset(seen)
            xs, ys, success = [], [], False
            for _ in range(env.spec.max_episode_steps if env.spec and env.spec.max_episode_steps else EPISODE_STEPS):
                label = teacher(obs)
                x = features(seen, memory.vector(), suction)
                xs.append(x)
                ys.append(to_frame(seen, label))
                act = np.array(label, dtype=np.float64)
                if learner is not None and rng.random() >= beta:
                    act = to_world(seen, learner.predict(x, deterministic=True)[0]).astype(np.float64)
                act[:3] += noise * rng.standard_normal(3)
                act = np.clip(act, -1.0, 1.0)
                executed = to_frame(seen, act)
                obs, _, terminated, truncated, info = env.step(act.astype(np.float32))
                seen = perturb_frame(obs, rotation)
                memory.step(executed, seen)
                steps += 1
                success = success or bool(info["is_success"])
                if success or terminated or truncated:
                    break
            run += 1
            if success:
                kept += 1
                obs_rows.extend(xs)
                act_rows.extend(ys)
    if not obs_rows:
        return Demos(episodes=run, steps=steps)
    return Demos(np.asarray(obs_rows, np.float32), np.asarray(act_rows, np.float32), run, kept, steps)


def clone(model, demos: Demos, epochs: int = 30, batch_size: int = 256, learning_rate: float = 1e-3,
          seed: int = 0) -> list[float]:
    """Behaviour cloning: fit the mean action of ``model``'s policy (a stable-baselines3 PPO) to the
    demonstrations' labels with a mean squared error, in place.

    :returns: the mean loss of each epoch
    """
    import torch

    policy = model.policy
    params = [p for name, p in policy.named_parameters()
              if name.startswith(("mlp_extractor.policy_net", "action_net", "pi_features_extractor",
                                  "features_extractor"))]
    optimizer = torch.optim.Adam(params, lr=learning_rate, fused=True)  # fused: the same bits on every CPU
    obs = torch.as_tensor(demos.obs)
    target = torch.as_tensor(demos.actions)
    generator = torch.Generator().manual_seed(seed)
    losses = []
    policy.train()
    for _ in range(epochs):
        order = torch.randperm(len(obs), generator=generator)
        total, batches = 0.0, 0
        for start in range(0, len(obs), batch_size):
            idx = order[start:start + batch_size]
            mean = policy.get_distribution(obs[idx]).distribution.mean
            loss = torch.mean((mean - target[idx]) ** 2)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += float(loss.detach())
            batches += 1
        losses.append(total / max(batches, 1))
    policy.set_training_mode(False)
    return losses
