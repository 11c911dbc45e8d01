"""Registers the environments with Gymnasium, by entry-point string (nothing heavy is imported here)."""

from __future__ import annotations

import gymnasium

#: Environment id -> entry point.
ENVIRONMENTS = {
    "SparkDrawer-v0": "spark_bench.envs.drawer:SparkDrawerEnv",
    "SparkDoor-v0": "spark_bench.envs.door:SparkDoorEnv",
}
MAX_EPISODE_STEPS = 100


def register_envs() -> None:
    """Register every environment of :data:`ENVIRONMENTS` (idempotent)."""
    for env_id, entry_point in ENVIRONMENTS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(id=env_id, entry_point=entry_point, max_episode_steps=MAX_EPISODE_STEPS)
