"""What the hand can do with a part, below :mod:`spark_bench.envs`: the grasp planner (``grasp``, with the
part features, pads, handles, handle search, flat fronts and rest meshes it reads), the end-effectors
(``end_effector``, the parallel ``gripper``, the ``suction`` cup), the opening ``task`` built and its compiled
``scene``, and the ``drive_check`` (can the end-effector open the part at all). The environments simulate
the scene; the scripted opener and the opening score's judge (:mod:`spark_bench.opening`) sit above them.
"""
