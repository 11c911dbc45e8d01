"""Registers the environments with Gymnasium and makes them (:func:`make_env`).

The way Gymnasium's third-party packages do it: the package's ``__init__`` calls :func:`register_envs`,
which registers each id of :data:`ENVIRONMENTS` with ``gymnasium.register(id, entry_point="module:Class")``
(a string, so nothing heavy is imported until an environment is made). So either of::

    import spark_bench                         # registers; gymnasium.register_envs(spark_bench) says so
    env = gymnasium.make("SparkDrawer-v0", asset=..., joint=...)

    env = gymnasium.make("spark_bench:SparkDoor-v0", asset=..., joint=...)  # imports spark_bench first

makes one; :func:`make_env` does the same with a clear error for an unknown id.
"""

from __future__ import annotations

import gymnasium

from spark_bench.errors import InputError

#: Environment id -> entry point.
ENVIRONMENTS = {
    "SparkDrawer-v0": "spark_bench.envs.drawer:SparkDrawerEnv",
    "SparkDoor-v0": "spark_bench.envs.door:SparkDoorEnv",
}
MAX_EPISODE_STEPS = 100
#: The environment that opens a joint of each type: a drawer (prismatic) is pulled, a door (revolute) and
#: a part turning without limit (continuous: a knob, a cap) are swung. The one table of it. Which
#: ground-truth joints the opening scores open is theirs to say (:data:`spark_bench.opening.pairing.OPENING_TYPES`:
#: drawers and doors).
ENV_OF_JOINT_TYPE = {"prismatic": "SparkDrawer-v0", "revolute": "SparkDoor-v0", "continuous": "SparkDoor-v0"}


def register_envs() -> None:
    """Register every environment of :data:`ENVIRONMENTS` (idempotent)."""
    for env_id, entry_point in ENVIRONMENTS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(id=env_id, entry_point=entry_point, max_episode_steps=MAX_EPISODE_STEPS)


def make_env(env_id: str, asset=None, joint: str | None = None, render_mode: str | None = None,
             max_episode_steps: int | None = None, **kwargs) -> gymnasium.Env:
    """``gymnasium.make`` for a spark-bench environment, with a clear error for an unknown id.

    :param env_id: ``SparkDrawer-v0`` or ``SparkDoor-v0``
    :param asset: see :mod:`spark_bench.envs.assets`
    :param joint: the joint to open
    :param render_mode: None or ``rgb_array``
    :param max_episode_steps: time limit (default: the registered one)
    """
    if env_id not in ENVIRONMENTS:
        raise InputError(None, f"unknown environment {env_id!r} (choose from {', '.join(ENVIRONMENTS)})")
    register_envs()
    options = {k: v for k, v in {"asset": asset, "joint": joint}.items() if v is not None}
    if max_episode_steps is not None:
        options["max_episode_steps"] = int(max_episode_steps)
    return gymnasium.make(env_id, render_mode=render_mode, **options, **kwargs)
