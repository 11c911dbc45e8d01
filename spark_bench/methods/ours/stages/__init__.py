"""The stages of ``ours`` and their backends: per stage, one registry of small classes by configured name.

- structure prior (:mod:`.prior`, :data:`PRIOR_BACKENDS`): ``annotation`` | ``vlm`` | ``file`` | ``retrieval``
- part geometry (:mod:`.geometry`, :data:`GEOMETRY_BACKENDS`): ``annotation`` | ``predictions`` | ``spark``
  | ``retrieval``
- open-state image (:mod:`.open_state`, :data:`OPEN_STATE_BACKENDS`): ``dataset`` | ``http``
- joint optimization (:mod:`.joint_opt`, :data:`OPTIMIZERS`): ``spark`` | ``native``, the latter after a
  refinement (:mod:`.refinements`, :data:`REFINEMENTS`): ``render`` | ``vlm`` | ``none``

What a backend declares is :class:`~.base.StageBackend`'s; a new backend is one class in its stage's
module (or anywhere, registered with the stage's decorator before the configuration is read).
"""

from spark_bench.methods.ours.stages.base import CaseRun, Registry, StageBackend
from spark_bench.methods.ours.stages.geometry import GEOMETRY_BACKENDS, GeometryBackend
from spark_bench.methods.ours.stages.joint_opt import OPTIMIZERS, JointOptimizer, OptimizeOutcome
from spark_bench.methods.ours.stages.open_state import OPEN_STATE_BACKENDS, OpenStateBackend
from spark_bench.methods.ours.stages.prior import PRIOR_BACKENDS, PriorAnswer, PriorBackend
from spark_bench.methods.ours.stages.refinements import REFINEMENTS, Refinement

__all__ = ["GEOMETRY_BACKENDS", "OPEN_STATE_BACKENDS", "OPTIMIZERS", "PRIOR_BACKENDS", "REFINEMENTS",
           "CaseRun", "GeometryBackend", "JointOptimizer", "OpenStateBackend", "OptimizeOutcome",
           "PriorAnswer", "PriorBackend", "Refinement", "Registry", "StageBackend"]
