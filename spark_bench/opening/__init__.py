"""The opening score: can a robot open each drawer, door and lid of an object with the joint a method
predicted?

Two layers, so that the environments of :mod:`spark_bench.envs` sit between them:

- :mod:`spark_bench.opening.planning` (below :mod:`spark_bench.envs`): what the hand can do with a part: where
  to grasp it (``grasp`` and the handle, pad and plate finders it calls), the two end-effectors (the parallel
  ``gripper``, the ``suction`` cup), the compiled ``scene`` of an opening task and its ``drive_check`` (can the
  end-effector open the part at all).
- this package's own modules (above :mod:`spark_bench.envs`): the scripted opener (``opener``, the
  cup's ``suction_opener``, the door's edge in ``door_geometry``; ``episodes`` runs one for an environment)
  and the opening score's judge (``judge``:
  which ground-truth joints are tests, the reference episode, the coverage; ``pairing``: predicted joints
  in the ground truth's metres).

Following a ground-truth folder from ``eval``: :mod:`spark_bench.evaluation` -> :mod:`.judge` ->
:mod:`spark_bench.envs` (the environment) -> :mod:`.planning` (its scene), then back to :mod:`.episodes`
(:mod:`.opener`), which drives the environment. This ``__init__`` imports nothing, so that importing
:mod:`spark_bench.opening.planning` from the environments loads none of the upper layer.
"""
