"""Learned opening policies on the environments of :mod:`spark_bench.envs`: rollouts, stable-baselines3
training, the generalist policies and the RL transfer score (:func:`spark_bench.rl.transfer.rl_transfer_score`).
The scripted opener and the opening score's judge are :mod:`spark_bench.opening`.

- :func:`run_episodes`: score a policy over some episodes (:class:`RolloutStats`);
  :func:`spark_bench.rl.rollout.rollout` makes the environment too
- :func:`spark_bench.rl.train.train` ``(env_id, algo="ppo", steps=..., out=...) -> TrainResult``: PPO or
  SAC (stable-baselines3)
- :class:`ScriptedPolicy`, :class:`ModelPolicy`, :func:`load_policy`, :func:`load_model`

Names are imported lazily (PEP 562), so that ``spark-bench --help`` does not import MuJoCo or torch.
``rollout`` and ``train`` are not exported here: they are also the names of their modules, which
shadow a package attribute once imported.
Imports run one way: ``train`` -> ``rollout`` -> ``policies`` -> :mod:`spark_bench.opening` ->
:mod:`spark_bench.envs`; ``transfer`` -> ``tasks`` -> :mod:`spark_bench.opening.judge`.
"""

from __future__ import annotations

from spark_bench.lazy import lazy_exports

#: Default fine-tuning budget of the RL transfer score (``eval --rl``): environment steps per policy kind,
#: measured by ``benchmarks/measure_eval.py --rl``. Here, not in :mod:`spark_bench.rl.transfer`, so that
#: the evaluation's options read it without importing torch.
FINETUNE_STEPS = 1024

_EXPORTS = {
    "ModelPolicy": "spark_bench.rl.policies",
    "ScriptedPolicy": "spark_bench.rl.policies",
    "load_model": "spark_bench.rl.policies",
    "load_policy": "spark_bench.rl.policies",
    "RolloutStats": "spark_bench.rl.rollout",
    "run_episodes": "spark_bench.rl.rollout",
    "TrainResult": "spark_bench.rl.train",
}

__all__, __getattr__ = lazy_exports(__name__, _EXPORTS)
