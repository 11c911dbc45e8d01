"""Gymnasium environments for opening articulated objects: ``SparkDrawer-v0`` and ``SparkDoor-v0``.

Importing this package (or ``spark_bench``) registers them; MuJoCo is imported only when one is made.
:func:`make_env` makes one, with a clear error for an unknown id.
"""

from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, ENVIRONMENTS, make_env, register_envs

register_envs()

__all__ = ["ENV_OF_JOINT_TYPE", "ENVIRONMENTS", "make_env", "register_envs"]
