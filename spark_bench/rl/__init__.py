"""Opening policies on the environments of :mod:`spark_bench.envs`: the scripted opener, rollouts and
training.

- :func:`open_with_joint` ``(env, axis, pivot, joint_type, seed=None, ...) -> OpenResult``: one scripted
  episode planned from given joint parameters; :func:`open_with_ground_truth` with the environment's own
- :func:`open_with_predicted_joints`: the scripted opening score of a prediction, and
  :func:`open_every_joint`, the opener on every joint of one object (:mod:`spark_bench.rl.scoring`: what
  the scores that open each ground-truth joint share; the RL transfer score is
  :func:`spark_bench.rl.transfer.rl_transfer_score`)
- :func:`run_episodes`: score a policy over some episodes (:class:`RolloutStats`);
  :func:`spark_bench.rl.rollout.rollout` makes the environment too
- :func:`spark_bench.rl.train.train` ``(env_id, algo="ppo", steps=..., out=...) -> TrainResult``: PPO or
  SAC (stable-baselines3)
- :class:`ScriptedPolicy`, :class:`ModelPolicy`, :func:`load_policy`, :func:`load_model`

Names are imported lazily (PEP 562), so that ``spark-bench --help`` does not import MuJoCo or torch.
``rollout`` and ``train`` are not exported here: they are also the names of their modules, which
shadow a package attribute once imported.
Imports run one way: ``train`` -> ``rollout`` -> ``policies`` -> ``scripted`` -> :mod:`spark_bench.envs`;
``transfer`` -> ``tasks`` -> ``scoring`` -> ``scripted``.
"""

from __future__ import annotations

from spark_bench.lazy import lazy_exports

#: Default fine-tuning budget of the RL transfer score (``eval --rl``): environment steps per policy kind,
#: measured by ``benchmarks/measure_eval.py --rl``. Here, not in :mod:`spark_bench.rl.transfer`, so that
#: the evaluation's options read it without importing torch.
FINETUNE_STEPS = 1024

_EXPORTS = {
    "OpenResult": "spark_bench.rl.scripted",
    "ScriptedOpener": "spark_bench.rl.scripted",
    "ground_truth_joint": "spark_bench.rl.scripted",
    "open_every_joint": "spark_bench.rl.scoring",
    "open_with_predicted_joints": "spark_bench.rl.scoring",
    "open_with_ground_truth": "spark_bench.rl.scripted",
    "open_with_joint": "spark_bench.rl.scripted",
    "ModelPolicy": "spark_bench.rl.policies",
    "ScriptedPolicy": "spark_bench.rl.policies",
    "load_model": "spark_bench.rl.policies",
    "load_policy": "spark_bench.rl.policies",
    "RolloutStats": "spark_bench.rl.rollout",
    "run_episodes": "spark_bench.rl.rollout",
    "TrainResult": "spark_bench.rl.train",
}

__all__, __getattr__ = lazy_exports(__name__, _EXPORTS)
