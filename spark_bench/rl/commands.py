"""``spark-bench rollout`` and ``spark-bench train``: score and train opening policies."""

from __future__ import annotations

import argparse

from spark_bench.envs.registration import ENVIRONMENTS  # light: ids and entry-point strings

ENV_IDS = tuple(ENVIRONMENTS)


def _env_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--env", required=True, choices=ENV_IDS, help="environment id")
    parser.add_argument("--asset", default=None,
                        help="object folder, URDF, benchmark case, or procedural:SEED (default: the default cabinet)")
    parser.add_argument("--joint", default=None, help="joint to open (default: the first of the right type)")


def run_rollout(args: argparse.Namespace) -> int:
    from rich.console import Console

    from spark_bench.rl.rollout import rollout, stats_json

    stats = rollout(args.env, asset=args.asset, policy=args.policy, episodes=args.episodes, seed=args.seed,
                    joint=args.joint, video=args.video, max_episode_steps=args.max_episode_steps,
                    end_effector=args.end_effector)
    if args.json:
        print(stats_json(stats))
    elif stats.reason is not None:
        Console().print(f"[bold]{args.env}[/] {args.policy} ({stats.end_effector}): not attempted, {stats.reason}")
    else:
        Console().print(f"[bold]{args.env}[/] {args.policy} ({stats.end_effector}): success rate {stats.success_rate:.2f} over "
                        f"{stats.episodes} episodes, mean return {stats.mean_return:.2f}, "
                        f"mean largest opening {stats.mean_max_fraction:.2f} of the range")
    return 0


def run_train(args: argparse.Namespace) -> int:
    import json

    from spark_bench.rl.train import train

    result = train(args.env, algo=args.algo, steps=args.steps, out=args.out, asset=args.asset, joint=args.joint,
                   n_envs=args.n_envs, seed=args.seed, eval_every=args.eval_every,
                   eval_episodes=args.eval_episodes, eval_asset=args.eval_asset, progress_bar=not args.no_progress)
    summary = {"out": str(result.out), "wall_s": result.wall_s, "final": result.final}
    if result.transfer is not None:
        summary["transfer"] = {k: result.transfer[k] for k in ("asset", "success_rate", "episodes", "mean_return")}
    print(json.dumps(summary))
    return 0


def add_commands(subparsers) -> None:
    """Add ``rollout`` and ``train`` to the ``spark-bench`` command."""
    p = subparsers.add_parser("rollout", help="score a policy (scripted opener or a trained model) on an opening task")
    _env_args(p)
    p.add_argument("--policy", default="scripted", help="'scripted' or a trained model (.zip or training folder)")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--max-episode-steps", type=int, default=None)
    p.add_argument("--video", default=None, help="write the episodes to a .gif or .mp4")
    p.add_argument("--end-effector", choices=("gripper", "suction", "auto"), default="gripper",
                   help="the parallel gripper, a suction cup, or auto: the cup where the planner finds nothing to pinch")
    p.add_argument("--json", action="store_true", help='print {"success_rate", "episodes", "mean_return", "mean_max_fraction", '
                   '"end_effector"} as JSON (and "reason" when the scripted planner declines the part)')
    p.set_defaults(func=run_rollout)

    p = subparsers.add_parser("train", help="train PPO or SAC on an opening task (stable-baselines3)")
    _env_args(p)
    p.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    p.add_argument("--steps", type=int, required=True, help="environment steps")
    p.add_argument("--n-envs", type=int, default=8, help="environment copies")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", required=True, help="output folder (model.zip, train.json, curve.csv, curve.png)")
    p.add_argument("--eval-every", type=int, default=None, help="evaluate every N steps (default: steps/10)")
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--eval-asset", default=None, help="also evaluate the trained policy on this object (transfer)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_train)
