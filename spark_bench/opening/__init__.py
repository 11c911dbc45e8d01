"""The opening score: can a robot open each drawer, door and lid of an object with the joint a method
predicted?

This package sits above the environments of :mod:`spark_bench.envs`, which simulate the scenes of
:mod:`spark_bench.manipulation` (the grasp planner, the end-effectors, the opening task's scene and its drive
check): the scripted opener (``opener``, the cup's ``suction_opener``, the door's edge in ``door_geometry``;
``episodes`` runs one for an environment) and the opening score's judge (``judge``: which ground-truth joints
are tests, the reference episode, the coverage; ``pairing``: predicted joints in the ground truth's metres).

Following a ground-truth folder from ``eval``: :mod:`spark_bench.evaluation` -> :mod:`.judge` (the grasp
planned once, :mod:`spark_bench.manipulation`) -> :mod:`spark_bench.envs` (the environment, given that plan,
compiles its scene), then :mod:`.episodes` (:mod:`.opener`), which drives the environment.
"""
