"""``spark-bench rollout``, ``spark-bench train`` and ``spark-bench train-generalist``: score and train opening
policies, and make the shipped generalist ones (:mod:`spark_bench.rl.generalist_recipe`)."""

from __future__ import annotations

import argparse
from pathlib import Path

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


#: The options of ``train-generalist`` that make up the recipe (always named in the record's command line).
RECIPE_OPTIONS = ("kinds", "train_seeds", "val_seeds", "test_seeds", "seed", "cup_every", "demo_episodes",
                  "dagger_rounds", "ppo_steps", "ppo_minutes")


def recipe_command(args: argparse.Namespace, defaults: argparse.Namespace) -> str:
    """The command line of a ``train-generalist`` run as its record names it: every recipe option, and the
    others where they differ from their default (paths relative to the working folder where inside it).

    :param args: the parsed options
    :param defaults: the options' defaults
    """
    from spark_bench.rl.generalist_recipe import shown_path

    words = ["spark-bench", "train-generalist"]
    for name, value in vars(args).items():
        if name in ("func", "command", "defaults") or (name not in RECIPE_OPTIONS and value == getattr(defaults, name)):
            continue
        if value is True:
            words.append(f"--{name.replace('_', '-')}")
        elif value is not False and value is not None:
            shown = [shown_path(v) if isinstance(v, Path) else f"{v:g}" if isinstance(v, float) else str(v)
                     for v in (value if isinstance(value, list) else [value])]
            words += [f"--{name.replace('_', '-')}", *shown]
    return " ".join(words)


def run_train_generalist(args: argparse.Namespace) -> int:
    from spark_bench.rl.generalist import WEIGHTS_DIR
    from spark_bench.rl.generalist_recipe import RecipeOptions, run_recipe, seed_range
    from spark_bench.rl.generalist_stages import StageSettings

    stages = StageSettings(demo_episodes=args.demo_episodes, dagger_rounds=args.dagger_rounds,
                           ppo_steps=args.ppo_steps, ppo_max_wall_s=60.0 * args.ppo_minutes)
    options = RecipeOptions(
        command=recipe_command(args, args.defaults), kinds=tuple(args.kinds),
        seeds={name: seed_range(getattr(args, f"{name}_seeds")) for name in ("train", "val", "test")},
        stages=stages, seed=args.seed, cup_every=args.cup_every,
        categories=tuple(args.categories) if args.categories else None,
        real=None if args.no_real else args.real, weights=args.weights or WEIGHTS_DIR, results=args.results,
        score_only=args.score_only)
    run_recipe(options)
    return 0


def _add_train_generalist(subparsers) -> None:
    """``train-generalist``: the options of the recipe that made the shipped weights (their defaults)."""
    p = subparsers.add_parser(
        "train-generalist", help="train the generalist opening policies (the shipped spark_bench/rl/weights)",
        description="Train the generalist opening policies (drawer, door): demonstrations of the scripted opener "
                    "+ behaviour cloning, DAgger, PPO on synth tasks; score them on held-out synth seeds and real "
                    "objects; write the weights with their record, and the report generalist_training.md with "
                    "generalist_curve.png.")
    p.add_argument("--kinds", nargs="+", default=["drawer", "door"], choices=["drawer", "door"])
    p.add_argument("--train-seeds", default="1000:1012", help="synth seeds of the training tasks (A:B or a,b,c)")
    p.add_argument("--val-seeds", default="8000:8003", help="synth seeds of the validation tasks (the curve)")
    p.add_argument("--test-seeds", default="9000:9005", help="synth seeds of the held-out test tasks")
    p.add_argument("--seed", type=int, default=0, help="training seed")
    p.add_argument("--cup-every", type=int, default=3,
                   help="also train on every N-th training task that 'auto' gives the gripper, with the suction "
                        "cup forced (cup experience on parts with a handle: synth drawers all have one); 0: none")
    p.add_argument("--demo-episodes", type=int, default=3, help="teacher episodes per solvable training task")
    p.add_argument("--dagger-rounds", type=int, default=2)
    p.add_argument("--ppo-steps", type=int, default=100_000)
    p.add_argument("--ppo-minutes", type=float, default=15.0, help="PPO wall-time limit per kind")
    p.add_argument("--categories", nargs="+", default=None,
                   help="only the synth tasks of these categories (default: every synth category)")
    p.add_argument("--real", type=Path, default=Path("../shared/partnet_dev"),
                   help="folder of real objects to score on (skipped when absent)")
    p.add_argument("--no-real", action="store_true", help="score on no real objects")
    p.add_argument("--score-only", action="store_true",
                   help="only score the weights in --weights again, on their held-out synth seeds and on --real "
                        "(unless --no-real), and update their record and report")
    p.add_argument("--weights", type=Path, default=None,
                   help="where the weights and generalist.json go (default: the package's spark_bench/rl/weights)")
    p.add_argument("--results", type=Path, default=Path("benchmarks/results"),
                   help="where generalist_training.md and generalist_curve.png go")
    p.set_defaults(func=run_train_generalist)
    p.set_defaults(defaults=p.parse_args([]))


def add_commands(subparsers) -> None:
    """Add ``rollout``, ``train`` and ``train-generalist`` to the ``spark-bench`` command."""
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

    _add_train_generalist(subparsers)
