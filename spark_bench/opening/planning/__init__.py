"""The opening task's physical side, below :mod:`spark_bench.envs`: the grasp planner (``grasp``, with the
part features, pads, handles, handle search, flat fronts and rest meshes it reads), the end-effectors
(``gripper``, ``suction``), the compiled ``scene`` of an opening task and its ``drive_check``.
"""
