"""Policies: the scripted opener with given (or ground-truth) joint parameters, and a saved
stable-baselines3 model.

A policy here is anything with ``reset(env)`` (called at each episode start) and ``__call__(obs) ->
action``. :func:`load_model` reads a model saved by :func:`spark_bench.rl.train.train`.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

from spark_bench.errors import InputError
from spark_bench.opening.episodes import ground_truth_joint, opener_for

#: The stable-baselines3 algorithms a model may be trained with.
ALGOS = ("ppo", "sac")


def algo_class(algo: str, where: str | Path | None = None):
    """The stable-baselines3 class of ``algo`` (``ppo`` or ``sac``).

    :param where: the file to name in the error for an unknown algorithm
    """
    if algo not in ALGOS:  # before the (slow) stable-baselines3 import
        raise InputError(where, f"unknown algorithm {algo!r} (choose from {', '.join(ALGOS)})")
    from stable_baselines3 import PPO, SAC

    return {"ppo": PPO, "sac": SAC}[algo]


def fused_adam(model) -> None:
    """Make every Adam optimizer of a stable-baselines3 model take torch's fused step.

    The unfused step divides by ``torch.sqrt`` of the second moment, MKL's vector square root, whose last
    bit differs between CPUs; the fused CPU step gave the same bits on this machine and on emulated Intel
    and AMD CPUs (``benchmarks/measure_kernels.py``), so a fine-tuned policy's weights, and the verdicts of
    its episodes, do not depend on the machine. Call it after ``load`` too: loading an optimizer's state
    restores the saved ``fused`` flag.

    :param model: a stable-baselines3 model (its ``_get_torch_save_params`` names its optimizers)
    """
    import torch

    names = model._get_torch_save_params()[0]
    for name in names:
        target = model
        for attribute in name.split("."):
            target = getattr(target, attribute)
        if isinstance(target, torch.optim.Adam):
            for group in target.param_groups:
                group.update(fused=True, foreach=None)


def load_model(path: str | Path):
    """A model saved by :func:`spark_bench.rl.train.train`: a ``model.zip`` (its ``train.json`` beside it
    names the algorithm) or the output folder."""
    path = Path(path)
    if path.is_dir():
        path = path / "model.zip"
    if not path.is_file():
        raise InputError(path, "no such model file")
    from spark_bench.data.readers import read_json

    meta_path = path.parent / "train.json"
    meta = read_json(meta_path, default={})
    if not isinstance(meta, dict):
        raise InputError(meta_path, "expected a JSON object")
    algos = [meta["algo"]] if "algo" in meta else list(ALGOS)
    for algo in algos:
        try:
            return algo_class(algo, meta_path).load(path, device="cpu")
        except (ValueError, KeyError, RuntimeError):
            continue
    raise InputError(path, "not a stable-baselines3 PPO or SAC model")


class ScriptedPolicy:
    """The scripted opener with the environment's own (ground-truth) joint, or with given parameters.

    :param joint: ``(axis, pivot, type)`` to plan from (world frame), or None for the ground truth
    """

    def __init__(self, joint: tuple | None = None):
        self.joint = joint
        self._opener = None

    def reset(self, env: gym.Env) -> None:
        axis, pivot, joint_type = self.joint if self.joint is not None else ground_truth_joint(env)
        self._opener = opener_for(env, axis, pivot, joint_type)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self._opener(obs)


class ModelPolicy:
    """A stable-baselines3 model, or one saved by :func:`spark_bench.rl.train.train`: the one wrapper of
    anything with SB3's ``predict(obs, deterministic) -> (action, state)`` (the generalist's task scores use
    it too, :func:`spark_bench.rl.tasks.evaluate`).

    :param model: the model (anything with ``predict``), its ``.zip`` file, or a training output folder
        holding ``model.zip``
    :param deterministic: act with the policy's mean action
    """

    def __init__(self, model, deterministic: bool = True):
        if isinstance(model, (str, Path)):
            model = load_model(model)
        self.model = model
        self.deterministic = deterministic

    def reset(self, env: gym.Env) -> None:
        pass

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        action, _ = self.model.predict(obs, deterministic=self.deterministic)
        return action


def load_policy(policy: str):
    """``scripted`` or the path of a saved model."""
    if policy == "scripted":
        return ScriptedPolicy()
    return ModelPolicy(policy)
