"""Gymnasium environments for opening articulated objects: ``SparkDrawer-v0`` and ``SparkDoor-v0``.

``import spark_bench`` registers them (:mod:`spark_bench.envs.registration`); MuJoCo is imported only when
one is made. :func:`make_env` makes one, with a clear error for an unknown id.
"""

from spark_bench.envs.registration import ENV_OF_JOINT_TYPE, ENVIRONMENTS, make_env, register_envs

__all__ = ["ENV_OF_JOINT_TYPE", "ENVIRONMENTS", "make_env", "register_envs"]
