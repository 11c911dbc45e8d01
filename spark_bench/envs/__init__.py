"""Gymnasium environments for opening articulated objects: ``SparkDrawer-v0`` and ``SparkDoor-v0``.

Importing this package (or ``spark_bench``) registers them; MuJoCo is imported only when one is made.
"""

from spark_bench.envs.registration import ENVIRONMENTS, register_envs

register_envs()

__all__ = ["ENVIRONMENTS", "register_envs"]
