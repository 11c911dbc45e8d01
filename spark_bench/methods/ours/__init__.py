"""``--method ours``: SPARK (paper section 3) as a pipeline of interchangeable stage backends.

The method (:mod:`.method`: :class:`OursMethod`, what the registry builds) runs :func:`run_ours`:

1. structure prior (:mod:`.structure`, :mod:`.vlm`, :mod:`.prior`, :mod:`.retrieved`): ``annotation`` |
   ``vlm`` | ``file`` | ``retrieval``
2. part geometry (:mod:`.geometry`, :mod:`.retrieved`): ``annotation`` | ``predictions`` | ``spark`` |
   ``retrieval`` (one retrieval serves both stages)
3. open-state image (:mod:`.open_state`): ``dataset`` | ``http``
4. joint optimization: ``spark``, SPARK's own recipe (:mod:`.spark_fit`), or ``native`` (:mod:`.optimize`,
   :mod:`.refine`, :mod:`.render`, :mod:`.simplify`, differentiable FK from :mod:`spark_bench.asset.torch_fk`)
5. export (:mod:`.pipeline`): PartNet-Mobility object folders

Each backend is one small class in its stage's module of :mod:`.stages` (a registry per stage), which
says what it reads of the case, whether that is the ground truth, its part of the label, the settings it
requires, and runs the stage; a new backend is one more class there.

Configuration: :mod:`.config` (the sections and their defaults), :mod:`.config_parse` (reading them).
SPARK's own code, run on a machine that has it: :mod:`.run_spark` (its stage scripts per case, the
``spark`` geometry backend's usual command) and :mod:`.commands` (``spark-bench run-spark``); what it
writes is read by :mod:`spark_bench.formats.spark`.
Every name below is loaded on first use, so that the registry, or reading a configuration, does not
import torch.
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {"OursMethod": "spark_bench.methods.ours.method",
                                               "ours_case": "spark_bench.methods.ours.method",
                                               "SparkConfig": "spark_bench.methods.ours.config",
                                               "run_ours": "spark_bench.methods.ours.pipeline"})
