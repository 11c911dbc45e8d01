"""Train an opening policy with stable-baselines3 (PPO or SAC), evaluating its success rate as it learns.

Output folder: ``model.zip`` (the final model), ``train.json`` (settings, final and transfer scores,
wall time; assets named by path and content hash, :func:`spark_bench.rl.records.asset_record`),
``curve.csv`` (one row per evaluation) and ``curve.png`` (success rate and return against environment
steps).
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from spark_bench.envs.registration import make_env
from spark_bench.errors import InputError
from spark_bench.rl.policies import ModelPolicy, algo_class, fused_adam
from spark_bench.rl.records import asset_record
from spark_bench.rl.rollout import run_episodes

#: Hyper-parameters per algorithm (stable-baselines3 keyword arguments), tuned on the default drawer.
HYPERPARAMS = {
    "ppo": dict(n_steps=256, batch_size=512, n_epochs=10, learning_rate=3e-4, gamma=0.98, gae_lambda=0.95,
                clip_range=0.2, ent_coef=0.0, policy_kwargs=dict(net_arch=[128, 128])),
    "sac": dict(buffer_size=300_000, learning_starts=2_000, batch_size=256, learning_rate=3e-4, gamma=0.98,
                tau=0.01, train_freq=1, gradient_steps=1, policy_kwargs=dict(net_arch=[256, 256])),
}


@dataclass
class EvalRow:
    """One periodic evaluation: environment steps so far, wall time, success rate, mean return."""

    steps: int
    wall_s: float
    success_rate: float
    mean_return: float
    mean_max_fraction: float


@dataclass
class TrainResult:
    """What :func:`train` did.

    :param out: the output folder
    :param curve: the evaluations, in order
    :param final: the last evaluation on the training asset
    :param transfer: the evaluation on ``eval_asset``, if one was given
    :param wall_s: training wall time, s (evaluations included)
    """

    out: Path
    curve: list[EvalRow] = field(default_factory=list)
    final: dict | None = None
    transfer: dict | None = None
    wall_s: float = 0.0


def plot_curve(rows: list[EvalRow], path: Path, title: str) -> Path:
    """The learning curve: success rate and mean return against environment steps, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r.steps for r in rows]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6, 5.5), sharex=True)
    top.plot(steps, [r.success_rate for r in rows], marker="o")
    top.set_ylabel("success rate")
    top.set_ylim(-0.03, 1.03)
    top.grid(alpha=0.3)
    top.set_title(title)
    bottom.plot(steps, [r.mean_return for r in rows], marker="o", color="tab:orange")
    bottom.set_ylabel("mean episode return")
    bottom.set_xlabel("environment steps")
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _eval_callback(eval_env, every: int, episodes: int, out: Path, title: str, t0: float,
                   max_wall_s: float | None = None):
    from stable_baselines3.common.callbacks import BaseCallback

    class SuccessRateCallback(BaseCallback):
        """Every ``every`` environment steps: evaluate, append to ``curve.csv``, redraw ``curve.png``."""

        def __init__(self):
            super().__init__()
            self.rows: list[EvalRow] = []
            self.next_eval = every

        def evaluate(self) -> None:
            stats = run_episodes(eval_env, ModelPolicy(self.model), episodes, seed=10_000)
            row = EvalRow(steps=int(self.num_timesteps), wall_s=round(time.perf_counter() - t0, 2),
                          success_rate=stats.success_rate, mean_return=stats.mean_return,
                          mean_max_fraction=stats.mean_max_fraction)
            self.rows.append(row)
            with open(out / "curve.csv", "w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(asdict(row)))
                writer.writeheader()
                writer.writerows(asdict(r) for r in self.rows)
            plot_curve(self.rows, out / "curve.png", title)
            self.logger.record("eval/success_rate", row.success_rate)
            self.logger.record("eval/mean_return", row.mean_return)

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_eval:
                self.next_eval += every
                self.evaluate()
            return max_wall_s is None or time.perf_counter() - t0 < max_wall_s

    return SuccessRateCallback()


def train(env_id: str, algo: str = "ppo", steps: int = 100_000, out: str | Path = "runs/train",
          asset=None, joint: str | None = None, n_envs: int = 8, seed: int = 0, eval_every: int | None = None,
          eval_episodes: int = 20, eval_asset=None, progress_bar: bool = True,
          hyperparams: dict | None = None, max_wall_s: float | None = None, verbose: int = 0) -> TrainResult:
    """Train ``algo`` on ``env_id``; evaluate periodically; save the model and the learning curve.

    :param env_id: ``SparkDrawer-v0`` or ``SparkDoor-v0``
    :param algo: ``ppo`` or ``sac``
    :param steps: environment steps to train for
    :param out: output folder
    :param asset: the training object (see :mod:`spark_bench.envs.assets`)
    :param joint: the joint to open
    :param n_envs: parallel environment copies (in one process)
    :param seed: seed of the environments and the algorithm
    :param eval_every: evaluate every this many environment steps (default: ``steps / 10``)
    :param eval_episodes: episodes per evaluation
    :param eval_asset: after training, also evaluate on this object (transfer)
    :param progress_bar: show stable-baselines3's progress bar
    :param hyperparams: overrides of :data:`HYPERPARAMS`
    :param max_wall_s: stop early after this much wall time (evaluations included)
    """
    from stable_baselines3.common.env_util import make_vec_env

    algo = algo.lower()
    cls = algo_class(algo)
    if steps <= 0 or n_envs <= 0:
        raise InputError(None, "steps and n_envs must be positive")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    make_env(env_id, asset=asset, joint=joint).close()  # fail early on a bad asset or joint
    vec = make_vec_env(lambda: make_env(env_id, asset=asset, joint=joint), n_envs=n_envs, seed=seed,
                       monitor_kwargs={"info_keywords": ("is_success",)})
    eval_env = make_env(env_id, asset=asset, joint=joint)
    params = {**HYPERPARAMS[algo], **(hyperparams or {})}
    model = cls("MlpPolicy", vec, seed=seed, verbose=verbose, device="cpu", **params)
    fused_adam(model)
    t0 = time.perf_counter()
    title = f"{algo.upper()} on {env_id}"
    every = int(eval_every or max(steps // 10, 1))
    callback = _eval_callback(eval_env, every, eval_episodes, out, title, t0, max_wall_s)
    model.learn(total_timesteps=int(steps), callback=callback, progress_bar=progress_bar)
    if not callback.rows or callback.rows[-1].steps < model.num_timesteps:
        callback.evaluate()
    wall = time.perf_counter() - t0
    model.save(out / "model.zip")
    result = TrainResult(out=out, curve=callback.rows, final=asdict(callback.rows[-1]), wall_s=round(wall, 2))
    if eval_asset is not None:
        transfer_env = make_env(env_id, asset=eval_asset, joint=joint)
        stats = run_episodes(transfer_env, ModelPolicy(model), eval_episodes, seed=20_000)
        transfer_env.close()
        result.transfer = {"asset": asset_record(eval_asset), **stats.to_dict()}
    meta = {"env_id": env_id, "algo": algo, "steps": int(model.num_timesteps), "n_envs": n_envs, "seed": seed,
            "asset": asset_record(asset), "joint": joint, "hyperparams": _jsonable(params),
            "wall_s": result.wall_s, "final": result.final, "transfer": result.transfer}
    (out / "train.json").write_text(json.dumps(meta, indent=2))
    vec.close()
    eval_env.close()
    return result


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value if isinstance(value, (int, float, str, bool, type(None))) else repr(value)
